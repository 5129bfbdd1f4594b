// SPDX-License-Identifier: GPL-3.0-or-later
//
// Camera response recovery after Debevec & Malik (SIGGRAPH 1997): the
// inverse response g(z) = ln(E * dt) per channel, from an 8-bit exposure
// stack, solved by least squares with a hat weighting and a second-derivative
// smoothness term of strength lambda. g is fixed by g(128) = 0 (the method
// leaves one free offset per channel, so radiance is relative).
#ifndef HDRSTEREO_PROCESSING_HDR_RESPONSE_H_
#define HDRSTEREO_PROCESSING_HDR_RESPONSE_H_

#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "processing/hdr/stack.h"

namespace hdrstereo::hdr {

inline constexpr int kLevels = 256;  // 8-bit codes

struct CameraResponse {
  // kLevels x 1, CV_32FC(channels): g(z) = ln(exposure) for code z, per
  // channel. Empty when `linear`.
  cv::Mat log_inverse;
  // Linear sensor data (16-bit or float RAW): exposure is proportional to
  // the value; no calibration needed.
  bool linear = false;
  std::string camera;  // which camera the response belongs to
  // Per channel, the lowest code the camera records (CodeFloors); codes at
  // or below it carry no information and get no weight. Empty = 0.
  std::vector<int> floor;
};

struct ResponseOptions {
  double lambda = 10.0;  // smoothness weight
  int samples = 120;     // pixels sampled per channel
  uint64_t seed = 1;     // sampling is random but reproducible
};

// Debevec & Malik's hat weighting over the codes a camera really records:
// 0 at and below `floor` and at 255, rising linearly from both ends to the
// middle of [floor, 255]. Floor 0: w(z) = z for z <= 127, 255 - z above,
// so w(0) = w(255) = 0 (clipped codes carry no information).
std::vector<float> HatWeights(int floor = 0);

// The lowest code an 8-bit stack's camera records, per channel: where the
// codes of the shortest exposure begin, as the 1st percentile of its
// non-zero codes (zeros are clipped or border pixels). A digital camera
// records down to 0-2; film has a base fog (Debevec's scanned church series:
// 15, 16 and 12 in B, G, R), below which no exposure time is told apart, so
// a hat on [0, 255] would let every short exposure's fog claim a radiance.
std::vector<int> CodeFloors(const ExposureStack& stack);

// Recovers g per channel from an 8-bit stack (CV_8UC1 or CV_8UC3) with the
// hat weights above the stack's CodeFloors (kept in the response). Pixels
// are sampled so that their approximate radiances span the scene's range.
// The result is strictly increasing in every channel: where the least-
// squares curve wiggles, it is replaced by its closest increasing curve.
absl::StatusOr<CameraResponse> RecoverResponse(
    const ExposureStack& stack, const ResponseOptions& options = {});

// The response of linear data (RAW decoded by LibRaw).
CameraResponse LinearResponse(std::string camera = "");

// Conversions to and from cv::CalibrateDebevec/MergeDebevec's response
// (kLevels x 1 CV_32FC3 of exposure, not its log).
CameraResponse FromOpenCvResponse(const cv::Mat& response);
cv::Mat ToOpenCvResponse(const CameraResponse& response);

// Saves/loads a response (OpenCV FileStorage YAML; written atomically).
absl::Status SaveResponse(const std::filesystem::path& path,
                          const CameraResponse& response);
absl::StatusOr<CameraResponse> LoadResponse(const std::filesystem::path& path);

}  // namespace hdrstereo::hdr

#endif  // HDRSTEREO_PROCESSING_HDR_RESPONSE_H_
