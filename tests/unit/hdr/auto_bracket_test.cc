// SPDX-License-Identifier: GPL-3.0-or-later
//
// The automatic bracketing algorithm (processing/hdr/auto_bracket.h) on
// synthetic inputs with exact expectations: the options' rules and JSON,
// the photon-transfer noise measurement, the well-exposed window, the
// probe sequence, the radiance estimate and the greedy choice, and the
// refusal of a scene the camera cannot cover (the bad input).
#include "processing/hdr/auto_bracket.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>
#include <vector>

#include "tests/support/option_tests.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::hdr {
namespace {

using ::hdrstereo::testing::ExpectJsonHasEveryField;
using ::hdrstereo::testing::ExpectRulesNameTheirField;
using ::hdrstereo::testing::StatusIs;
using ::testing::AllOf;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

constexpr double kSaturation = 0.98;

TEST(AutoBracketOptionsTest, BadOptionsNameTheField) {
  ExpectRulesNameTheirField<AutoBracketOptions>({
      {[](AutoBracketOptions& o) { o.min_snr = 5; }, "min_snr is 5"},
      {[](AutoBracketOptions& o) { o.max_step_stops = 0; },
       "max_step_stops is 0"},
      {[](AutoBracketOptions& o) { o.max_step_stops = 9; },
       "max_step_stops is 9"},
      {[](AutoBracketOptions& o) { o.exclude_emitters_above = 0.5; },
       "exclude_emitters_above is 0.5"},
      {[](AutoBracketOptions& o) { o.max_uncovered_fraction = 1; },
       "max_uncovered_fraction is 1"},
      {[](AutoBracketOptions& o) { o.max_exposure_s = -1; },
       "max_exposure_s is -1"},
  });
}

TEST(AutoBracketOptionsTest, CanonicalJsonHasEveryField) {
  ExpectJsonHasEveryField<AutoBracketOptions>({
      {"/min_snr", [](AutoBracketOptions& o) { o.min_snr = 20; }},
      {"/max_step_stops", [](AutoBracketOptions& o) { o.max_step_stops = 2; }},
      {"/exclude_emitters_above",
       [](AutoBracketOptions& o) { o.exclude_emitters_above = 100; }},
      {"/max_uncovered_fraction",
       [](AutoBracketOptions& o) { o.max_uncovered_fraction = 0.01; }},
      {"/max_exposure_s", [](AutoBracketOptions& o) { o.max_exposure_s = 1; }},
  });
}

// Two frames of a horizontal ramp of signal 0.001 .. 0.9 with seeded
// Gaussian shot + read noise of a sensor of `full_well` and `read` e-.
std::pair<cv::Mat, cv::Mat> NoisyPair(double full_well, double read) {
  std::mt19937_64 rng(24);
  std::normal_distribution<double> gauss;
  cv::Mat frames[2];
  for (cv::Mat& f : frames) {
    f.create(200, 400, CV_32FC3);
    for (int y = 0; y < f.rows; ++y) {
      for (int x = 0; x < f.cols; ++x) {
        const double signal = 0.001 * std::pow(900.0, x / (f.cols - 1.0));
        const double sigma = std::sqrt(signal / full_well +
                                       read * read / (full_well * full_well));
        for (int c = 0; c < 3; ++c) {
          f.at<cv::Vec3f>(y, x)[c] =
              static_cast<float>(signal + sigma * gauss(rng));
        }
      }
    }
  }
  return {frames[0], frames[1]};
}

TEST(SensorNoiseTest, PhotonTransferFindsFullWellAndReadNoise) {
  const auto [a, b] = NoisyPair(20000, 4);
  ASSERT_OK_AND_ASSIGN(const SensorNoise noise,
                       MeasureSensorNoise(a, b, kSaturation));
  EXPECT_NEAR(noise.full_well_e, 20000, 0.02 * 20000);
  EXPECT_NEAR(noise.read_noise_e, 4, 0.5);
  EXPECT_GE(noise.levels, 30);  // a quarter stop each over 9.8 stops
  // sigma^2 = x / F + (R / F)^2.
  const SensorNoise exact{20000, 4, 0};
  EXPECT_DOUBLE_EQ(exact.Sigma(0.5), std::sqrt(0.5 / 20000 + 16 / 4e8));
  EXPECT_DOUBLE_EQ(exact.Snr(0.5), 0.5 / exact.Sigma(0.5));
}

TEST(SensorNoiseTest, RefusesFramesItCannotMeasure) {
  const cv::Mat flat(50, 50, CV_32FC3, cv::Scalar::all(0.3));
  EXPECT_THAT(MeasureSensorNoise(flat, flat, kSaturation),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("0 signal level(s)")));
  // 0.3242 is the middle of a quarter-stop bin, 5 sigma from its edges.
  const cv::Mat level(50, 50, CV_32FC3, cv::Scalar::all(0.3242));
  cv::Mat noisy = level.clone();
  cv::randn(noisy, cv::Scalar::all(0.3242), cv::Scalar::all(0.01));
  EXPECT_THAT(MeasureSensorNoise(level, noisy, kSaturation),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("1 signal level(s) over 0.0 stops")));
  EXPECT_THAT(MeasureSensorNoise(flat, cv::Mat(40, 50, CV_32FC3), kSaturation),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("probe 1 differs in size")));
  EXPECT_THAT(MeasureSensorNoise(cv::Mat(50, 50, CV_8UC3), flat, kSaturation),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("not a linear CV_32F image")));
}

