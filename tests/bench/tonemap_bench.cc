// SPDX-License-Identifier: GPL-3.0-or-later
//
// Tone mapping at 1280x960: our seven operators against OpenCV's
// TonemapReinhard, TonemapDrago and TonemapMantiuk in the same process, and
// our guided filter against cv::ximgproc::guidedFilter. OpenCV's operators
// return float [0, 1]; the peers include the conversion to 8 bit so both
// sides produce the same kind of image. See docs/benchmarks.md.
#include <benchmark/benchmark.h>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>
#include <opencv2/ximgproc/edge_filter.hpp>

#include "processing/filters/guided_filter.h"
#include "processing/tonemap/tonemap.h"
#include "tests/unit/tonemap/synthetic_scene.h"

namespace {

using hdrstereo::tonemap::Operator;

const cv::Mat& Scene() {
  static const cv::Mat scene = hdrstereo::testing::SyntheticScene(1280, 960);
  return scene;
}

void BM_Ours(benchmark::State& state) {
  const Operator op = static_cast<Operator>(state.range(0));
  state.SetLabel(hdrstereo::tonemap::OperatorName(op));
  for (auto _ : state) {
    absl::StatusOr<cv::Mat> out = hdrstereo::tonemap::ToneMap(Scene(), op);
    if (!out.ok()) state.SkipWithError(out.status().ToString().c_str());
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_Ours)->DenseRange(0, 6)->Unit(benchmark::kMillisecond);

void BM_OursAllSeven(benchmark::State& state) {
  for (auto _ : state) {
    for (Operator op : hdrstereo::tonemap::AllOperators()) {
      absl::StatusOr<cv::Mat> out = hdrstereo::tonemap::ToneMap(Scene(), op);
      if (!out.ok()) state.SkipWithError(out.status().ToString().c_str());
      benchmark::DoNotOptimize(out);
    }
  }
}
BENCHMARK(BM_OursAllSeven)->Unit(benchmark::kMillisecond);

template <typename Make>
void RunOpenCv(benchmark::State& state, Make make) {
  cv::Ptr<cv::Tonemap> tm = make();
  cv::Mat ldr, out;
  for (auto _ : state) {
    tm->process(Scene(), ldr);
    ldr.convertTo(out, CV_8UC3, 255.0);
    benchmark::DoNotOptimize(out.data);
  }
}

void BM_OpenCvReinhard(benchmark::State& state) {
  RunOpenCv(state, [] { return cv::createTonemapReinhard(); });
}
BENCHMARK(BM_OpenCvReinhard)->Unit(benchmark::kMillisecond);

void BM_OpenCvDrago(benchmark::State& state) {
  RunOpenCv(state, [] { return cv::createTonemapDrago(); });
}
BENCHMARK(BM_OpenCvDrago)->Unit(benchmark::kMillisecond);

void BM_OpenCvMantiuk(benchmark::State& state) {
  RunOpenCv(state, [] { return cv::createTonemapMantiuk(); });
}
BENCHMARK(BM_OpenCvMantiuk)->Unit(benchmark::kMillisecond);

// Guided filter, r = 9, eps = 1e-4, on [0, 1] data; range(0) = guide
// channels, range(1) = subsample (1 = exact).
cv::Mat GuideImage(int channels) {
  cv::Mat lum;
  cv::Mat scene = Scene();
  if (channels == 1) {
    cv::cvtColor(scene, lum, cv::COLOR_BGR2GRAY);
  } else {
    lum = scene.clone();
  }
  cv::log(lum + 1.0, lum);
  cv::normalize(lum, lum, 0, 1, cv::NORM_MINMAX);
  return lum;
}

void BM_GuidedOurs(benchmark::State& state) {
  const cv::Mat guide = GuideImage(static_cast<int>(state.range(0)));
  cv::Mat src;
  cv::cvtColor(Scene(), src, cv::COLOR_BGR2GRAY);
  cv::normalize(src, src, 0, 1, cv::NORM_MINMAX);
  hdrstereo::filters::GuidedFilterOptions o;
  o.subsample = static_cast<int>(state.range(1));
  for (auto _ : state) {
    absl::StatusOr<cv::Mat> out =
        hdrstereo::filters::ApplyGuidedFilter(guide, src, o);
    benchmark::DoNotOptimize(out);
  }
}
BENCHMARK(BM_GuidedOurs)
    ->Args({1, 1})
    ->Args({3, 1})
    ->Args({1, 4})
    ->Args({3, 4})
    ->Unit(benchmark::kMillisecond);

// Reusing one guide for many inputs (the stereo cost-volume case): per input.
void BM_GuidedOursReusedGuide(benchmark::State& state) {
  const cv::Mat guide = GuideImage(static_cast<int>(state.range(0)));
  cv::Mat src;
  cv::cvtColor(Scene(), src, cv::COLOR_BGR2GRAY);
  cv::normalize(src, src, 0, 1, cv::NORM_MINMAX);
  absl::StatusOr<hdrstereo::filters::GuidedFilter> f =
      hdrstereo::filters::GuidedFilter::Create(guide, {});
  cv::Mat out;
  hdrstereo::filters::GuidedFilterWorkspace ws;
  for (auto _ : state) {
    f->FilterPlane(src, out, &ws);
    benchmark::DoNotOptimize(out.data);
  }
}
BENCHMARK(BM_GuidedOursReusedGuide)
    ->Arg(1)
    ->Arg(3)
    ->Unit(benchmark::kMillisecond);

void BM_GuidedOpenCv(benchmark::State& state) {
  const cv::Mat guide = GuideImage(static_cast<int>(state.range(0)));
  cv::Mat src;
  cv::cvtColor(Scene(), src, cv::COLOR_BGR2GRAY);
  cv::normalize(src, src, 0, 1, cv::NORM_MINMAX);
  cv::Mat out;
  for (auto _ : state) {
    cv::ximgproc::guidedFilter(guide, src, out, 9, 1e-4, CV_32F);
    benchmark::DoNotOptimize(out.data);
  }
}
BENCHMARK(BM_GuidedOpenCv)->Arg(1)->Arg(3)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
