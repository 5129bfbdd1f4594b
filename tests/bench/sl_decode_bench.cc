// SPDX-License-Identifier: GPL-3.0-or-later
//
// Gray-code decode of one view: 20 bit planes + inverses (1024x768
// projector) plus white and black, seen by a 1280x960 8-bit camera, against
// OpenCV 4.6's cv::structured_light::GrayCodePattern in the same run:
//   - GrayCodePattern::decode: OpenCV has no single-view decode; decode()
//     needs two cameras, so it gets this view twice and its time is halved
//     (that half still includes its projector-space matching);
//   - GrayCodePattern::getProjPixel over every lit pixel (OpenCV's per-pixel
//     decode, with the shadow mask decode() uses): the like-for-like peer,
//     and the one whose code maps are compared.
// Thresholds are set alike (white - black > 40, |pattern - inverse| >= 5
// grey levels); the program checks that both give identical projector
// column and row on every pixel both call valid, prints the median-of-N
// ratios and PASS/FAIL against the target (ours <= 0.05x decode), then runs
// the Google Benchmark table.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/structured_light.hpp>
#include <vector>

#include "processing/structured_light/decode.h"
#include "processing/structured_light/gray_code.h"

namespace {

namespace sl = hdrstereo::structured_light;

const cv::Size kProjector(1024, 768);
const cv::Size kCamera(1280, 960);

struct Capture {
  sl::ViewFrames ours;
  std::vector<cv::Mat> patterns;  // OpenCV order: same as ours (40 frames)
  cv::Mat white, black;
};

// The projector seen through a mild perspective warp (about 1.2 camera
// pixels per projector pixel), on a surface with varying albedo, ambient
// light, a projector shadow and sensor noise.
const Capture& TestCapture() {
  static const Capture* capture = [] {
    auto* c = new Capture;
    c->ours.projector_size = kProjector;
    const cv::Point2f src[4] = {{0, 0}, {1023, 0}, {1023, 767}, {0, 767}};
    const cv::Point2f dst[4] = {{20, 30}, {1250, 10}, {1270, 950}, {5, 930}};
    const cv::Mat h = cv::getPerspectiveTransform(src, dst);
    cv::Mat albedo(kCamera, CV_32F);
    for (int y = 0; y < kCamera.height; ++y) {
      for (int x = 0; x < kCamera.width; ++x) {
        albedo.at<float>(y, x) =
            0.35f + 0.3f * static_cast<float>((x * 7 + y * 3) % 200) / 200.0f;
      }
    }
    cv::Mat shadow(kCamera, CV_8U, cv::Scalar(255));
    cv::circle(shadow, {400, 500}, 120, cv::Scalar(0), cv::FILLED);
    cv::RNG rng(7);
    sl::ExposureFrames e;
    e.exposure_s = 1.0 / 30;
    for (const sl::Pattern& p : sl::AllPatterns(kProjector)) {
      cv::Mat pattern = *sl::Render(p, kProjector);
      cv::Mat seen;
      cv::warpPerspective(pattern, seen, h, kCamera, cv::INTER_NEAREST,
                          cv::BORDER_CONSTANT, cv::Scalar(0));
      seen.setTo(0, shadow == 0);
      cv::Mat f;
      seen.convertTo(f, CV_32F, 180.0 / 255.0);
      f = f.mul(albedo) + 25.0f;
      cv::Mat noise(kCamera, CV_32F);
      rng.fill(noise, cv::RNG::NORMAL, 0, 1.5);
      f += noise;
      cv::Mat frame;
      f.convertTo(frame, CV_8U);
      e.frames.push_back(frame);
    }
    c->ours.exposures.push_back(e);
    c->patterns.assign(e.frames.begin(), e.frames.end() - 2);
    c->white = e.frames[e.frames.size() - 2];
    c->black = e.frames.back();
    return c;
  }();
  return *capture;
}

sl::DecodeOptions OpenCvAlikeOptions() {
  sl::DecodeOptions o;
  o.min_lit = 41.0 / 255;       // decode(): white - black > 40
  o.min_contrast = 5.0 / 255;   // getProjPixel(): |p - inv| >= 5
  o.min_relative_contrast = 0;  // OpenCV has no relative test
  return o;
}

cv::Ptr<cv::structured_light::GrayCodePattern> OpenCvPattern() {
  cv::structured_light::GrayCodePattern::Params params;
  params.width = kProjector.width;
  params.height = kProjector.height;
  cv::Ptr<cv::structured_light::GrayCodePattern> g =
      cv::structured_light::GrayCodePattern::create(params);
  g->setBlackThreshold(40);
  g->setWhiteThreshold(5);
  return g;
}

// OpenCV's per-pixel decode of the whole view (shadow mask as decode()).
void OpenCvCodeMaps(const Capture& c, cv::Mat* col, cv::Mat* row) {
  static auto g = OpenCvPattern();
  *col = cv::Mat(kCamera, CV_32S, cv::Scalar(-1));
  *row = cv::Mat(kCamera, CV_32S, cv::Scalar(-1));
  for (int y = 0; y < kCamera.height; ++y) {
    for (int x = 0; x < kCamera.width; ++x) {
      if (c.white.at<uchar>(y, x) - c.black.at<uchar>(y, x) <= 40) continue;
      cv::Point p;
      if (g->getProjPixel(c.patterns, x, y, p)) continue;  // true = error
      col->at<int>(y, x) = p.x;
      row->at<int>(y, x) = p.y;
    }
  }
}

void OpenCvDecodeTwice(const Capture& c) {
  static auto g = OpenCvPattern();
  std::vector<std::vector<cv::Mat>> views = {c.patterns, c.patterns};
  std::vector<cv::Mat> blacks = {c.black, c.black};
  std::vector<cv::Mat> whites = {c.white, c.white};
  cv::Mat disparity;
  g->decode(views, disparity, blacks, whites);
  benchmark::DoNotOptimize(disparity.data);
}

void BM_OursDecode(benchmark::State& state) {
  cv::setNumThreads(static_cast<int>(state.range(0)));
  const Capture& c = TestCapture();
  for (auto _ : state) {
    auto d = sl::Decode(c.ours, OpenCvAlikeOptions());
    if (!d.ok()) state.SkipWithError("decode failed");
    benchmark::DoNotOptimize(d->column.data);
  }
}

void BM_OpenCvGetProjPixel(benchmark::State& state) {
  const Capture& c = TestCapture();
  cv::Mat col, row;
  for (auto _ : state) {
    OpenCvCodeMaps(c, &col, &row);
    benchmark::DoNotOptimize(col.data);
  }
}

void BM_OpenCvDecodeTwoViews(benchmark::State& state) {
  const Capture& c = TestCapture();
  for (auto _ : state) OpenCvDecodeTwice(c);
}

BENCHMARK(BM_OursDecode)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK(BM_OpenCvGetProjPixel)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();
BENCHMARK(BM_OpenCvDecodeTwoViews)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1)
    ->UseRealTime();

