// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/jobs/capture_job.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <future>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "absl/cleanup/cleanup.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "daemon/jobs/device_log.h"
#include "daemon/jobs/frame_boundary.h"
#include "daemon/jobs/frame_check.h"
#include "daemon/jobs/metering.h"
#include "daemon/jobs/projector_probe.h"
#include "daemon/jobs/rig_calibration.h"
#include "daemon/store/frame_repository.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/capture_layout.h"
#include "processing/io/image.h"
#include "processing/io/sha256.h"

namespace hdrstereo::jobs {
namespace {

namespace fs = std::filesystem;
namespace sl = structured_light;

// A frame whose write finds the disk full this often in a row, each time
// without a suspension (the disk condition said the rest fits), fails the
// job: the estimate or the margin does not suit this filesystem, and the
// camera would otherwise be fired again and again.
constexpr int kMaxDiskFullWrites = 3;

// Frames already recorded for this capture whose files are intact, by
// sequence. Rows whose file is missing or differs are deleted (the frame is
// taken again) and reported.
absl::StatusOr<std::map<int, store::FrameRecord>> VerifiedFrames(
    store::FrameRepository& frames, int64_t capture_id,
    const fs::path& session_dir, JobContext& context) {
  ASSIGN_OR_RETURN(std::vector<store::FrameRecord> recorded,
                   frames.FramesOfCapture(capture_id));
  std::map<int, store::FrameRecord> good;
  for (store::FrameRecord& frame : recorded) {
    absl::StatusOr<std::string> sha =
        io::Sha256HexOfFile(session_dir / frame.path);
    if (sha.ok() && *sha == frame.sha256) {
      good.emplace(frame.sequence, std::move(frame));
      continue;
    }
    context.Warn(absl::StrCat(
        "frame ", frame.path,
        sha.ok() ? " does not match its recorded sha256" : " is missing",
        "; taking it again"));
    RETURN_IF_ERROR(frames.Delete(frame.id));
  }
  return good;
}

// Files under the capture's folder that no frame row references were left
// by a crash between writing a file and recording it: remove them.
absl::Status RemoveUnrecordedFiles(
    const fs::path& session_dir, int64_t capture_id,
    const std::map<int, store::FrameRecord>& good) {
  std::set<fs::path> keep;
  for (const auto& [sequence, frame] : good) keep.insert(frame.path);
  const fs::path root = session_dir / io::CaptureDir(capture_id);
  std::error_code ec;
  if (!fs::exists(root, ec)) return absl::OkStatus();
  std::vector<fs::path> doomed;
  for (auto it = fs::recursive_directory_iterator(root, ec);
       !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (it->is_regular_file() &&
        !keep.contains(fs::relative(it->path(), session_dir))) {
      doomed.push_back(it->path());
    }
  }
  for (const fs::path& path : doomed) fs::remove(path, ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat("cannot clean ", root.string(), ": ", ec.message()));
  }
  return absl::OkStatus();
}

// What a recorded frame said of itself when it was taken.
CameraReport ReportOf(const store::FrameRecord& frame) {
  CameraReport report;
  report.exposure_s = frame.camera_exposure_s;
  report.iso = frame.iso;
  report.aperture_f = frame.aperture_f;
  report.time_ms = frame.camera_time_ms;
  report.file_name = frame.camera_file_name;
  report.sha256 = frame.sha256;
  return report;
}

std::string Describe(const FrameSpec& spec, int views) {
  std::string what = io::FrameRoleName(spec.role);
  if (spec.pattern.has_value()) {
    what = absl::StrCat("pattern ", spec.pattern->Id(),
                        spec.pattern->inverse ? " inverse" : "");
  }
  return absl::StrFormat("%s view, %s, %s",
                         io::ViewName(spec.view_index, views), what,
                         io::ExposureTag(spec.exposure_s));
}

int ViewsOf(const v1::CapturePlan& plan) {
  switch (plan.plan_case()) {
    case v1::CapturePlan::kBracketedStereo:
      return plan.bracketed_stereo().views();
    case v1::CapturePlan::kStructuredLight:
      return plan.structured_light().views();
    default:
      return 2;
  }
}

// Drops a recorded frame (row and file), e.g. the left view of a
// calibration pose whose right view did not show the board.
absl::Status DropFrame(store::FrameRepository& frames, int64_t capture_id,
                       int sequence, const std::filesystem::path& session_dir) {
  ASSIGN_OR_RETURN(std::vector<store::FrameRecord> recorded,
                   frames.FramesOfCapture(capture_id));
  for (const store::FrameRecord& frame : recorded) {
    if (frame.sequence != sequence) continue;
    RETURN_IF_ERROR(frames.Delete(frame.id));
    std::error_code ec;
    std::filesystem::remove(session_dir / frame.path, ec);
  }
  return absl::OkStatus();
}

absl::Status FinishPending(std::future<absl::Status>& pending) {
  if (!pending.valid()) return absl::OkStatus();
  return pending.get();
}

// Checks that it decodes, writes (atomically) and records one frame (hashed
// already); the row and the progress it advances are one transaction.
absl::Status PersistFrame(JobContext& context, store::FrameRepository& frames,
                          const std::string& session, store::FrameRecord record,
                          const std::string& bytes, int64_t done, int64_t total,
                          const std::string& step) {
  if (record.format != hardware::ImageFormat::kRaw) {
    // A transfer that arrived damaged usually no longer decodes.
    absl::StatusOr<cv::Mat> decoded =
        io::DecodeWithOpenCv(bytes, cv::IMREAD_UNCHANGED);
    if (!decoded.ok()) {
      return store::WithEventKind(
          absl::DataLossError(absl::StrCat(
              "frame ", record.path, " arrived corrupt from the camera (",
              decoded.status().message(),
              "); resubmit the capture to take it again")),
          store::EventKind::kCorrupt);
    }
    // A 16-bit format must decode to 16 bits, the others to 8: a camera
    // that sends other files than asked is not taken at its word.
    const int want =
        record.format == hardware::ImageFormat::kTiff16 ? CV_16U : CV_8U;
    if (decoded->depth() != want) {
      return absl::FailedPreconditionError(absl::StrCat(
          "frame ", record.path, " decodes to ",
          cv::typeToString(decoded->type()), " pixels, but its format ",
          hardware::ImageFormatName(record.format), " is ",
          want == CV_16U ? "16" : "8",
          "-bit; set the camera to the format the capture asks for"));
    }
    record.width_px = decoded->cols;
    record.height_px = decoded->rows;
  }
  RETURN_IF_ERROR(
      context.store().files().WriteSessionFile(session, record.path, bytes));
  absl::Status recorded = context.Progress(
      done, total, step, [&] { return frames.InsertLocked(record); });
  if (!recorded.ok()) {
    // No file without its row (e.g. the database could not grow).
    std::error_code ec;
    fs::remove(context.store().files().SessionDir(session) / record.path, ec);
  }
  return recorded;
}

}  // namespace