TEST(WellExposedWindowTest, SnrAtTheBottomAndHeadroomAtTheTop) {
  const SensorNoise noise{20000, 4, 0};
  ASSERT_OK_AND_ASSIGN(const ExposureWindow w,
                       WellExposedWindow(noise, 40, kSaturation));
  EXPECT_NEAR(noise.Snr(w.min_signal), 40, 1e-9);
  EXPECT_NEAR(w.max_signal + 5 * noise.Sigma(w.max_signal), kSaturation, 1e-12);
  // 40^2 / (2 F) (1 + sqrt(1 + 4 R^2 / 40^2)).
  EXPECT_NEAR(w.min_signal, 0.04 * (1 + std::sqrt(1.04)), 1e-12);
  EXPECT_EQ(w.min_snr, 40);
  EXPECT_NEAR(w.Stops(), std::log2(w.max_signal / w.min_signal), 1e-12);
  // The best SNR below saturation of this sensor is about 138.
  EXPECT_THAT(WellExposedWindow(noise, 200, kSaturation),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       AllOf(HasSubstr("reaches SNR 137"),
                             HasSubstr("min_snr 200 is out of its reach"))));
}

TEST(ShutterSpeedsTest, ThirdStopsOfADslrWithinTheRange) {
  const std::vector<double> all = ThirdStopShutterSpeeds(1.0 / 8000, 30);
  EXPECT_EQ(all.size(), 55u);
  EXPECT_DOUBLE_EQ(all.front(), 1.0 / 8000);
  EXPECT_DOUBLE_EQ(all.back(), 30);
  EXPECT_TRUE(std::is_sorted(all.begin(), all.end()));
  EXPECT_THAT(ThirdStopShutterSpeeds(1.0 / 20, 0.3),
              ElementsAre(1.0 / 20, 1.0 / 15, 1.0 / 13, 1.0 / 10, 1.0 / 8,
                          1.0 / 6, 1.0 / 5, 1.0 / 4, 0.3));
}

// A 1 x n one-channel probe with these readings.
Probe ProbeOf(std::vector<float> readings, double exposure_s) {
  return {cv::Mat(readings, true).reshape(1, 1), exposure_s};
}

const ExposureWindow kWindow{0.1, 0.8, 40};  // reach 0.8 / (0.1 * 1.125)
const std::vector<double> kPowersOfTwo = {
    1.0 / 64, 1.0 / 32, 1.0 / 16, 1.0 / 8, 1.0 / 4, 1.0 / 2, 1, 2, 4, 8, 16};