template <typename F>
double MedianMs(int n, F f) {
  std::vector<double> t;
  for (int i = 0; i < n; ++i) {
    const auto a = std::chrono::steady_clock::now();
    f();
    const auto b = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double, std::milli>(b - a).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const Capture& c = TestCapture();
  // Identical code maps on the pixels both call valid.
  auto ours = sl::Decode(c.ours, OpenCvAlikeOptions());
  if (!ours.ok()) {
    std::fprintf(stderr, "decode failed\n");
    return 1;
  }
  cv::Mat col, row;
  OpenCvCodeMaps(c, &col, &row);
  int shared = 0, differ = 0, only_ours = 0, only_cv = 0;
  for (int y = 0; y < kCamera.height; ++y) {
    for (int x = 0; x < kCamera.width; ++x) {
      const bool a = ours->column.at<int>(y, x) >= 0,
                 b = col.at<int>(y, x) >= 0;
      only_ours += a && !b;
      only_cv += b && !a;
      if (!a || !b) continue;
      ++shared;
      differ += ours->column.at<int>(y, x) != col.at<int>(y, x) ||
                ours->row.at<int>(y, x) != row.at<int>(y, x);
    }
  }
  std::printf(
      "code maps: %d pixels valid in both, %d differ; valid only in ours %d, "
      "only in OpenCV %d\n",
      shared, differ, only_ours, only_cv);

  cv::setNumThreads(1);
  const double ours1 = MedianMs(9, [&] {
    auto d = sl::Decode(c.ours, OpenCvAlikeOptions());
    benchmark::DoNotOptimize(d->column.data);
  });
  cv::setNumThreads(2);
  const double ours2 = MedianMs(9, [&] {
    auto d = sl::Decode(c.ours, OpenCvAlikeOptions());
    benchmark::DoNotOptimize(d->column.data);
  });
  const double proj = MedianMs(3, [&] { OpenCvCodeMaps(c, &col, &row); });
  const double dec2 = MedianMs(3, [&] { OpenCvDecodeTwice(c); });
  const double dec = dec2 / 2;
  std::printf(
      "median ms: ours %.2f (1 thread), %.2f (2 threads); OpenCV "
      "getProjPixel loop %.1f; OpenCV decode(two views) %.1f -> per view "
      "%.1f\n",
      ours1, ours2, proj, dec2, dec);
  std::printf(
      "ratio ours(1 thread) / OpenCV decode per view: %.4f; / getProjPixel: "
      "%.4f; ours(2 threads) / decode per view: %.4f\n",
      ours1 / dec, ours1 / proj, ours2 / dec);
  const bool pass = differ == 0 && ours1 / dec <= 0.05;
  std::printf("%s (target: identical codes, ratio <= 0.05)\n",
              pass ? "PASS" : "FAIL");

  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return pass ? 0 : 1;
}
