// SPDX-License-Identifier: GPL-3.0-or-later
//
// Simulator speed: one 1200 x 900 frame of the bundled lab-lamp scene.
// Multi-threaded (cv::parallel_for_), so wall-clock time is what counts.
//   build/tests/bench/sim_render_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>

#include "hardware/sim/sim_world.h"

namespace hdrstereo::sim {
namespace {

Scene LabLamp() {
  absl::StatusOr<Scene> scene = LoadBundledScene("lab-lamp");
  if (!scene.ok()) std::abort();
  return *scene;
}

// Noise-free radiance, depth and object ids (the ray casting alone).
void BM_LabLampRadiance(benchmark::State& state) {
  SimWorld world(LabLamp());
  for (auto _ : state) {
    RadianceFrame f = world.RenderRadiance();
    benchmark::DoNotOptimize(f.radiance.data);
  }
  state.counters["threads"] = cv::getNumThreads();
}
BENCHMARK(BM_LabLampRadiance)->Unit(benchmark::kMillisecond)->UseRealTime();

// A camera frame: radiance + exposure, noise, response, 8-bit quantisation.
void BM_LabLampFrame8Bit(benchmark::State& state) {
  SimWorld world(LabLamp());
  for (auto _ : state) {
    cv::Mat frame = world.RenderExposure({1.0 / 125, 100}, 8);
    benchmark::DoNotOptimize(frame.data);
  }
}
BENCHMARK(BM_LabLampFrame8Bit)->Unit(benchmark::kMillisecond)->UseRealTime();

// A frame lit by a projector pattern (one more shadow ray per pixel).
void BM_LabLampFrameWithPattern(benchmark::State& state) {
  SimWorld world(LabLamp());
  cv::Mat pattern(768, 1024, CV_8UC1);
  for (int c = 0; c < 1024; ++c) pattern.col(c).setTo((c / 16) % 2 ? 255 : 0);
  if (!world.SetProjectorPattern(pattern).ok()) std::abort();
  for (auto _ : state) {
    cv::Mat frame = world.RenderExposure({1.0 / 125, 100}, 8);
    benchmark::DoNotOptimize(frame.data);
  }
}
BENCHMARK(BM_LabLampFrameWithPattern)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// Full stereo truth: two radiance renders plus correspondence/occlusion.
void BM_LabLampStereoTruth(benchmark::State& state) {
  SimWorld world(LabLamp());
  for (auto _ : state) {
    absl::StatusOr<StereoTruth> t = world.Truth(0, 150);
    benchmark::DoNotOptimize(t.ok());
  }
}
BENCHMARK(BM_LabLampStereoTruth)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace hdrstereo::sim

BENCHMARK_MAIN();