TEST(NextProbeTest, StartsInTheMiddleThenReachesForBothEnds) {
  // sqrt(1/64 * 16) = 1/2.
  EXPECT_EQ(NextProbeExposure({}, kWindow, kSaturation, kPowersOfTwo), 0.5);
  // Clipped: the shortest choice at most 7.1x shorter than 1/2 is 1/8.
  EXPECT_EQ(NextProbeExposure({ProbeOf({0.99f, 0.5f}, 0.5)}, kWindow,
                              kSaturation, kPowersOfTwo),
            1.0 / 8);
  // Dark: twice min_signal for 0.02 is 10x longer, capped at 7.1x: 2.
  EXPECT_EQ(NextProbeExposure({ProbeOf({0.02f, 0.5f}, 0.5)}, kWindow,
                              kSaturation, kPowersOfTwo),
            2);
  // Just below: twice min_signal for 0.09 is 1.11 s; the next choice up.
  EXPECT_EQ(NextProbeExposure({ProbeOf({0.09f, 0.5f}, 0.5)}, kWindow,
                              kSaturation, kPowersOfTwo),
            2);
  // Brighter first, then darker.
  EXPECT_EQ(NextProbeExposure({ProbeOf({0.99f, 0.02f}, 0.5)}, kWindow,
                              kSaturation, kPowersOfTwo),
            1.0 / 8);
  // Below in one probe, clipped in the next: between them.
  EXPECT_EQ(NextProbeExposure(
                {ProbeOf({0.05f, 0.5f}, 1.0 / 16), ProbeOf({0.99f, 0.9f}, 1)},
                kWindow, kSaturation, kPowersOfTwo),
            0.25);
  // Every channel read in the window by some probe: done.
  EXPECT_EQ(NextProbeExposure(
                {ProbeOf({0.05f, 0.5f}, 1.0 / 16), ProbeOf({0.4f, 0.9f}, 0.5)},
                kWindow, kSaturation, kPowersOfTwo),
            std::nullopt);
  // Nothing shorter or longer to take: done too.
  EXPECT_EQ(NextProbeExposure({ProbeOf({0.99f, 0.02f}, 1.0 / 64),
                               ProbeOf({0.99f, 0.02f}, 16)},
                              kWindow, kSaturation, kPowersOfTwo),
            std::nullopt);
}

