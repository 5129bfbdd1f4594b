// SPDX-License-Identifier: GPL-3.0-or-later
//
// Full-HD mesopic retargeting (thesis ch. 6) on 2 OpenCV threads, against
// peers in the same run: cv::cvtColor BGR->Lab (a per-pixel non-linear
// colour transform) and cv::transform with a 3x3 matrix (a lower bound for
// any per-pixel colour operation). Target: <= 50 ms per frame. "Time" is
// wall time, "CPU" the CPU time of the whole process (all threads): on a
// shared, loaded machine CPU / 2 estimates the wall time on 2 free cores.
#include <benchmark/benchmark.h>

#include "opencv2/core.hpp"
#include "opencv2/imgproc.hpp"
#include "processing/mesopic/retarget.h"

namespace {

using hdrstereo::mesopic::Method;

cv::Mat TestFrame(int type) {
  // Smooth colour gradients plus noise, 1920x1080.
  cv::Mat f(1080, 1920, CV_32FC3);
  for (int y = 0; y < f.rows; ++y) {
    for (int x = 0; x < f.cols; ++x) {
      f.at<cv::Vec3f>(y, x) = cv::Vec3f(x / 1920.0f, y / 1080.0f,
                                        0.5f + 0.5f * ((x + y) % 97) / 97);
    }
  }
  cv::Mat noise(f.size(), CV_32FC3);
  cv::randu(noise, -0.05, 0.05);
  f += noise;
  f = cv::max(f, 0.0);
  f = cv::min(f, 1.0);
  if (type == CV_8UC3) f.convertTo(f, CV_8UC3, 255.0);
  return f;
}

void BM_Retarget(benchmark::State& state, Method method, bool tone, int type) {
  cv::setNumThreads(2);
  const cv::Mat frame = TestFrame(type);
  hdrstereo::mesopic::RetargetOptions opt;
  opt.display_cd = 2.0;
  opt.source_cd = 200.0;
  opt.method = method;
  opt.tone_curve = tone;
  for (auto _ : state) {
    auto out = hdrstereo::mesopic::Retarget(frame, opt);
    if (!out.ok()) state.SkipWithError("retarget failed");
    benchmark::DoNotOptimize(out->data);
  }
}

// Reusing the output buffer, as a video pipeline would.
void BM_RetargetInto(benchmark::State& state, Method method, int type) {
  cv::setNumThreads(2);
  const cv::Mat frame = TestFrame(type);
  hdrstereo::mesopic::RetargetOptions opt;
  opt.method = method;
  cv::Mat out;
  for (auto _ : state) {
    if (!hdrstereo::mesopic::RetargetInto(frame, opt, &out).ok()) {
      state.SkipWithError("retarget failed");
    }
    benchmark::DoNotOptimize(out.data);
  }
}

void BM_PeerCvtColorLab(benchmark::State& state, int type) {
  cv::setNumThreads(2);
  const cv::Mat frame = TestFrame(type);
  cv::Mat out;
  for (auto _ : state) {
    cv::cvtColor(frame, out, cv::COLOR_BGR2Lab);
    benchmark::DoNotOptimize(out.data);
  }
}

void BM_PeerTransform3x3(benchmark::State& state, int type) {
  cv::setNumThreads(2);
  const cv::Mat frame = TestFrame(type);
  const cv::Matx33f m(0.9f, 0.1f, 0.0f, 0.05f, 0.9f, 0.05f, 0.0f, 0.1f, 0.9f);
  cv::Mat out;
  for (auto _ : state) {
    cv::transform(frame, out, m);
    benchmark::DoNotOptimize(out.data);
  }
}

BENCHMARK_CAPTURE(BM_Retarget, shin_tone_f32, Method::kShin, true, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Retarget, shin_tone_u8, Method::kShin, true, CV_8UC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Retarget, shin_notone_f32, Method::kShin, false, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Retarget, wanat_saturation_tone_f32,
                  Method::kWanatSaturation, true, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Retarget, rods_tone_f32, Method::kRods, true, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_Retarget, none_tone_f32, Method::kNone, true, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_RetargetInto, shin_tone_f32, Method::kShin, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_RetargetInto, shin_tone_u8, Method::kShin, CV_8UC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_PeerCvtColorLab, f32, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_PeerCvtColorLab, u8, CV_8UC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();
BENCHMARK_CAPTURE(BM_PeerTransform3x3, f32, CV_32FC3)
    ->Unit(benchmark::kMillisecond)
    ->MeasureProcessCPUTime()
    ->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