absl::StatusOr<RigLimits> LimitsOf(const hardware::Rig& rig) {
  if (rig.stage() == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("no stage: ", rig.stage_error().message()));
  }
  RigLimits limits;
  limits.travel_mm = rig.stage()->travel_mm();
  limits.home_position_mm = rig.config().home_position_mm;
  if (rig.projector() != nullptr) {
    limits.projector_size = rig.projector()->resolution();
    limits.projector_refresh_hz = rig.projector()->RefreshHz().value_or(0);
  }
  return limits;
}

absl::Status CheckDevicesFor(const v1::CapturePlan& plan,
                             const hardware::Rig& rig) {
  if (rig.camera() == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("no camera: ", rig.camera_error().message()));
  }
  if (rig.stage() == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("no stage: ", rig.stage_error().message()));
  }
  if (plan.has_structured_light() && rig.projector() == nullptr) {
    return absl::FailedPreconditionError(
        absl::StrCat("structured light needs the projector: ",
                     rig.projector_error().message()));
  }
  return absl::OkStatus();
}

absl::Status RunCaptureJob(hardware::Rig& rig, JobContext& context,
                           const TruthWriter& write_truth,
                           const CaptureConditions& conditions,
                           const BoardPlacer& place_board) {
  const DiskGuard* disk = conditions.disk;
  const store::JobRecord& job = context.job();
  v1::CapturePlan plan;
  if (!plan.ParseFromString(job.request)) {
    return absl::DataLossError("the job's capture plan cannot be read");
  }
  RETURN_IF_ERROR(CheckDevicesFor(plan, rig));
  ASSIGN_OR_RETURN(RigLimits limits, LimitsOf(rig));

  // The hardware is ours until the job ends.
  std::unique_lock<std::mutex> lane(rig.lane());
  hardware::Camera& camera = *rig.camera();
  hardware::Stage& stage = *rig.stage();
  hardware::Projector* projector = rig.projector();
  // Structured light needs the projector: a lost one is waited for.
  hardware::Projector* const watched_projector =
      plan.has_structured_light() ? projector : nullptr;

  store::FrameRepository frames(context.store());
  ASSIGN_OR_RETURN(const io::CaptureKind kind, PlanKind(plan));
  ASSIGN_OR_RETURN(store::CaptureRecord capture,
                   frames.CaptureForJob(job.id, kind, job.request));
  const fs::path session_dir = context.store().files().SessionDir(job.session);

  // Whatever happens, leave the hardware safe.
  bool moved = false;
  absl::Cleanup safe = [&] {
    if (projector != nullptr) projector->Blank().IgnoreError();
    if (moved) stage.Stop().IgnoreError();
  };

  // Every device call is timed, and its error marked with its kind.
  DeviceLog devices(context.store(), job.id);
  // Structured light: the projector's refresh rate and (probed if the plan
  // asks) latency, recorded with the capture; each pattern is waited for.
  absl::Duration pattern_wait;
  if (plan.has_structured_light()) {
    auto prepare = [&] {
      return PrepareProjectorTiming(plan.structured_light(), camera, *projector,
                                    context, frames, capture.id);
    };
    if (!plan.structured_light().has_projector_probe()) {
      // Only the display's refresh rate is read: no camera call.
      ASSIGN_OR_RETURN(pattern_wait, prepare());
    } else {
      // The probe takes frames: at a frame boundary, as a frame.
      Attempts attempts(context, "measuring the projector's timing",
                        "it is measured again", "no frame was taken");
      ASSIGN_OR_RETURN(pattern_wait, TakeBeforeFrames<absl::Duration>(
                                         context, camera, attempts,
                                         [&] {
                                           return BlockingCondition(
                                               conditions, camera, stage,
                                               watched_projector, {}, devices);
                                         },
                                         conditions.poll, [] {}, prepare));
    }
  }
  const BaseSettings base = SettingsOf(plan);
  // The stage is homed before it is next placed when it is not homed (or
  // does not say), after a suspension and after a fault of its own (its
  // position may be off): at a frame, after that boundary's checks, so that
  // a fault of the homing is one of that frame's, taken again with it.
  const absl::StatusOr<hardware::StageState> state =
      devices.Time(store::Device::kStage, [&] { return stage.State(); });
  bool home_first = !state.ok() || !state->homed;
  double position = std::nan("");
  // Puts the stage at `target_mm`, homing it first where it must be.
  auto place_stage = [&](double target_mm) -> absl::Status {
    if (home_first) {
      moved = true;
      RETURN_IF_ERROR(InStep(
          "homing the stage",
          devices.Sample(store::Device::kStage, [&] { return stage.Home(); })));
      home_first = false;
      position = std::nan("");
    }
    if (std::abs(position - target_mm) < 1e-6) return absl::OkStatus();
    moved = true;
    RETURN_IF_ERROR(
        InStep(absl::StrFormat("moving the stage to %.3f mm", target_mm),
               devices.Sample(store::Device::kStage,
                              [&] { return stage.MoveTo(target_mm); })));
    position = target_mm;
    if (base.settle_s > 0) devices.Wait(absl::Seconds(base.settle_s));
    return absl::OkStatus();
  };
  if (ChoosesExposuresAtTheRig(plan)) {
    // After a suspension or a fault the stage may be off: home it again.
    auto home_again = [&] {
      home_first = true;
      position = std::nan("");
    };
    ASSIGN_OR_RETURN(
        plan, ChooseExposures(context, frames, capture, camera, stage,
                              projector, devices, conditions, place_stage,
                              home_again, plan, limits, base));
  }
  const std::vector<FrameSpec> specs = ExpandPlan(plan, limits, capture.id);
  absl::StatusOr<std::map<int, store::FrameRecord>> done =
      VerifiedFrames(frames, capture.id, session_dir, context);
  if (!done.ok()) return done.status();
  RETURN_IF_ERROR(RemoveUnrecordedFiles(session_dir, capture.id, *done));
  const bool calibration = plan.has_calibration();
  const int poses = calibration ? plan.calibration().poses() : 0;
  const calib::BoardSpec board =
      calibration ? BoardOf(plan.calibration()) : calib::BoardSpec();
  if (calibration) {
    // A pose left half taken (the daemon stopped between its views) is
    // taken again whole: the board may have moved meanwhile.
    for (int pose = 0; pose < poses; ++pose) {
      const int left = specs[2 * pose].sequence;
      const int right = specs[2 * pose + 1].sequence;
      if (done->contains(left) && !done->contains(right)) {
        RETURN_IF_ERROR(DropFrame(frames, capture.id, left, session_dir));
        done->erase(left);
        context.Info(absl::StrCat("pose ", pose + 1, " of ", poses,
                                  " was half taken; it is taken again"));
      }
    }
  }
  const int64_t total = static_cast<int64_t>(specs.size());
  int64_t count = static_cast<int64_t>(done->size());
  RETURN_IF_ERROR(context.Progress(
      count, total,
      count > 0 ? absl::StrCat("resuming: ", count, " frames already recorded")
                : "preparing the rig"));
  double exposure = std::nan("");
  hardware::ExposureSettings in_effect;  // as Configure last returned them
  // Every frame is checked against the camera's own report; frames
  // recorded before a restart count as already seen.
  FrameChecker checker;
  for (const auto& [sequence, frame] : *done) checker.Remember(ReportOf(frame));
  auto prepare_camera = [&]() -> absl::Status {
    ASSIGN_OR_RETURN(int discarded, devices.Time(store::Device::kCamera, [&] {
      return camera.PrepareCaptureGroup();
    }));
    if (discarded > 0) {
      context.Warn(absl::StrCat("discarded ", discarded,
                                " file(s) the camera still held from before"));
    }
    return absl::OkStatus();
  };
  // Pattern id on the projector, "" = blank; unknown at the start and after
  // a suspension (a projector that was lost may show anything).
  std::optional<std::string> showing;
  const int views = ViewsOf(plan);
  // Done before the first frame, and again after the camera came back.
  bool camera_prepared = false;
  // After a transient device fault (`attempts` says whether there is to be
  // another try), everything is done again: the stage homed (after a fault
  // of its own) and moved, the pattern shown, the exposure set, the camera
  // prepared (after a fault of its own).
  auto take_again = [&](Attempts& attempts,
                        const absl::Status& fault) -> absl::Status {
    RETURN_IF_ERROR(attempts.Retry(fault));
    const std::optional<store::Device> device =
        store::DeviceOf(store::EventKindOf(fault));
    home_first = home_first || device == store::Device::kStage;
    camera_prepared = camera_prepared && device != store::Device::kCamera;
    position = std::nan("");
    showing.reset();
    exposure = std::nan("");
    return absl::OkStatus();
  };

  // Time inside device calls versus the whole loop: the rest is the daemon's
  // own overhead (pattern rendering, hashing, writing, recording).
  const absl::Time loop_start = absl::Now();
  const absl::Duration devices_before_loop = devices.total();
  const int64_t first_count = count;
  // At most one frame is being written while the next is captured; it is
  // always finished before the job returns, whatever the outcome.
  std::future<absl::Status> pending;
  absl::Cleanup wait_for_pending = [&pending] {
    if (pending.valid()) pending.wait();
  };

  // The frames not written yet must fit with room to spare, checked before
  // each is taken: a disk found full by a failing write could not even
  // record the job's end. A write that finds the disk full all the same
  // (space taken between the check and the write) does not fail the job:
  // its frame is taken again, after the disk condition.
  FrameSizeEstimate frame_size;
  if (disk != nullptr) {
    ASSIGN_OR_RETURN(frame_size.before_first, disk->BytesPerFrame(kind));
    ASSIGN_OR_RETURN(frame_size.largest_so_far, disk->LargestFrame(capture.id));
  }
  // `count` includes the frame being written, which is not written yet.
  auto frames_left = [&] { return total - count + (pending.valid() ? 1 : 0); };
  size_t pending_index = 0;   // in specs, of the frame being written
  std::string write_failure;  // see DiskNeed
  int disk_full_in_a_row = 0;
  // Finishes the write in flight and returns where the frames go on: at
  // `next`, or, when the write found the disk full, at the frame it was for
  // (a frame taken since is dropped and taken again after it).
  auto finish_pending = [&](size_t next) -> absl::StatusOr<size_t> {
    const bool writing = pending.valid();
    absl::Status written = FinishPending(pending);
    if (!io::IsDiskFull(written)) {
      RETURN_IF_ERROR(written);
      if (writing) {
        write_failure.clear();
        disk_full_in_a_row = 0;
      }
      return next;
    }
    --count;
    write_failure =
        absl::StrCat("frame ", Describe(specs[pending_index], views),
                     " was not stored: ", written.message());
    if (++disk_full_in_a_row >= kMaxDiskFullWrites) {
      return absl::ResourceExhaustedError(absl::StrCat(
          write_failure, "; the disk was full at ", disk_full_in_a_row,
          " writes in a row although its free space held the rest of the "
          "plan (a user quota? a margin too small for this filesystem? "
          "raise --disk-margin-mb)"));
    }
    context.Warn(
        absl::StrCat(write_failure, "; it is taken again once there is room"));
    return pending_index;
  };
  // Calibration: the pose the operator was last asked for and continued
  // to (-1: none yet, or it must be asked for again), and what the next
  // instruction says first (why the pose is asked for again).
  int placed_pose = -1;
  std::string retry_note;
  for (size_t next = 0;;) {
    if (next == specs.size()) {
      ASSIGN_OR_RETURN(next, finish_pending(next));  // the last frame's write
      if (next == specs.size()) break;
    }
    const FrameSpec& spec = specs[next];
    if (done->contains(spec.sequence)) {
      ++next;
      continue;
    }
    const int pose = static_cast<int>(next / 2);
    if (calibration && placed_pose != pose) {
      // Before a pose: the previous one is recorded, then the operator
      // places the board and continues.
      ASSIGN_OR_RETURN(const size_t go_on, finish_pending(next));
      if (go_on != next) {
        next = go_on;
        continue;
      }
      // Live view shows the pose's first frame: the stage goes to it now.
      // A stage that fails here is dealt with by that frame's own attempts.
      place_stage(spec.stage_position_mm).IgnoreError();
      // The simulated operator places the board as asked, while the job
      // waits, as a person would.
      if (place_board != nullptr) {
        RETURN_IF_ERROR(InStep("placing the simulated calibration board",
                               place_board(pose)));
      }
      // The rig is let go meanwhile, for live view (Hardware.StreamPreview
      // allows a waiting job's rig and guides the board; other direct calls
      // still refuse it).
      lane.unlock();
      const absl::Status continued = context.WaitForOperator(
          absl::StrCat(retry_note, "place the board in pose ", pose + 1, " of ",
                       poses, " and continue"));
      lane.lock();
      RETURN_IF_ERROR(continued);
      retry_note.clear();
      placed_pose = pose;
    }
    // A frame still being written while the rest does not fit is finished
    // first: its write may have found the disk full, and then the
    // suspension names that and its frame is taken again.
    if (pending.valid() && disk != nullptr &&
        !disk->CheckRoomForRest(frames_left(), frame_size.bytes()).ok()) {
      ASSIGN_OR_RETURN(next, finish_pending(next));
      continue;
    }
    absl::StatusOr<hardware::Frame> frame;
    CameraReport report;
    // A frame whose camera dropped (a camera call failed and the camera
    // counts one more drop) is taken again once the camera is back: the
    // job suspends at this frame boundary until it is.
    // The same for a projector that was lost while its pattern was set.
    // A frame that met a transient device fault is taken again from its
    // start (take_again) at this boundary too, after its checks: a stage
    // that still does not answer, or shows a fault flag, suspends the job
    // there until it does.
    Attempts attempts(context, absl::StrCat("frame ", Describe(spec, views)),
                      "the frame is taken again from its start",
                      "nothing was recorded for it");
    for (int drops = 0, projector_losses = 0;;) {
      RETURN_IF_ERROR(context.Checkpoint());
      bool was_suspended = false;
      RETURN_IF_ERROR(context.SuspendWhile(
          [&] {
            std::string why =
                BlockingCondition(conditions, camera, stage, watched_projector,
                                  {.frames = frames_left(),
                                   .bytes_per_frame = frame_size.bytes(),
                                   .write_failure = write_failure},
                                  devices);
            was_suspended = was_suspended || !why.empty();
            return why;
          },
          conditions.poll));
      if (was_suspended) {
        disk_full_in_a_row = 0;
        // The stage may have been touched meanwhile: home it again.
        home_first = true;
        showing.reset();
      }
      if (absl::Status placed = place_stage(spec.stage_position_mm);
          !placed.ok()) {
        RETURN_IF_ERROR(take_again(attempts, placed));
        continue;
      }
      if (projector != nullptr) {
        const std::string wanted =
            spec.pattern.has_value()
                ? absl::StrCat(spec.pattern->Id(),
                               spec.pattern->inverse ? "i" : "")
                : "";
        if (wanted != showing) {
          ASSIGN_OR_RETURN(
              const cv::Mat image,
              spec.pattern.has_value()
                  ? sl::Render(*spec.pattern, projector->resolution())
                  : absl::StatusOr<cv::Mat>(cv::Mat()));
          const absl::Status shown =
              devices.Sample(store::Device::kProjector, [&] {
                return spec.pattern.has_value() ? projector->Show(image)
                                                : projector->Blank();
              });
          if (!shown.ok()) {
            // Not lost (the condition says so): a fault of this pattern.
            if (watched_projector == nullptr ||
                watched_projector->Check().ok()) {
              RETURN_IF_ERROR(take_again(
                  attempts,
                  InStep(wanted.empty()
                             ? std::string("blanking the projector")
                             : absl::StrCat("showing pattern ", wanted),
                         shown)));
              continue;
            }
            // Lost: waited for at this boundary, then the pattern is shown
            // again.
            if (++projector_losses > kMaxDropsPerFrame) {
              return absl::Status(
                  shown.code(),
                  absl::StrCat(
                      "frame ", Describe(spec, views),
                      ": the projector was lost ", projector_losses,
                      " times while taking it; last: ", shown.message()));
            }
            context.Warn(
                absl::StrCat("frame ", Describe(spec, views),
                             ": the projector was lost (", shown.message(),
                             "); the frame is taken again once it is back"));
            showing.reset();
            continue;
          }
          showing = wanted;
          if (pattern_wait > absl::ZeroDuration()) devices.Wait(pattern_wait);
        }
      }
      const int64_t drops_before = camera.Connection().drops;
      std::string camera_step;  // what the camera was doing when it failed
      absl::Status took = [&]() -> absl::Status {
        if (!camera_prepared) {
          camera_step = "preparing the camera";
          RETURN_IF_ERROR(prepare_camera());
          camera_prepared = true;
        }
        if (exposure != spec.exposure_s) {
          camera_step = absl::StrCat("setting the exposure to ",
                                     io::ExposureTag(spec.exposure_s));
          ASSIGN_OR_RETURN(
              hardware::ExposureSettings applied,
              devices.Time(store::Device::kCamera, [&] {
                return camera.Configure({.exposure_s = spec.exposure_s,
                                         .iso = base.iso,
                                         .aperture_f = base.aperture_f,
                                         .format = base.format});
              }));
          exposure = spec.exposure_s;
          in_effect = applied;
        }
        // Taken, then checked against what the camera reports; a frame that
        // does not match is taken once more (after re-preparing the camera)
        // before the job fails.
        std::optional<Mismatch> first_mismatch;
        for (int attempt = 0;; ++attempt) {
          camera_step = "capturing";
          frame = devices.Sample(store::Device::kCamera,
                                 [&] { return camera.Capture(); });
          if (!frame.ok()) return frame.status();
          report = ReadCameraReport(*frame);
          std::optional<Mismatch> mismatch = checker.Check(in_effect, report);
          if (!mismatch.has_value()) return absl::OkStatus();
          if (attempt > 0) {
            return store::WithEventKind(
                absl::DataLossError(absl::StrCat(
                    "frame ", Describe(spec, views),
                    " failed verification twice: ", first_mismatch->message,
                    "; then ", mismatch->message,
                    "; nothing was recorded for it")),
                mismatch->kind);
          }
          context.Warn(absl::StrCat("frame ", Describe(spec, views), ": ",
                                    mismatch->message, "; taking it again"),
                       store::EventTag(mismatch->kind));
          first_mismatch = std::move(mismatch);
          camera_step = "preparing the camera";
          RETURN_IF_ERROR(prepare_camera());
        }
      }();
      if (took.ok()) break;
      // Failed because the camera went away (or was away already)?
      if (!CameraDropped(camera, drops_before)) {
        // A frame that failed its verification twice ends the job as it is.
        if (store::FamilyOf(store::EventKindOf(took)) !=
            store::EventFamily::kDeviceError) {
          return took;
        }
        RETURN_IF_ERROR(take_again(attempts, InStep(camera_step, took)));
        continue;
      }
      // Nothing of this frame was recorded; the camera comes back with its
      // own settings and perhaps files from before.
      RETURN_IF_ERROR(
          OnCameraDrop(context, absl::StrCat("frame ", Describe(spec, views)),
                       "the frame is taken again", took, &drops));
      camera_prepared = false;
      exposure = std::nan("");
    }
    if (calibration) {
      if (const std::string missing = BoardMissing(*frame, board);
          !missing.empty()) {
        const std::string view = spec.view_index == 0 ? "left" : "right";
        context.Warn(absl::StrCat("pose ", pose + 1, " of ", poses,
                                  ": the board was not found in the ", view,
                                  " view (", missing,
                                  "); the pose is not kept"));
        if (spec.view_index == 1) {
          // Its left view is recorded (or being written): dropped.
          ASSIGN_OR_RETURN(const size_t go_on, finish_pending(next));
          if (go_on != next) {
            next = go_on;
            continue;
          }
          RETURN_IF_ERROR(DropFrame(frames, capture.id,
                                    specs[next - 1].sequence, session_dir));
          done->erase(specs[next - 1].sequence);
          --count;
          RETURN_IF_ERROR(context.Progress(
              count, total,
              absl::StrCat("pose ", pose + 1, " not kept: no board")));
          --next;
        }
        retry_note = absl::StrCat("the board was not found in the ", view,
                                  " view of pose ", pose + 1, "; ");
        placed_pose = -1;
        continue;
      }
    }
    checker.Remember(report);
    frame_size.Delivered(static_cast<int64_t>(frame->bytes.size()));

    store::FrameRecord record;
    record.capture_id = capture.id;
    record.sequence = spec.sequence;
    record.view_index = spec.view_index;
    record.stage_position_mm = spec.stage_position_mm;
    record.exposure_s =
        frame->exposure_s > 0 ? frame->exposure_s : spec.exposure_s;
    record.pattern = spec.pattern.has_value() ? spec.pattern->Id() : "";
    record.inverse = spec.pattern.has_value() && spec.pattern->inverse;
    record.format = frame->format;
    record.width_px = frame->width_px;
    record.height_px = frame->height_px;
    record.path = absl::StrCat(spec.relative_stem, ".", frame->extension);
    record.camera_time_ms = report.time_ms;
    record.camera_exposure_s = report.exposure_s;
    record.iso = report.iso;
    record.aperture_f = report.aperture_f;
    record.camera_file_name = report.file_name;
    record.sha256 = report.sha256;
    // The previous frame must be recorded before this one (progress is
    // sequential); then this one is persisted while the rig takes the next.
    ASSIGN_OR_RETURN(const size_t go_on, finish_pending(next));
    if (go_on != next) {
      next = go_on;
      continue;
    }
    ++count;
    pending_index = next++;
    pending = std::async(
        std::launch::async,
        [&context, &frames, &job, total, done = count,
         step = Describe(spec, views), record = std::move(record),
         bytes = std::move(frame->bytes)]() mutable {
          return PersistFrame(context, frames, job.session, std::move(record),
                              bytes, done, total, step);
        });
  }

  const absl::Duration loop_time = absl::Now() - loop_start;
  if (count > first_count && loop_time > absl::ZeroDuration()) {
    const absl::Duration device_time = devices.total() - devices_before_loop;
    const absl::Duration own = loop_time - device_time;
    context.Info(absl::StrFormat(
        "%d frames in %.2f s: %.2f s in the devices, %.3f s (%.2f%%) in the "
        "daemon",
        count - first_count, absl::ToDoubleSeconds(loop_time),
        absl::ToDoubleSeconds(device_time), absl::ToDoubleSeconds(own),
        100.0 * absl::ToDoubleSeconds(own) / absl::ToDoubleSeconds(loop_time)));
  }
  // The rig left as a capture finds it: the projector blank, the stage at
  // its home position. A transient fault is tried again here, in place.
  Attempts parking(context, "parking the rig after the last frame",
                   "it is parked again", "every frame was recorded");
  for (;;) {
    absl::Status parked =
        projector == nullptr
            ? absl::OkStatus()
            : InStep("blanking the projector",
                     devices.Sample(store::Device::kProjector,
                                    [&] { return projector->Blank(); }));
    if (parked.ok() &&
        (plan.has_bracketed_stereo() || plan.has_structured_light())) {
      parked = place_stage(limits.home_position_mm);
    }
    if (parked.ok()) break;
    RETURN_IF_ERROR(take_again(parking, parked));
  }
  std::move(safe).Cancel();
  if (calibration) {
    RETURN_IF_ERROR(
        CalibrateRig(context, frames, capture, session_dir, poses, board));
  }
  if (write_truth && plan.has_bracketed_stereo()) {
    const double left_mm = specs.front().stage_position_mm;
    const double baseline_mm = plan.bracketed_stereo().baseline_mm();
    if (absl::Status s = write_truth(left_mm, baseline_mm,
                                     session_dir / io::TruthDir(capture.id));
        !s.ok()) {
      return absl::Status(
          s.code(),
          absl::StrCat("writing the simulator's truth: ", s.message()));
    }
    context.Info("wrote the simulator's exact truth (disparity, radiance)");
  }
  return absl::OkStatus();
}

