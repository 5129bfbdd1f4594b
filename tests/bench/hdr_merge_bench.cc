// SPDX-License-Identifier: GPL-3.0-or-later
//
// HDR merge: ours (processing/hdr/merge.h) against cv::MergeDebevec on the
// same 8 exposures of 1280x960 (thesis exposure times, synthetic scene) and
// the same camera response. Ours runs with cv::MergeDebevec's conventions
// (its triangle weights, one weight per pixel averaged over channels) so the
// outputs are comparable. Before timing, the program checks the relative
// difference; afterwards it prints the median-time ratio ours/OpenCV.
//
//   build/tests/bench/hdr_merge_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <opencv2/photo.hpp>
#include <vector>

#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "tests/unit/hdr/synthetic_scene.h"

namespace hdrstereo::hdr {
namespace {

constexpr int kWidth = 1280;
constexpr int kHeight = 960;

struct Data {
  ExposureStack stack;
  CameraResponse response;  // ours
  cv::Mat opencv_response;  // the same, as MergeDebevec wants it
  MergeOptions options;     // MergeDebevec's conventions
};

// cv::MergeDebevec's weights in OpenCV 4.6 (photo/src/hdr_common.cpp).
std::vector<float> OpenCvTriangleWeights() {
  std::vector<float> w(kLevels);
  for (int i = 0; i < kLevels; ++i) {
    w[i] = i < kLevels / 2 ? i + 1.0f : static_cast<float>(kLevels - i);
  }
  return w;
}

const Data& GetData() {
  static const Data* data = [] {
    auto* d = new Data;
    const cv::Mat radiance = testing::SyntheticRadiance(kWidth, kHeight);
    d->stack.exposure_s = testing::ThesisExposureTimes();
    d->stack.images = testing::RenderExposures(
        radiance, d->stack.exposure_s, testing::TrueResponse{}, 0.005, 1);
    absl::StatusOr<CameraResponse> r = RecoverResponse(d->stack);
    if (!r.ok()) {
      std::fprintf(stderr, "response: %s\n", r.status().ToString().c_str());
      std::abort();
    }
    d->response = *r;
    d->opencv_response = ToOpenCvResponse(d->response);
    d->options.weights = OpenCvTriangleWeights();
    d->options.per_channel_weights = false;
    return d;
  }();
  return *data;
}

cv::Mat MergeOurs(const Data& d) {
  absl::StatusOr<MergeResult> m = MergeStack(d.stack, d.response, d.options);
  if (!m.ok()) std::abort();
  return m->radiance;
}

cv::Mat MergeOpenCv(const Data& d) {
  std::vector<float> times(d.stack.exposure_s.begin(),
                           d.stack.exposure_s.end());
  cv::Mat out;
  cv::createMergeDebevec()->process(d.stack.images, out, times,
                                    d.opencv_response);
  return out;
}

void BM_MergeOurs(benchmark::State& state) {
  const Data& d = GetData();
  for (auto _ : state) benchmark::DoNotOptimize(MergeOurs(d).data);
}
BENCHMARK(BM_MergeOurs)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_MergeOpenCv(benchmark::State& state) {
  const Data& d = GetData();
  for (auto _ : state) benchmark::DoNotOptimize(MergeOpenCv(d).data);
}
BENCHMARK(BM_MergeOpenCv)->Unit(benchmark::kMillisecond)->UseRealTime();

template <typename F>
double MedianSeconds(F f, int runs) {
  std::vector<double> t;
  for (int i = 0; i < runs; ++i) {
    const auto start = std::chrono::steady_clock::now();
    f();
    t.push_back(
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start)
            .count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace
}  // namespace hdrstereo::hdr

int main(int argc, char** argv) {
  using namespace hdrstereo::hdr;  // NOLINT: small benchmark driver
  const Data& d = GetData();
  const cv::Mat ours = MergeOurs(d);
  const cv::Mat theirs = MergeOpenCv(d);
  double max_rel = 0, sum_rel = 0;
  const size_t n = ours.total() * ours.channels();
  for (size_t i = 0; i < n; ++i) {
    const double a = ours.ptr<float>()[i], b = theirs.ptr<float>()[i];
    const double rel = std::abs(a - b) / std::max(std::abs(b), 1e-30);
    max_rel = std::max(max_rel, rel);
    sum_rel += rel;
  }
  std::printf(
      "relative difference ours vs cv::MergeDebevec: max %.3g, mean "
      "%.3g (limit 1e-3)\n",
      max_rel, sum_rel / n);

  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();

  const double t_ours = MedianSeconds([&] { MergeOurs(d); }, 9);
  const double t_cv = MedianSeconds([&] { MergeOpenCv(d); }, 9);
  const double ratio = t_ours / t_cv;
  std::printf(
      "median of 9: ours %.1f ms, cv::MergeDebevec %.1f ms, ratio "
      "%.3f (limit 0.5), %d OpenCV threads\n",
      1e3 * t_ours, 1e3 * t_cv, ratio, cv::getNumThreads());
  const bool ok = max_rel <= 1e-3 && ratio <= 0.5;
  std::printf("%s\n", ok ? "PASS" : "FAIL");
  return ok ? 0 : 1;
}
