// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/hdr/response.h"

#include <algorithm>
#include <cmath>
#include <opencv2/core/persistence.hpp>
#include <random>

#include "absl/strings/str_cat.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/image.h"

namespace hdrstereo::hdr {
namespace {

constexpr int kMid = kLevels / 2;

// Picks pixel indices whose approximate log radiance spans the scene:
// each pixel's proxy is ln((z + 0.5) / dt) in the exposure where its code is
// nearest mid-grey; the proxy range is cut into `samples` bins and one random
// pixel is taken from each non-empty bin.
std::vector<int> SamplePixels(const ExposureStack& stack, int channel,
                              int samples, std::mt19937_64& rng) {
  const int total = stack.images[0].rows * stack.images[0].cols;
  const int channels = stack.images[0].channels();
  const int stride = std::max(1, total / 200000);
  std::vector<std::pair<float, int>> candidates;
  candidates.reserve(total / stride + 1);
  for (int p = 0; p < total; p += stride) {
    int best = -1, best_dist = kLevels;
    for (size_t j = 0; j < stack.images.size(); ++j) {
      int z = stack.images[j].data[static_cast<size_t>(p) * channels + channel];
      if (std::abs(z - kMid) < best_dist) {
        best_dist = std::abs(z - kMid);
        best = static_cast<int>(j);
      }
    }
    int z =
        stack.images[best].data[static_cast<size_t>(p) * channels + channel];
    candidates.emplace_back(
        static_cast<float>(std::log((z + 0.5) / stack.exposure_s[best])), p);
  }
  float lo = candidates[0].first, hi = lo;
  for (const auto& c : candidates) {
    lo = std::min(lo, c.first);
    hi = std::max(hi, c.first);
  }
  std::vector<std::vector<int>> bins(samples);
  const float span = std::max(hi - lo, 1e-6f);
  for (const auto& [proxy, p] : candidates) {
    int b =
        std::min(samples - 1, static_cast<int>((proxy - lo) / span * samples));
    bins[b].push_back(p);
  }
  std::vector<int> picked;
  for (const auto& bin : bins) {
    if (bin.empty()) continue;
    std::uniform_int_distribution<size_t> pick(0, bin.size() - 1);
    picked.push_back(bin[pick(rng)]);
  }
  // Fill up with random pixels where bins were empty.
  std::uniform_int_distribution<int> any(0, total - 1);
  while (static_cast<int>(picked.size()) < samples) picked.push_back(any(rng));
  return picked;
}

// The least-squares curve of a real stack wiggles where few samples speak
// (misregistration, noise); an exposure's code must still map to a larger
// radiance for a larger code. Projects g onto non-decreasing curves
// (pool-adjacent-violators, weighted by each code's support), then makes
// pooled runs strictly increasing by interpolating linearly between the
// centres of neighbouring runs. A curve that already increases is kept.
void MakeIncreasing(const std::vector<double>& support,
                    std::vector<double>* g) {
  struct Run {
    double sum_wv, sum_w;
    int first, last;
  };
  std::vector<Run> runs;
  for (int z = 0; z < kLevels; ++z) {
    runs.push_back({support[z] * (*g)[z], support[z], z, z});
    while (runs.size() > 1) {
      const Run& hi = runs.back();
      const Run& lo = runs[runs.size() - 2];
      if (lo.sum_wv / lo.sum_w < hi.sum_wv / hi.sum_w) break;
      Run merged{lo.sum_wv + hi.sum_wv, lo.sum_w + hi.sum_w, lo.first, hi.last};
      runs.pop_back();
      runs.back() = merged;
    }
  }
  if (runs.size() < 2) return;  // flat: nothing to interpolate between
  std::vector<double> centre(runs.size()), value(runs.size());
  for (size_t k = 0; k < runs.size(); ++k) {
    centre[k] = 0.5 * (runs[k].first + runs[k].last);
    value[k] = runs[k].sum_wv / runs[k].sum_w;
  }
  size_t k = 0;
  for (int z = 0; z < kLevels; ++z) {
    while (k + 2 < runs.size() && z > centre[k + 1]) ++k;
    const double t = (z - centre[k]) / (centre[k + 1] - centre[k]);
    (*g)[z] = value[k] + t * (value[k + 1] - value[k]);
  }
}

}  // namespace

std::vector<float> HatWeights(int floor) {
  floor = std::clamp(floor, 0, kLevels - 2);
  const double mid = 0.5 * (floor + kLevels - 1);
  std::vector<float> w(kLevels);
  for (int z = 0; z < kLevels; ++z) {
    w[z] = static_cast<float>(z <= floor ? 0
                              : z < mid  ? z - floor
                                         : kLevels - 1 - z);
  }
  return w;
}

std::vector<int> CodeFloors(const ExposureStack& stack) {
  std::vector<int> floors;
  if (stack.images.empty() || stack.images[0].depth() != CV_8U) return floors;
  size_t shortest = 0;
  for (size_t j = 1; j < stack.exposure_s.size(); ++j) {
    if (stack.exposure_s[j] < stack.exposure_s[shortest]) shortest = j;
  }
  const cv::Mat& image = stack.images[shortest];
  const int channels = image.channels();
  for (int c = 0; c < channels; ++c) {
    std::vector<int64_t> histogram(kLevels, 0);
    for (int y = 0; y < image.rows; ++y) {
      const uint8_t* row = image.ptr<uint8_t>(y);
      for (int x = 0; x < image.cols; ++x) ++histogram[row[x * channels + c]];
    }
    int64_t nonzero = 0;
    for (int z = 1; z < kLevels; ++z) nonzero += histogram[z];
    int64_t below = 0;
    int floor = 0;
    for (int z = 1; z < kLevels; ++z) {
      below += histogram[z];
      if (below * 100 >= nonzero) {
        floor = z;
        break;
      }
    }
    floors.push_back(floor);
  }
  return floors;
}

absl::StatusOr<CameraResponse> RecoverResponse(const ExposureStack& stack,
                                               const ResponseOptions& options) {
  RETURN_IF_ERROR(ValidateStack(stack));
  if (stack.images[0].depth() != CV_8U) {
    return absl::InvalidArgumentError(absl::StrCat(
        "response recovery needs 8-bit images; ", stack.Name(0),
        " is deeper (use LinearResponse() for linear 16-bit RAW data)"));
  }
  if (absl::Status s = options.Validate(); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("response: ", s.message()));
  }
  const int channels = stack.images[0].channels();
  const int n_images = static_cast<int>(stack.images.size());
  ExposureStack s = stack;
  for (cv::Mat& m : s.images) {
    if (!m.isContinuous()) m = m.clone();
  }
  const std::vector<int> floors = CodeFloors(s);
  std::mt19937_64 rng(options.seed);
  cv::Mat result(kLevels, 1, CV_32FC(channels));
  try {
    for (int c = 0; c < channels; ++c) {
      const std::vector<float> w = HatWeights(floors[c]);
      std::vector<int> pixels = SamplePixels(s, c, options.samples, rng);
      const int n = static_cast<int>(pixels.size());
      const int rows = n * n_images + 1 + (kLevels - 2);
      const int cols = kLevels + n;
      cv::Mat a = cv::Mat::zeros(rows, cols, CV_64F);
      cv::Mat b = cv::Mat::zeros(rows, 1, CV_64F);
      int k = 0;
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n_images; ++j, ++k) {
          int z =
              s.images[j].data[static_cast<size_t>(pixels[i]) * channels + c];
          double wij = w[z];
          a.at<double>(k, z) = wij;
          a.at<double>(k, kLevels + i) = -wij;
          b.at<double>(k) = wij * std::log(s.exposure_s[j]);
        }
      }
      a.at<double>(k++, kMid) = 1.0;  // g(128) = 0
      for (int z = 1; z < kLevels - 1; ++z, ++k) {
        // At least weight 1, so that the codes below the floor (weight 0)
        // are still tied to their neighbours: g is defined everywhere.
        double lw = options.lambda * std::max(w[z], 1.0f);
        a.at<double>(k, z - 1) = lw;
        a.at<double>(k, z) = -2 * lw;
        a.at<double>(k, z + 1) = lw;
      }
      cv::Mat x;
      if (!cv::solve(a, b, x, cv::DECOMP_SVD)) {
        return absl::InternalError("response least-squares solve failed");
      }
      // How much data speaks for each code (its equations' weights).
      std::vector<double> g(kLevels), support(kLevels, 1e-6);
      for (int z = 0; z < kLevels; ++z) g[z] = x.at<double>(z);
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n_images; ++j) {
          const int z =
              s.images[j].data[static_cast<size_t>(pixels[i]) * channels + c];
          support[z] += w[z];
        }
      }
      MakeIncreasing(support, &g);
      for (int z = 0; z < kLevels; ++z) {
        result.ptr<float>(z)[c] = static_cast<float>(g[z] - g[kMid]);
      }
    }
  } catch (const cv::Exception& e) {
    return absl::InternalError(
        absl::StrCat("response recovery failed: ", e.what()));
  }
  CameraResponse out;
  out.log_inverse = result;
  out.camera = stack.camera;
  out.floor = floors;
  return out;
}

