// SPDX-License-Identifier: GPL-3.0-or-later
//
// What a frame costs through the real camera stack: our gphoto2 driver ->
// libgphoto2 -> PTP/IP over loopback -> the simulated network camera,
// against the same simulated camera called directly (SimCamera), for the
// lab-lamp scene at 1200 x 900 as 8-bit PNG and 16-bit TIFF. Both render
// the same frame; the difference is libgphoto2's and the protocol's cost
// (trigger, events, object info, the file's transfer, its deletion).
//   build/tests/bench/ptpip_bench --benchmark_repetitions=5
#include <benchmark/benchmark.h>

#include <cstdlib>

#include "hardware/gphoto2/gphoto2_camera.h"
#include "hardware/sim/ptpip_camera.h"
#include "hardware/sim/sim_devices.h"
#include "hardware/sim/sim_world.h"

namespace hdrstereo::sim {
namespace {

Scene LabLamp() {
  absl::StatusOr<Scene> scene = LoadBundledScene("lab-lamp");
  if (!scene.ok()) std::abort();
  scene->timing.scale = 0;  // no modelled waits: the cost of the stack
  return *scene;
}

ImageFormat SimFormat(int64_t arg) {
  return arg == 16 ? ImageFormat::kTiff16 : ImageFormat::kPng;
}

void CountBytes(benchmark::State& state, int64_t bytes) {
  state.SetBytesProcessed(bytes);
  state.counters["MB_per_frame"] = benchmark::Counter(
      static_cast<double>(bytes) / 1e6, benchmark::Counter::kAvgIterations);
}

void BM_DirectSimCamera(benchmark::State& state) {
  SimWorld world(LabLamp());
  SimCameraOptions options;
  options.format = state.range(0) == 16 ? hardware::ImageFormat::kTiff16
                                        : hardware::ImageFormat::kPng8;
  SimCamera camera(world, options);
  int64_t bytes = 0;
  for (auto _ : state) {
    absl::StatusOr<hardware::Frame> frame = camera.Capture();
    if (!frame.ok()) {
      state.SkipWithError(frame.status().ToString().c_str());
      break;
    }
    bytes += static_cast<int64_t>(frame->bytes.size());
  }
  CountBytes(state, bytes);
}
BENCHMARK(BM_DirectSimCamera)
    ->Arg(8)
    ->Arg(16)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_Libgphoto2OverPtpIp(benchmark::State& state) {
  SimWorld world(LabLamp());
  PtpIpCameraOptions options;
  options.format = SimFormat(state.range(0));
  absl::StatusOr<std::unique_ptr<PtpIpCamera>> responder =
      PtpIpCamera::Start(world, options);
  if (!responder.ok()) {
    state.SkipWithError(responder.status().ToString().c_str());
    return;
  }
  gphoto2::Gphoto2Options camera_options;
  camera_options.model = PtpIpCamera::kGphoto2Model;
  camera_options.port = (*responder)->gphoto2_port();
  absl::StatusOr<std::unique_ptr<gphoto2::Gphoto2Camera>> camera =
      gphoto2::Gphoto2Camera::Open(camera_options);
  if (!camera.ok()) {
    state.SkipWithError(camera.status().ToString().c_str());
    return;
  }
  int64_t bytes = 0;
  for (auto _ : state) {
    absl::StatusOr<hardware::Frame> frame = (*camera)->Capture();
    if (!frame.ok()) {
      state.SkipWithError(frame.status().ToString().c_str());
      break;
    }
    bytes += static_cast<int64_t>(frame->bytes.size());
  }
  CountBytes(state, bytes);
}
BENCHMARK(BM_Libgphoto2OverPtpIp)
    ->Arg(8)
    ->Arg(16)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace hdrstereo::sim

BENCHMARK_MAIN();