TEST(EstimateRadianceTest, BestReadingInTheWindowElseABound) {
  const SensorNoise noise{20000, 4, 0};
  // Channel 0 is read in the window at 1/8 and 1/2 (the higher wins);
  // channel 1 clipped in both; channel 2 below the window in both;
  // channel 3 above max_signal at 1/2 (0.9), inside at 1/8.
  ASSERT_OK_AND_ASSIGN(
      const RadianceEstimate e,
      EstimateRadiance({ProbeOf({0.1f, 0.99f, 0.01f, 0.3f}, 0.125),
                        ProbeOf({0.4f, 1.0f, 0.04f, 0.9f}, 0.5)},
                       noise, kWindow, kSaturation));
  EXPECT_FLOAT_EQ(e.radiance.at<float>(0), 0.8f);
  EXPECT_EQ(e.state.at<uint8_t>(0),
            static_cast<uint8_t>(ChannelState::kMeasured));
  EXPECT_FLOAT_EQ(e.rel_sigma.at<float>(0),
                  static_cast<float>(noise.Sigma(0.4) / 0.4));
  EXPECT_FLOAT_EQ(e.radiance.at<float>(1), kSaturation / 0.125);
  EXPECT_EQ(e.state.at<uint8_t>(1),
            static_cast<uint8_t>(ChannelState::kTooBright));
  EXPECT_FLOAT_EQ(e.radiance.at<float>(2), 0.08f);
  EXPECT_EQ(e.state.at<uint8_t>(2),
            static_cast<uint8_t>(ChannelState::kTooDark));
  EXPECT_FLOAT_EQ(e.radiance.at<float>(3), 2.4f);  // 0.3 / (1/8)
  EXPECT_THAT(
      EstimateRadiance({}, noise, kWindow, kSaturation),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no probes")));
}

// An estimate of exact radiances (no noise): one channel per value.
RadianceEstimate Exact(std::vector<float> radiance) {
  RadianceEstimate e;
  e.radiance = cv::Mat(radiance, true).reshape(1, 1);
  e.rel_sigma = cv::Mat::zeros(e.radiance.size(), CV_32F);
  e.state = cv::Mat::zeros(e.radiance.size(), CV_8U);
  return e;
}

const SensorNoise kNoise{20000, 4, 0};

TEST(ChooseBracketTest, FewestExposuresAtMostOneStepApart) {
  // r = 12.8 needs t in [1/128, 1/16]; r = 0.5 needs [0.2, 1.6].
  AutoBracketOptions options;
  ASSERT_OK_AND_ASSIGN(AutoBracketResult r,
                       ChooseBracket({Exact({12.8f, 3, 0.5f})}, kWindow, kNoise,
                                     kPowersOfTwo, options));
  EXPECT_THAT(r.exposures_s, ElementsAre(0.25, 0.125, 1.0 / 16));
  EXPECT_EQ(r.uncovered_pixels, 0);
  EXPECT_EQ(r.Coverage(), 1);
  EXPECT_DOUBLE_EQ(r.radiance_min, 0.5);
  EXPECT_DOUBLE_EQ(r.radiance_max, 12.8f);  // as the float it was
  EXPECT_NEAR(r.SceneStops(), std::log2(25.6), 1e-6);
  // 0.1 / 16 .. 0.8 / (1/64).
  EXPECT_NEAR(r.CameraStops(), std::log2(0.8 * 64 / (0.1 / 16)), 1e-9);
  // Three stops allowed: one exposure covers both ends of its window.
  options.max_step_stops = 3;
  ASSERT_OK_AND_ASSIGN(r, ChooseBracket({Exact({12.8f, 3, 0.5f})}, kWindow,
                                        kNoise, kPowersOfTwo, options));
  EXPECT_THAT(r.exposures_s, ElementsAre(0.5, 1.0 / 16));
}

TEST(ChooseBracketTest, TwoAtLeastTheSecondLonger) {
  // r = 5 needs [0.02, 0.16]: 1/8, and the merge needs a second.
  ASSERT_OK_AND_ASSIGN(
      const AutoBracketResult r,
      ChooseBracket({Exact({5, 5})}, kWindow, kNoise, kPowersOfTwo, {}));
  EXPECT_THAT(r.exposures_s, ElementsAre(0.25, 0.125));
}

TEST(ChooseBracketTest, EstimatesAreCoveredWithFiveSigmas) {
  // r = 0.8 with a relative sigma of 2 %: [0.1 / (0.8 * 0.9), 0.8 / (0.8 *
  // 1.1)] = [0.139, 0.909]: 1/2 covers it; without the margin 1 would.
  RadianceEstimate e = Exact({0.8f});
  e.rel_sigma.setTo(0.02);
  ASSERT_OK_AND_ASSIGN(const AutoBracketResult r,
                       ChooseBracket({e}, kWindow, kNoise, kPowersOfTwo, {}));
  EXPECT_THAT(r.exposures_s, ElementsAre(1, 0.5));
}

TEST(ChooseBracketTest, EmittersAreExcludedAndReported) {
  // Median of {1, 1, 2, 2000} is 2 (the upper middle); 2000 > 100 x 2.
  AutoBracketOptions options;
  options.exclude_emitters_above = 100;
  ASSERT_OK_AND_ASSIGN(const AutoBracketResult r,
                       ChooseBracket({Exact({1, 1, 2, 2000})}, kWindow, kNoise,
                                     kPowersOfTwo, options));
  EXPECT_EQ(r.pixels, 4);
  EXPECT_EQ(r.emitter_pixels, 1);
  EXPECT_DOUBLE_EQ(r.EmitterFraction(), 0.25);
  EXPECT_DOUBLE_EQ(r.radiance_max, 2);
  EXPECT_THAT(r.Reason(), HasSubstr("1 emitter pixels (25.00 %) excluded"));
  EXPECT_THAT(r.SummaryRows()[3].second,
              HasSubstr("1 pixels (25.00 %) brighter than 100 x"));
}

TEST(ChooseBracketTest, BestCoverageWhenTheSceneExceedsTheCamera) {
  // 1e5 saturates even at 1/64 s; 0.001 stays below SNR 40 at 1 s (the
  // longest allowed); an unmeasured channel is uncovered as well.
  RadianceEstimate e = Exact({1e5f, 1, 0.001f, 4});
  e.state.at<uint8_t>(3) = static_cast<uint8_t>(ChannelState::kTooDark);
  AutoBracketOptions options;
  options.max_exposure_s = 1;
  ASSERT_OK_AND_ASSIGN(
      const AutoBracketResult r,
      ChooseBracket({e}, kWindow, kNoise, kPowersOfTwo, options));
  EXPECT_THAT(r.exposures_s, ElementsAre(1, 0.5));
  EXPECT_EQ(r.uncovered_pixels, 3);
  EXPECT_EQ(r.uncovered_bright, 1);
  EXPECT_EQ(r.uncovered_dark, 2);
  EXPECT_DOUBLE_EQ(r.UncoveredFraction(), 0.75);
  EXPECT_THAT(
      AcceptCoverage(r, options),
      StatusIs(absl::StatusCode::kFailedPrecondition,
               AllOf(HasSubstr("the scene's range exceeds what the camera "
                               "offers"),
                     HasSubstr("the scene spans at least 26.6 stops"),
                     HasSubstr("the camera covers 9.0 stops (1/64 s .. 1 s"),
                     HasSubstr("75.00 % of the non-emitter pixels (3 of 4)"),
                     HasSubstr("1 too bright even at 1/64 s, 2 too dark even "
                               "at 1 s"),
                     HasSubstr("exclude_emitters_above"),
                     HasSubstr("allow longer exposures (max_exposure_s)"))));
  options.max_uncovered_fraction = 0.75;
  EXPECT_OK(AcceptCoverage(r, options));
}

TEST(ChooseBracketTest, NothingMeasuredSaysSoAndOnlyTheRemediesThatApply) {
  // Every channel below SNR 40 even at the longest allowed exposure: the
  // scene's range is unknown, nothing is too bright, and the remedy is a
  // longer exposure (or accepting the loss), not excluding emitters.
  RadianceEstimate e = Exact({1, 1, 1, 1});
  e.state.setTo(static_cast<uint8_t>(ChannelState::kTooDark));
  AutoBracketOptions options;
  options.max_exposure_s = 1.0 / 64;
  ASSERT_OK_AND_ASSIGN(
      const AutoBracketResult r,
      ChooseBracket({e}, kWindow, kNoise, kPowersOfTwo, options));
  EXPECT_EQ(r.uncovered_pixels, 4);
  EXPECT_EQ(r.radiance_max, 0);
  const absl::Status refused = AcceptCoverage(r, options);
  EXPECT_THAT(
      refused,
      StatusIs(absl::StatusCode::kFailedPrecondition,
               AllOf(HasSubstr("the scene's range exceeds what the camera "
                               "offers: no channel of the scene could be "
                               "measured"),
                     HasSubstr("100.00 % of the non-emitter pixels (4 of 4)"),
                     HasSubstr("0 too bright"),
                     HasSubstr("Allow longer exposures (max_exposure_s) or "
                               "accept the uncovered fraction"))));
  EXPECT_THAT(refused.message(),
              ::testing::Not(HasSubstr("exclude_emitters_above")));
}

TEST(ChooseBracketTest, RefusesWhatCannotBeChosenFrom) {
  AutoBracketOptions options;
  options.max_exposure_s = 1.0 / 100;
  EXPECT_THAT(
      ChooseBracket({Exact({1})}, kWindow, kNoise, kPowersOfTwo, options),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("max_exposure_s is 0.01 s, shorter than "
                         "every exposure the camera offers")));
  EXPECT_THAT(
      ChooseBracket({}, kWindow, kNoise, kPowersOfTwo, {}),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no views")));
  options = {};
  options.min_snr = 1;
  EXPECT_THAT(
      ChooseBracket({Exact({1})}, kWindow, kNoise, kPowersOfTwo, options),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("min_snr is 1")));
  // A camera with one exposure cannot give the merge two.
  ASSERT_OK_AND_ASSIGN(
      const AutoBracketResult one,
      ChooseBracket({Exact({5})}, kWindow, kNoise, {0.125}, {}));
  EXPECT_THAT(AcceptCoverage(one, {}),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("no two exposures within 1 stops")));
}

