// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/camera_model.h"

#include <gtest/gtest.h>
#include <libraw/libraw.h>

#include <cmath>
#include <limits>
#include <vector>

#include "hardware/sim/scene.h"

namespace hdrstereo::sim {
namespace {

// The thesis' eight exposures (chapter 3).
const std::vector<double> kExposures = {1.0 / 2000, 1.0 / 1000, 1.0 / 500,
                                        1.0 / 250,  1.0 / 125,  1.0 / 60,
                                        1.0 / 30,   1.0 / 15};

// Radiance ramp over 6 decades, 0.01 .. 10000 cd/m^2, per channel offsets.
cv::Mat RadianceRamp() {
  cv::Mat r(8, 200, CV_32FC3);
  for (int y = 0; y < r.rows; ++y) {
    for (int x = 0; x < r.cols; ++x) {
      const float v = static_cast<float>(0.01 * std::pow(10.0, 6.0 * x / 199));
      r.at<cv::Vec3f>(y, x) = cv::Vec3f(v, 0.5f * v, 0.25f * v);
    }
  }
  return r;
}

SensorModel NoiseFree() {
  SensorModel s;
  s.shot_noise = false;
  s.read_noise_e = 0;
  return s;
}

TEST(CameraModelTest, SignalIsLinearInExposureBeforeClipping) {
  const cv::Mat radiance = RadianceRamp();
  const SensorModel sensor = NoiseFree();
  for (double t : kExposures) {
    const cv::Mat e1 = ExposeSensor(radiance, sensor, {t, 100}, 1);
    const cv::Mat e2 = ExposeSensor(radiance, sensor, {2 * t, 100}, 1);
    const cv::Mat iso = ExposeSensor(radiance, sensor, {t, 200}, 1);
    for (int x = 0; x < radiance.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        const double a = e1.at<cv::Vec3f>(0, x)[c];
        const double expected =
            radiance.at<cv::Vec3f>(0, x)[c] * t * sensor.electrons_per_exposure;
        ASSERT_NEAR(a, expected, 1e-6 * expected);
        ASSERT_NEAR(e2.at<cv::Vec3f>(0, x)[c], 2 * a, 1e-6 * a);
        ASSERT_NEAR(iso.at<cv::Vec3f>(0, x)[c], 2 * a, 1e-6 * a);
      }
    }
  }
}

TEST(CameraModelTest, PixelValuesAreMonotonicInExposureAndSaturateAtMax) {
  const cv::Mat radiance = RadianceRamp();
  const SensorModel sensor = NoiseFree();
  for (int bits : {8, 16}) {
    const int max_value = bits == 8 ? 255 : 65535;
    cv::Mat prev;
    int strictly_increasing = 0;
    for (double t : kExposures) {
      const cv::Mat e = ExposeSensor(radiance, sensor, {t, 100}, 1);
      cv::Mat v;
      Digitize(e, sensor, bits).convertTo(v, CV_32S);
      for (int x = 0; x < v.cols; ++x) {
        for (int c = 0; c < 3; ++c) {
          const int value = v.at<cv::Vec3i>(0, x)[c];
          if (e.at<cv::Vec3f>(0, x)[c] >= sensor.full_well_e) {
            ASSERT_EQ(value, max_value) << "saturated pixel x=" << x;
          } else {
            ASSERT_LE(value, max_value);
          }
          if (!prev.empty()) {
            const int before = prev.at<cv::Vec3i>(0, x)[c];
            ASSERT_GE(value, before) << "x=" << x << " t=" << t;
            strictly_increasing += value > before;
          }
        }
      }
      prev = v;
    }
    EXPECT_GT(strictly_increasing, 500);  // of 4200: a real change, not flat
  }
}

TEST(CameraModelTest, SaturatedPixelsAreExactlyMaxEvenWithNoise) {
  const cv::Mat radiance = RadianceRamp();
  SensorModel sensor;  // shot + read noise on
  const cv::Mat e_clean =
      ExposeSensor(radiance, NoiseFree(), {1.0 / 15, 100}, 1);
  const cv::Mat e = ExposeSensor(radiance, sensor, {1.0 / 15, 100}, 7);
  const cv::Mat v = Digitize(e, sensor, 8);
  int saturated = 0;
  for (int y = 0; y < v.rows; ++y) {
    for (int x = 0; x < v.cols; ++x) {
      for (int c = 0; c < 3; ++c) {
        // 10% above full well is > 50 sigma of noise away from it.
        if (e_clean.at<cv::Vec3f>(y, x)[c] > 1.1 * sensor.full_well_e) {
          ASSERT_EQ(v.at<cv::Vec3b>(y, x)[c], 255);
          ++saturated;
        }
      }
    }
  }
  EXPECT_GT(saturated, 100);
}

TEST(CameraModelTest, NoiseHasShotAndReadVariance) {
  SensorModel sensor;
  sensor.read_noise_e = 10;
  // 1000 electrons expected at 1/100 s: radiance = 1000 / (0.01 * 3333).
  const float radiance_value =
      static_cast<float>(1000.0 / (0.01 * sensor.electrons_per_exposure));
  const cv::Mat radiance(200, 200, CV_32FC3, cv::Scalar::all(radiance_value));
  const cv::Mat e = ExposeSensor(radiance, sensor, {0.01, 100}, 3);
  cv::Scalar mean, stddev;
  cv::meanStdDev(e.reshape(1), mean, stddev);
  // 120000 samples: the mean is within 5 standard errors, the variance
  // (1000 + 100) within 3%.
  EXPECT_NEAR(mean[0], 1000.0, 5 * std::sqrt(1100.0 / 120000));
  EXPECT_NEAR(stddev[0] * stddev[0], 1100.0, 0.03 * 1100);
  // Seeded: the same seed gives the same values, another seed others.
  const cv::Mat again = ExposeSensor(radiance, sensor, {0.01, 100}, 3);
  const cv::Mat other = ExposeSensor(radiance, sensor, {0.01, 100}, 4);
  EXPECT_EQ(cv::norm(e, again, cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(e, other, cv::NORM_INF), 0.0);
}

// Digitize and MosaicBayer take any float: below 0 electrons (read noise),
// -inf and NaN read as 0 electrons, +inf as full well; nothing indexes the
// response table or rounds out of range.
TEST(CameraModelTest, NonFiniteAndNegativeElectronsDigitizeWithinRange) {
  const SensorModel sensor = NoiseFree();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  const float full_well = static_cast<float>(sensor.full_well_e);
  // Pixel i holds values[i] in all three channels.
  const std::vector<float> values = {std::numeric_limits<float>::quiet_NaN(),
                                     -kInf,
                                     -5.0f,
                                     0.0f,
                                     kInf,
                                     2 * full_well};
  const std::vector<int> expected_fraction = {0, 0, 0, 0, 1, 1};
  cv::Mat e(1, static_cast<int>(values.size()), CV_32FC3);
  for (size_t i = 0; i < values.size(); ++i) {
    e.at<cv::Vec3f>(0, static_cast<int>(i)) = cv::Vec3f::all(values[i]);
  }
  for (int bits : {8, 16}) {
    const int max_value = bits == 8 ? 255 : 65535;
    cv::Mat v;
    Digitize(e, sensor, bits).convertTo(v, CV_32S);
    for (size_t i = 0; i < values.size(); ++i) {
      EXPECT_EQ(v.at<cv::Vec3i>(0, static_cast<int>(i)),
                cv::Vec3i::all(expected_fraction[i] * max_value))
          << bits << " bits, electrons " << values[i];
    }
  }
  const cv::Mat bayer = MosaicBayer(e, sensor);
  for (size_t i = 0; i < values.size(); ++i) {
    EXPECT_EQ(bayer.at<uint16_t>(0, static_cast<int>(i)),
              expected_fraction[i] * sensor.raw_white_level)
        << "electrons " << values[i];
  }
}

// Noise on an infinite radiance would be inf - inf = NaN, a black pixel:
// the pixel stays saturated.
TEST(CameraModelTest, InfiniteRadianceSaturatesEvenWithNoise) {
  SensorModel sensor;  // shot + read noise on
  ASSERT_TRUE(sensor.shot_noise);
  const cv::Mat radiance(
      4, 4, CV_32FC3, cv::Scalar::all(std::numeric_limits<float>::infinity()));
  const cv::Mat e = ExposeSensor(radiance, sensor, {1.0 / 125, 100}, 2);
  cv::Mat v;
  Digitize(e, sensor, 8).convertTo(v, CV_32S);
  for (int y = 0; y < v.rows; ++y) {
    for (int x = 0; x < v.cols; ++x) {
      EXPECT_EQ(v.at<cv::Vec3i>(y, x), cv::Vec3i::all(255))
          << "x=" << x << " y=" << y << " electrons "
          << e.at<cv::Vec3f>(y, x)[0];
    }
  }
}

TEST(CameraModelTest, DngDecodesWithLibRawToTheSameMosaic) {
  SensorModel sensor;
  cv::Mat radiance(48, 64, CV_32FC3);
  cv::randu(radiance, 0.0, 100.0);
  const cv::Mat e = ExposeSensor(radiance, sensor, {1.0 / 30, 100}, 9);
  const cv::Mat bayer = MosaicBayer(e, sensor);
  absl::StatusOr<std::string> dng = EncodeDng(bayer, sensor, {1.0 / 30, 100});
  ASSERT_TRUE(dng.ok()) << dng.status();

  LibRaw raw;
  ASSERT_EQ(raw.open_buffer(dng->data(), dng->size()), LIBRAW_SUCCESS);
  ASSERT_EQ(raw.unpack(), LIBRAW_SUCCESS);
  ASSERT_EQ(raw.imgdata.sizes.raw_width, 64);
  ASSERT_EQ(raw.imgdata.sizes.raw_height, 48);
  ASSERT_NE(raw.imgdata.rawdata.raw_image, nullptr);
  // RGGB: red at (0, 0), blue at (1, 1) (LibRaw colours: 0 R, 1 G, 2 B, 3 G).
  EXPECT_EQ(raw.COLOR(0, 0), 0);
  EXPECT_EQ(raw.COLOR(1, 1), 2);
  EXPECT_EQ(raw.imgdata.color.maximum,
            static_cast<unsigned>(sensor.raw_white_level));
  int mismatches = 0;
  for (int y = 0; y < 48; ++y) {
    for (int x = 0; x < 64; ++x) {
      mismatches +=
          raw.imgdata.rawdata.raw_image[y * 64 + x] != bayer.at<uint16_t>(y, x);
    }
  }
  EXPECT_EQ(mismatches, 0);
}

}  // namespace
}  // namespace hdrstereo::sim
