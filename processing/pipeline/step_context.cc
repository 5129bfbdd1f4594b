// SPDX-License-Identifier: GPL-3.0-or-later
#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <limits>
#include <system_error>
#include <utility>

#include "absl/strings/str_cat.h"
#include "processing/base/parallel_for.h"
#include "processing/base/status_macros.h"
#include "processing/io/atomic_file.h"
#include "processing/io/capture_layout.h"
#include "processing/io/hdr_formats.h"
#include "processing/io/image.h"
#include "processing/io/middlebury.h"
#include "processing/pipeline/step.h"

namespace hdrstereo::pipeline {
namespace fs = std::filesystem;
namespace {

constexpr char kSimulation[] = "simulation";
constexpr char kStructuredLight[] = "structured_light";

}  // namespace

// ------------------------------------------------------------ StepOutputs

absl::Status StepOutputs::Write(
    const std::string& kind, const std::string& rel,
    const std::function<absl::Status(const fs::path&)>& write) {
  const fs::path path = dir_ / rel;
  std::error_code ec;
  fs::create_directories(path.parent_path(), ec);
  if (ec) {
    return absl::InternalError(
        absl::StrCat(path.parent_path().string(), ": ", ec.message()));
  }
  RETURN_IF_ERROR(write(path));
  Record(kind, rel);
  return absl::OkStatus();
}

absl::Status StepOutputs::WriteImage(const std::string& kind,
                                     const std::string& rel,
                                     const cv::Mat& image) {
  return Write(kind, rel, [&](const fs::path& path) {
    return io::WriteImage(path, image);
  });
}

absl::Status StepOutputs::WriteText(const std::string& kind,
                                    const std::string& rel,
                                    const std::string& text) {
  return Write(kind, rel, [&](const fs::path& path) {
    return io::WriteFileAtomically(path, text);
  });
}

absl::Status StepOutputs::CopyFile(const std::string& kind,
                                   const std::string& from_rel,
                                   const std::string& rel) {
  ASSIGN_OR_RETURN(const std::string bytes, io::ReadFileBytes(dir_ / from_rel));
  return WriteText(kind, rel, bytes);
}

void StepOutputs::Record(const std::string& kind, const std::string& rel) {
  Artifact a;
  a.step = step_;
  a.kind = kind;
  a.path = rel;
  a.params_json = params_;
  artifacts_.push_back(std::move(a));
}

void StepOutputs::Append(StepOutputs&& other) {
  for (Artifact& a : other.artifacts_) artifacts_.push_back(std::move(a));
  other.artifacts_.clear();
}

// --------------------------------------------------------------- RunState

absl::Status RunState::Checkpoint() {
  absl::MutexLock l(&mu_);
  return observer_.Checkpoint();
}

void RunState::Progress(int64_t done, int64_t total, const std::string& what) {
  absl::MutexLock l(&mu_);
  observer_.Progress(done, total, what);
}

void RunState::Info(const std::string& message) {
  absl::MutexLock l(&mu_);
  observer_.Info(message);
}

void RunState::Warn(const std::string& message) {
  absl::MutexLock l(&mu_);
  observer_.Warn(message);
}

void RunState::StepComputed(const std::string& step, absl::Duration took) {
  absl::MutexLock l(&mu_);
  observer_.StepComputed(step, took);
}

std::vector<Artifact> RunState::Lookup(const std::string& step,
                                       const std::string& input_hash) {
  absl::MutexLock l(&mu_);
  return store_.Lookup(step, input_hash);
}

absl::Status RunState::Record(const std::string& step,
                              const std::string& input_hash,
                              const std::vector<Artifact>& artifacts) {
  absl::MutexLock l(&mu_);
  return store_.Record(step, input_hash, artifacts);
}

absl::Status RunState::RecordMetrics(const std::vector<Metric>& metrics) {
  absl::MutexLock l(&mu_);
  return store_.RecordMetrics(metrics);
}

void RunState::SetOutputs(const std::string& step,
                          std::vector<Artifact> artifacts) {
  absl::MutexLock l(&outputs_mu_);
  outputs_[step] = std::move(artifacts);
}

std::vector<Artifact> RunState::OutputsOf(const std::string& step) const {
  absl::MutexLock l(&outputs_mu_);
  auto it = outputs_.find(step);
  return it == outputs_.end() ? std::vector<Artifact>() : it->second;
}

// ------------------------------------------------------------ StepContext

absl::StatusOr<cv::Mat> StepContext::Read(const std::string& rel) const {
  ASSIGN_OR_RETURN(io::DecodedImage image, io::DecodeImageFile(dir() / rel));
  return image.pixels;
}

absl::StatusOr<cv::Mat> StepContext::ReadPfm(const std::string& rel) const {
  return io::ReadPfm(dir() / rel);
}

absl::StatusOr<hdr::ExposureStack> StepContext::Stack(int view) const {
  return hdr::LoadStack(dir() / "exposures" / io::ViewName(view));
}

absl::StatusOr<hdr::StackImage> StepContext::Ldr(int view) const {
  return hdr::LoadStackImage(dir() / "exposures" / io::ViewName(view),
                             LdrIndex());
}

bool StepContext::HasStructuredLightTruth() const {
  const std::string rel =
      absl::StrCat(kStructuredLightDir, "/", io::kDisparity0File);
  for (const Artifact& a : state_.OutputsOf("sl_groundtruth")) {
    if (a.path == rel) return true;
  }
  return false;
}

absl::StatusOr<int> StepContext::MaxDisparity(int width, double scale) const {
  double hi = 0;
  if (HasStructuredLightTruth()) {
    ASSIGN_OR_RETURN(
        const cv::Mat d,
        ReadPfm(absl::StrCat(kStructuredLightDir, "/", io::kDisparity0File)));
    hi = std::max(hi, experiment::LargestDisparity(d));
  }
  if (!input().sim_truth_disparity.empty()) {
    ASSIGN_OR_RETURN(const cv::Mat d, ReadPfm(input().sim_truth_disparity));
    hi = std::max(hi, experiment::LargestDisparity(d));
  }
  return experiment::DisparityRange(hi, width, scale);
}

absl::StatusOr<std::vector<Truth>> StepContext::Truths() const {
  std::vector<Truth> out;
  if (HasStructuredLightTruth()) {
    Truth t;
    t.name = kStructuredLight;
    ASSIGN_OR_RETURN(t.disparity, ReadPfm(absl::StrCat(kStructuredLightDir, "/",
                                                       io::kDisparity0File)));
    ASSIGN_OR_RETURN(t.mask0nocc, Read(absl::StrCat(kStructuredLightDir, "/",
                                                    io::kMask0File)));
    t.nonoccluded = t.mask0nocc == io::kMaskNonOccluded;
    out.push_back(std::move(t));
  }
  if (!input().sim_truth_disparity.empty()) {
    Truth t;
    t.name = kSimulation;
    ASSIGN_OR_RETURN(t.disparity, ReadPfm(input().sim_truth_disparity));
    cv::Mat nonoccluded;
    if (!input().sim_truth_nonoccluded.empty()) {
      ASSIGN_OR_RETURN(nonoccluded, Read(input().sim_truth_nonoccluded));
    }
    t.mask0nocc = io::MaskFromTruth(t.disparity, nonoccluded);
    t.nonoccluded = t.mask0nocc == io::kMaskNonOccluded;
    out.push_back(std::move(t));
  }
  return out;
}

absl::Status StepContext::ParallelFor(
    const std::vector<std::string>& names,
    const std::function<absl::Status(int, StepOutputs&)>& fn, int max_at_once) {
  const int n = static_cast<int>(names.size());
  const int threads = max_at_once > 0
                          ? std::min(max_at_once, session_.options.threads)
                          : session_.options.threads;
  std::vector<StepOutputs> parts(names.size(), outputs_.Empty());
  std::atomic<int> done{0};
  RETURN_IF_ERROR(
      hdrstereo::ParallelFor(n, threads, [&](int i) -> absl::Status {
        RETURN_IF_ERROR(state_.Checkpoint());
        try {
          RETURN_IF_ERROR(fn(i, parts[static_cast<size_t>(i)]));
        } catch (const cv::Exception& e) {
          return absl::InternalError(
              absl::StrCat(step_, ": OpenCV: ", e.what()));
        }
        Progress(done.fetch_add(1) + 1, n,
                 absl::StrCat(step_, ": ", names[static_cast<size_t>(i)]));
        return absl::OkStatus();
      }));
  for (StepOutputs& p : parts) outputs_.Append(std::move(p));
  return absl::OkStatus();
}

experiment::UnitRunner StepContext::Units() {
  return [this](const std::vector<std::string>& names,
                const std::function<absl::Status(int)>& unit) {
    return ParallelFor(names, [&](int i, StepOutputs&) { return unit(i); });
  };
}

}  // namespace hdrstereo::pipeline
