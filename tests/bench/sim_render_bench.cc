// SPDX-License-Identifier: GPL-3.0-or-later
//
// Simulator speed: one 1200 x 900 frame of the bundled lab-lamp scene.
// Multi-threaded (cv::parallel_for_), so wall-clock time is what counts.
//   build/tests/bench/sim_render_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <ctime>
#include <opencv2/core.hpp>

#include "hardware/sim/sim_world.h"

namespace hdrstereo::sim {
namespace {

// Process CPU time of all threads, per iteration, in ms: robust against other
// load on a shared machine (wall time is not).
class CpuPerFrame {
 public:
  CpuPerFrame() : start_(std::clock()) {}
  void Report(benchmark::State& state) {
    const double ms = 1000.0 * (std::clock() - start_) / CLOCKS_PER_SEC;
    state.counters["cpu_ms_all_threads"] =
        benchmark::Counter(ms, benchmark::Counter::kAvgIterations);
    state.counters["threads"] = cv::getNumThreads();
  }

 private:
  std::clock_t start_;
};

Scene LabLamp() {
  absl::StatusOr<Scene> scene = LoadBundledScene("lab-lamp");
  if (!scene.ok()) std::abort();
  return *scene;
}

// Noise-free radiance, depth and object ids (the ray casting alone).
void BM_LabLampRadiance(benchmark::State& state) {
  SimWorld world(LabLamp());
  CpuPerFrame cpu;
  for (auto _ : state) {
    RadianceFrame f = world.RenderRadiance();
    benchmark::DoNotOptimize(f.radiance.data);
  }
  cpu.Report(state);
}
BENCHMARK(BM_LabLampRadiance)->Unit(benchmark::kMillisecond)->UseRealTime();

// A camera frame: radiance + exposure, noise, response, 8-bit quantisation.
void BM_LabLampFrame8Bit(benchmark::State& state) {
  SimWorld world(LabLamp());
  CpuPerFrame cpu;
  for (auto _ : state) {
    cv::Mat frame = world.RenderExposure({1.0 / 125, 100}, 8);
    benchmark::DoNotOptimize(frame.data);
  }
  cpu.Report(state);
}
BENCHMARK(BM_LabLampFrame8Bit)->Unit(benchmark::kMillisecond)->UseRealTime();

// A frame lit by a projector pattern (one more shadow ray per pixel).
void BM_LabLampFrameWithPattern(benchmark::State& state) {
  SimWorld world(LabLamp());
  cv::Mat pattern(768, 1024, CV_8UC1);
  for (int c = 0; c < 1024; ++c) pattern.col(c).setTo((c / 16) % 2 ? 255 : 0);
  if (!world.SetProjectorPattern(pattern).ok()) std::abort();
  CpuPerFrame cpu;
  for (auto _ : state) {
    cv::Mat frame = world.RenderExposure({1.0 / 125, 100}, 8);
    benchmark::DoNotOptimize(frame.data);
  }
  cpu.Report(state);
}
BENCHMARK(BM_LabLampFrameWithPattern)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Full stereo truth: two radiance renders plus correspondence/occlusion.
void BM_LabLampStereoTruth(benchmark::State& state) {
  SimWorld world(LabLamp());
  CpuPerFrame cpu;
  for (auto _ : state) {
    absl::StatusOr<StereoTruth> t = world.Truth(0, 150);
    benchmark::DoNotOptimize(t.ok());
  }
  cpu.Report(state);
}
BENCHMARK(BM_LabLampStereoTruth)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace hdrstereo::sim

BENCHMARK_MAIN();