namespace {

// A plan judged against the rig as SubmitCapture and EstimateCapture both
// judge it.
struct JudgedPlan {
  RigLimits limits;
  v1::CapturePlan normal;
  io::CaptureKind kind = io::CaptureKind::kBracketedStereo;
  bool metered = false;
  int64_t frames = 0;  // a metered plan's are known at the rig: none yet
  // The frames the disk guard promises room for: a metered plan's are
  // those of the default bracket until it has chosen (and the rest is
  // checked at every frame); otherwise the plan's own.
  std::vector<FrameSpec> promised;
};

absl::StatusOr<JudgedPlan> JudgePlan(const hardware::Rig& rig,
                                     const v1::CapturePlan& plan) {
  JudgedPlan judged;
  // Limits come from the stage; without one, say so before judging the plan.
  ASSIGN_OR_RETURN(judged.limits, LimitsOf(rig));
  ASSIGN_OR_RETURN(judged.normal, NormalizePlan(plan, judged.limits));
  RETURN_IF_ERROR(CheckDevicesFor(judged.normal, rig));
  judged.kind = *PlanKind(judged.normal);
  judged.metered = ChoosesExposuresAtTheRig(judged.normal);
  judged.frames =
      static_cast<int64_t>(ExpandPlan(judged.normal, judged.limits, 0).size());
  judged.promised =
      ExpandPlan(WithDefaultExposures(judged.normal), judged.limits, 0);
  return judged;
}

}  // namespace