CameraResponse LinearResponse(std::string camera) {
  CameraResponse r;
  r.linear = true;
  r.camera = std::move(camera);
  return r;
}

cv::Mat ToOpenCvResponse(const CameraResponse& response) {
  cv::Mat e;
  if (response.linear) {
    e.create(kLevels, 1, CV_32FC3);
    for (int z = 0; z < kLevels; ++z) {
      float v = std::max(z, 1) / float(kLevels - 1);
      e.at<cv::Vec3f>(z) = cv::Vec3f(v, v, v);
    }
    return e;
  }
  cv::exp(response.log_inverse, e);
  return e;
}

absl::Status SaveResponse(const std::filesystem::path& path,
                          const CameraResponse& response) {
  std::string yaml;
  try {
    cv::FileStorage fs(".yml",
                       cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
    fs << "format"
       << "hdrstereo-camera-response-1";
    fs << "camera" << response.camera;
    fs << "linear" << static_cast<int>(response.linear);
    if (!response.linear) fs << "log_inverse" << response.log_inverse;
    if (!response.floor.empty()) fs << "floor" << response.floor;
    yaml = fs.releaseAndGetString();
  } catch (const cv::Exception& e) {
    return absl::InternalError(absl::StrCat("cannot encode response for ",
                                            path.string(), ": ", e.what()));
  }
  return io::WriteFileAtomically(path, yaml);
}

absl::StatusOr<CameraResponse> LoadResponse(const std::filesystem::path& path) {
  ASSIGN_OR_RETURN(std::string yaml, io::ReadFileBytes(path));
  CameraResponse r;
  try {
    cv::FileStorage fs(yaml, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    std::string format;
    fs["format"] >> format;
    if (format != "hdrstereo-camera-response-1") {
      return absl::InvalidArgumentError(
          absl::StrCat("not a camera response file: ", path.string()));
    }
    int linear = 0;
    fs["camera"] >> r.camera;
    fs["linear"] >> linear;
    r.linear = linear != 0;
    if (!fs["floor"].empty()) fs["floor"] >> r.floor;
    for (int f : r.floor) {
      if (f < 0 || f >= kLevels - 1) {
        return absl::InvalidArgumentError(
            absl::StrCat("bad code floor ", f, " in ", path.string()));
      }
    }
    if (!r.linear) {
      fs["log_inverse"] >> r.log_inverse;
      if (r.log_inverse.rows != kLevels || r.log_inverse.cols != 1 ||
          r.log_inverse.depth() != CV_32F ||
          (r.log_inverse.channels() != 1 && r.log_inverse.channels() != 3)) {
        return absl::InvalidArgumentError(
            absl::StrCat("bad log_inverse table in ", path.string()));
      }
    }
  } catch (const cv::Exception& e) {
    return absl::InvalidArgumentError(
        absl::StrCat("corrupt response file ", path.string(), ": ", e.what()));
  }
  return r;
}

}  // namespace hdrstereo::hdr
