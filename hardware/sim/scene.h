// SPDX-License-Identifier: GPL-3.0-or-later
//
// The simulated world as data: geometry, materials, lights, the projector,
// the camera rig, the sensor, timing and faults. Scenes are JSON files (see
// hardware/sim/scenes/*.json and ParseScene below for the schema).
//
// Units and frames:
//   - lengths in millimetres, times in seconds;
//   - radiance in cd/m^2 (photometric, per RGB channel), illuminance in lux,
//     point-light and projector intensities in candela;
//   - the world frame is the frame of the camera at stage position 0 when
//     the rig pose is the identity (the default): x to the right, y down,
//     z forward (the OpenCV camera convention). The stage moves the camera
//     along +x, so the "right" view is at a larger stage position.
#ifndef HDRSTEREO_HARDWARE_SIM_SCENE_H_
#define HDRSTEREO_HARDWARE_SIM_SCENE_H_

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace hdrstereo::sim {

using Vec3 = cv::Vec3d;
using Mat3 = cv::Matx33d;
// Colours and albedos are RGB in the scene model; images are BGR (OpenCV).
using Rgb = cv::Vec3d;

enum class TextureKind { kUniform, kChecker, kNoise };

// A texture varies the albedo over the surface coordinates (u, v) in mm.
struct Texture {
  TextureKind kind = TextureKind::kUniform;
  Rgb second_albedo{0.1, 0.1, 0.1};  // checker: odd squares; noise: the 1-end
  double square_mm = 50.0;           // checker square size
  double scale_mm = 20.0;            // noise feature size (finest octave)
  int octaves = 3;                   // noise octaves (each twice as coarse)
  uint64_t seed = 1;                 // noise seed
};

struct Material {
  Rgb albedo{0.5, 0.5, 0.5};  // Lambertian reflectance in [0, 1]
  Texture texture;
  Rgb emission{0, 0, 0};  // emitted radiance, cd/m^2 (lamps)
};

enum class ShapeKind { kPlane, kBox, kSphere };

struct Object {
  std::string name;
  ShapeKind shape = ShapeKind::kPlane;
  // Plane: a point on the plane (texture origin, centre of a finite plane).
  // Box and sphere: the centre.
  Vec3 center{0, 0, 0};
  Vec3 normal{0, 0, -1};  // plane only; unit length
  Vec3 u_axis{1, 0, 0};   // plane only; unit, perpendicular to normal
  cv::Vec2d size{0, 0};   // plane only: extent along u and v; 0 = infinite
  Vec3 box_size{100, 100, 100};  // box only: full edge lengths (local x, y, z)
  Mat3 rotation = Mat3::eye();   // box only: local-to-world rotation
  double radius = 100.0;         // sphere only
  Material material;
  bool casts_shadow = true;  // emitters default to false
};

struct PointLight {
  Vec3 position{0, 0, 0};
  double intensity_cd = 100.0;
  Rgb color{1, 1, 1};
};

// The projector is a light source with a pinhole model: a pattern pixel
// (col, row) emits towards the points that project onto it.
struct ProjectorModel {
  bool present = false;
  Vec3 position{0, 0, 0};
  Mat3 rotation = Mat3::eye();  // projector-to-world (x right, y down, z out)
  int width = 1024;
  int height = 768;
  double fov_deg = 30.0;            // horizontal field of view
  double max_intensity_cd = 500.0;  // intensity of a full-white pixel
  double black_level = 0.02;        // fraction of max emitted for value 0
  double gamma = 2.2;               // emitted = black + (1-black) * v^gamma
  double blur_px = 0.0;             // defocus: Gaussian sigma in pattern px
  // Input latency: a pattern shows this long after the projector was given
  // it, the previous one until then. Modelled time, like TimingModel's
  // durations (it lasts latency_s * timing.scale).
  double latency_s = 0.0;
  // The display's refresh rate, as a projector on an X display reports it
  // (XRandR).
  double refresh_hz = 60.0;

  double focal_px() const;
  double cx() const { return (width - 1) / 2.0; }
  double cy() const { return (height - 1) / 2.0; }
};

struct CameraIntrinsics {
  int width = 1200;
  int height = 900;
  double fx = 1600.0;
  double fy = 1600.0;
  double cx = 599.5;
  double cy = 449.5;
};

// Where the camera is for a stage position s:
//   centre(s) = origin + s * stage_axis        (world)
//   camera-to-world rotation = camera_rotation
// An ideal rig has stage_axis equal to the camera's x axis, so a stage move
// is a pure x translation and disparity = f * B / Z exactly.
struct RigModel {
  Vec3 origin{0, 0, 0};
  Mat3 rotation = Mat3::eye();  // rig-to-world
  double travel_mm = 150.0;     // stage travel (positions 0 .. travel_mm)
  // Misalignment (all 0 for an ideal rig): the stage axis in the rig frame is
  // normalize(1, axis_dy_per_mm, axis_dz_per_mm); the camera is rolled about
  // its optical axis by camera_roll_deg.
  double axis_dy_per_mm = 0.0;
  double axis_dz_per_mm = 0.0;
  double camera_roll_deg = 0.0;

  Vec3 StageAxis() const;       // unit, world frame
  Mat3 CameraRotation() const;  // camera-to-world
  Vec3 CameraCenter(double stage_mm) const;
  bool IsIdeal() const;
};

enum class ResponseKind { kLinear, kGamma, kSCurve };

// Camera response: normalised sensor signal x in [0, 1] (1 = full well) to
// normalised pixel value in [0, 1]. Strictly increasing, f(0)=0, f(1)=1.
//   linear: x;  gamma: x^(1/gamma);
//   s_curve: y = x^(1/gamma), f = y^c / (y^c + (1-y)^c) with c = contrast
//   (an S around mid-grey in gamma space; not a pure power law).
struct ResponseCurve {
  ResponseKind kind = ResponseKind::kSCurve;
  double gamma = 2.2;
  double contrast = 1.6;

  double Evaluate(double x) const;
  // The x with Evaluate(x) == y (bisection; for tests and calibration).
  double Inverse(double y) const;
};

struct SensorModel {
  // Electrons per (cd/m^2 * s) at ISO 100; the signal scales with ISO/100.
  double electrons_per_exposure = 3333.0;
  double full_well_e = 20000.0;
  double read_noise_e = 4.0;  // Gaussian, standard deviation in electrons
  bool shot_noise = true;     // Poisson (Gaussian approximation) photon noise
  ResponseCurve response;     // applied to 8-bit output
  ResponseCurve raw_response{ResponseKind::kLinear, 1.0, 1.0};  // 16-bit
  int raw_white_level = 16383;  // Bayer DNG white level (14-bit)
};

// Modelled durations; every sleep is multiplied by `scale` (0 = instant,
// 1 = real time).
struct TimingModel {
  double scale = 0.0;
  double readout_s = 0.25;  // sensor readout after the exposure
  double transfer_s = 0.5;  // download of the file to the host
  double stage_speed_mm_s = 20.0;
  double stage_accel_mm_s2 = 100.0;
  double projector_settle_s = 0.1;

  // Exposure + readout + transfer (unscaled).
  double CaptureSeconds(double exposure_s) const;
  // Trapezoidal (or triangular) profile for a move of `distance_mm`.
  double MoveSeconds(double distance_mm) const;
  // Distance covered `t_s` seconds into a move of `distance_mm` (>= 0).
  double MoveProgressMm(double distance_mm, double t_s) const;
};

// A fault fires on the listed 1-based call numbers, and otherwise with
// `probability` per call (drawn from the scene's seeded generator).
struct FaultTrigger {
  std::vector<int> calls;
  double probability = 0.0;
  bool enabled() const { return !calls.empty() || probability > 0.0; }
};

// A fault that comes and goes: it begins on a call `begins` fires on and
// holds on `lasts` calls from there, that one included (a call that begins
// it again while it holds extends it). Which calls count is said where
// each window is used; calls are counted, not seconds, so that a test does
// not depend on the machine's speed.
struct FaultWindow {
  FaultTrigger begins;
  int lasts = 1;
};

struct CameraFaults {
  int busy_first_calls = 0;  // the first N capture calls fail with "busy"
  FaultTrigger timeout;      // DEADLINE_EXCEEDED, nothing delivered
  FaultTrigger disconnect;   // ABORTED mid-transfer; later calls fail
                             // until the camera is reopened
  // After a disconnect, how many reopen attempts (SimWorld::ReopenCamera)
  // fail before one succeeds; -1: none succeeds (the camera never comes
  // back; SimWorld::ReconnectCamera() still plugs it in).
  int disconnect_failed_reopens = -1;
  // The camera is not plugged in when the world starts: every camera call
  // fails as after a disconnect, and a reopen finds it only once the file
  // at this path exists (the test creates it). "" = plugged in from the
  // start.
  std::string absent_until_file;
  FaultTrigger corrupt;  // the delivered file has flipped bytes
  // Faults that corrupt a dataset without an error (the camera "works"):
  FaultTrigger previous_file;   // delivers the previous file again and keeps
                                // the new one pending: every later frame is
                                // one behind until the pending files are
                                // drained (SimWorld::PrepareCaptureGroup)
  FaultTrigger wrong_exposure;  // exposes twice as long as set (EXIF says so)
  FaultTrigger wrong_depth;     // a PNG or TIFF file of the other bit depth
                                // (16 bits for 8, 8 for 16), as from a
                                // camera whose TIFF is 8-bit
  FaultTrigger card_target;     // the capture target switches to the card
                                // until PrepareCaptureGroup sets RAM again
  // Not a camera fault but a test's handle on a moment: the capture call
  // waits, before it exposes, until a byte (or end of file) can be read from
  // the FIFO `hold_fifo`. A test's open of the FIFO for writing returns once
  // the camera is held, so the test acts between a capture job's checks at
  // the frame boundary and the frame's write; its write releases the camera.
  FaultTrigger hold;
  std::string hold_fifo;  // required with `hold`
  // The battery is low for a while: calls are battery readings (each
  // Camera::Info), which report `low_battery_percent` while the window
  // holds and 100 otherwise.
  FaultWindow low_battery;
  int low_battery_percent = 5;
  // Faults only the network camera (ptpip_camera.h) shows, on its captures
  // counted from 1 (scene file: faults.camera.ptpip):
  struct PtpIp {
    // Both connections close halfway through the file's transfer.
    FaultTrigger drop_in_transfer;
    // The file trickles out: its transfer takes slow_transfer_s (modelled
    // time, times timing.scale), in pauses of at most 1 s.
    FaultTrigger slow_transfer;
    double slow_transfer_s = 3;
    // The store is full: a StoreFull event instead of ObjectAdded.
    FaultTrigger store_full;
  } ptpip;
};

struct StageFaults {
  FaultTrigger silent;   // the command gets no reply at all
  FaultTrigger garbled;  // the reply's bytes are scrambled
  FaultTrigger stall;    // a move command never finishes (BUSY until stop)
  std::string warning_flag = "--";  // e.g. "FS", "WL": shown on every reply
  // A warning that comes and goes (e.g. "WH", temperature high): calls are
  // the commands addressed to the device, on whose replies (and in
  // `warnings`) `warning_window_flag` shows while the window holds. It
  // cannot be cleared.
  FaultWindow warning_window;
  std::string warning_window_flag = "WH";
};

struct ProjectorFaults {
  // The projector is lost for a while (its display gone, its cable
  // pulled): it begins on the Nth Show or Blank (`begins` counts only
  // those) and holds on `lasts` calls to the projector (Show, Blank and
  // Check: the first is the one that fails). While lost, every call fails
  // with UNAVAILABLE and nothing is projected; back, it shows black.
  FaultWindow lost;
};

// Where the operator holds the calibration board for one pose: the board's
// objects rotated by `rotation` about the first one's centre (as placed in
// the scene file), then moved by `offset`.
struct BoardPose {
  Vec3 offset{0, 0, 0};
  Mat3 rotation = Mat3::eye();
};

// A calibration board the simulated operator moves between poses: the
// objects (planes, e.g. the chessboard and its white border) that move
// together, and the poses in the order a calibration capture asks for them.
struct CalibrationBoard {
  std::vector<int> objects;  // indices into Scene::objects
  std::vector<BoardPose> poses;
};

struct Scene {
  std::string name;
  std::string description;
  uint64_t seed = 1;  // noise and fault generators
  CameraIntrinsics camera;
  RigModel rig;
  SensorModel sensor;
  Rgb ambient_lux{0, 0, 0};
  std::vector<Object> objects;
  std::vector<PointLight> lights;
  ProjectorModel projector;
  TimingModel timing;
  CameraFaults camera_faults;
  StageFaults stage_faults;
  ProjectorFaults projector_faults;
  CalibrationBoard calibration_board;  // no poses: the board never moves

  // Index of the object called `name`, or -1.
  int FindObject(absl::string_view name) const;
};

// Parses a scene from JSON text. Errors are INVALID_ARGUMENT and name the
// offending field, e.g. "objects[2].material.albedo: expected 3 numbers".
// Unknown fields are errors too (they are usually typos). Scenes are shared
// between labs: the text (at most 1 MiB) and every size and count in it
// are bounded before they are used (the limits and their reasons are in
// scene.cc), and messages quote what they received bounded.
absl::StatusOr<Scene> ParseScene(absl::string_view json_text);
// The same for a file, refused by its size before it is read, its path in
// front of the errors (NOT_FOUND when there is none).
absl::StatusOr<Scene> LoadSceneFile(const std::filesystem::path& path);
// The scenes compiled into the library: lab-lamp, textured, checkerboard,
// shadowed.
std::vector<std::string> BundledSceneNames();
absl::StatusOr<Scene> LoadBundledScene(absl::string_view name);
// A bundled scene name, or else a path to a JSON file.
absl::StatusOr<Scene> LoadScene(absl::string_view name_or_path);

// The scene with its calibration board in pose `pose` (0-based, taken
// modulo the number of poses). INVALID_ARGUMENT for a scene without board
// poses or a negative pose.
absl::StatusOr<Scene> WithBoardPose(const Scene& scene, int pose);

// The same camera at another resolution: `width` pixels wide, the height
// keeping the aspect ratio (rounded), the focal lengths scaled alike and the
// principal point at the centre. Tests and tools render small to be quick.
void ScaleCamera(Scene& scene, int width);

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_SCENE_H_