absl::StatusOr<store::JobRecord> SubmitCapture(JobEngine& engine,
                                               const hardware::Rig& rig,
                                               absl::string_view session,
                                               const v1::CapturePlan& plan,
                                               absl::string_view submitted_by,
                                               const DiskGuard* disk) {
  ASSIGN_OR_RETURN(const JudgedPlan judged, JudgePlan(rig, plan));
  if (disk != nullptr) {
    RETURN_IF_ERROR(disk->CheckRoomFor(
        judged.kind, static_cast<int64_t>(judged.promised.size())));
  }
  const int64_t frames = judged.frames;
  const std::string kind_name(io::CaptureKindName(judged.kind));
  return engine.Submit(
      store::JobKind::kCapture, session, judged.normal.SerializeAsString(),
      frames,
      judged.metered
          ? absl::StrCat("queued ", kind_name,
                         " capture; its exposures are chosen by metering "
                         "the scene at the rig")
          : absl::StrCat("queued ", kind_name, " capture of ", frames,
                         " frames"),
      submitted_by);
}

absl::StatusOr<CaptureEstimate> EstimateCapture(const hardware::Rig& rig,
                                                const v1::CapturePlan& plan,
                                                const DiskGuard& disk) {
  ASSIGN_OR_RETURN(const JudgedPlan judged, JudgePlan(rig, plan));
  CaptureEstimate estimate;
  estimate.frames = static_cast<int64_t>(judged.promised.size());
  estimate.duration_s = ExpectedSeconds(
      judged.promised, SettingsOf(judged.normal), judged.limits);
  ASSIGN_OR_RETURN(estimate.disk_bytes,
                   disk.NeededBytes(judged.kind, estimate.frames));
  estimate.exposures_chosen_at_rig = judged.metered;
  return estimate;
}

}  // namespace hdrstereo::jobs