TEST(AutoBracketResultTest, JsonRoundTripAndBadRecords) {
  ASSERT_OK_AND_ASSIGN(
      AutoBracketResult r,
      ChooseBracket({Exact({12.8f, 0.5f})}, kWindow, kNoise, kPowersOfTwo, {}));
  r.probes = 7;
  const std::string text = nlohmann::json(r).dump();
  ASSERT_OK_AND_ASSIGN(const AutoBracketResult back, AutoBracketFromJson(text));
  EXPECT_EQ(nlohmann::json(back).dump(), text);
  EXPECT_EQ(back.Reason(), r.Reason());
  EXPECT_THAT(AutoBracketFromJson("{}"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("not an automatic bracket record")));
  nlohmann::json bad = r;
  bad["exposures_s"] = {0.1, -1};
  EXPECT_THAT(AutoBracketFromJson(bad.dump()),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("exposure -1 s is not > 0")));
}

TEST(MeterAndChooseTest, ProbesEachViewAndPassesErrorsOn) {
  // A two-level scene of a noiseless linear camera cannot be metered: its
  // noise is not measurable.
  const auto flat = [](int, double t) -> absl::StatusOr<cv::Mat> {
    return cv::Mat(20, 20, CV_32FC1, cv::Scalar(std::min(0.99, 2 * t)));
  };
  EXPECT_THAT(MeterAndChoose(2, flat, kPowersOfTwo, kSaturation, {}),
              StatusIs(absl::StatusCode::kFailedPrecondition,
                       HasSubstr("signal level")));
  const auto unplugged = [](int, double) -> absl::StatusOr<cv::Mat> {
    return absl::UnavailableError("camera gone");
  };
  EXPECT_THAT(MeterAndChoose(2, unplugged, kPowersOfTwo, kSaturation, {}),
              StatusIs(absl::StatusCode::kUnavailable, "camera gone"));
  EXPECT_THAT(
      MeterAndChoose(2, unplugged, {}, kSaturation, {}),
      StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr("no exposures")));
}

}  // namespace
}  // namespace hdrstereo::hdr
