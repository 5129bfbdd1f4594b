// SPDX-License-Identifier: GPL-3.0-or-later
//
// FrameChecker against frames whose truth is known: files stamped with the
// EXIF writer at known settings, and a real camera's JPEGs whose exposures
// the data folder documents.
#include "daemon/jobs/frame_check.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "absl/strings/str_cat.h"
#include "processing/io/exif.h"

namespace hdrstereo::jobs {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// A PNG as a camera would deliver it, stamped with `exif`; the pixel value
// makes the bytes differ between frames.
hardware::Frame Stamped(const io::ExifInfo& exif, int value,
                        const std::string& name) {
  cv::Mat img(4, 4, CV_8UC3, cv::Scalar(value, value, value));
  std::vector<uint8_t> buf;
  cv::imencode(".png", img, buf);
  hardware::Frame frame;
  frame.bytes = *io::EmbedExif(std::string(buf.begin(), buf.end()),
                               io::EncodeExifTiff(exif));
  frame.format = hardware::ImageFormat::kPng8;
  frame.camera_file_name = name;
  frame.stored_to = hardware::StoredTo::kRam;
  return frame;
}

io::ExifInfo At(double exposure_s, int iso, double f, const char* subsec) {
  io::ExifInfo exif;
  exif.exposure_s = exposure_s;
  exif.iso = iso;
  exif.aperture = f;
  exif.date_time_original = "2026:12:02 06:00:00";
  exif.subsec_time_original = subsec;
  return exif;
}

// "ok", or what the checker found (so that a failure prints it).
std::string Verdict(const std::optional<Mismatch>& m) {
  return m.has_value()
             ? absl::StrCat(store::EventKindName(m->kind), ": ", m->message)
             : "ok";
}

const hardware::ExposureSettings kSet{.exposure_s = 1.0 / 125,
                                      .iso = 100,
                                      .aperture_f = 8,
                                      .format = std::nullopt};

TEST(FrameCheckTest, AMatchingFrameIsAcceptedAndItsValuesRead) {
  FrameChecker checker;
  const CameraReport report =
      ReadCameraReport(Stamped(At(1.0 / 125, 100, 8, "250"), 1, "A.PNG"));
  EXPECT_EQ(Verdict(checker.Check(kSet, report)), "ok");
  EXPECT_DOUBLE_EQ(report.exposure_s.value_or(0), 1.0 / 125);
  EXPECT_EQ(report.iso.value_or(0), 100);
  EXPECT_EQ(report.aperture_f.value_or(0), 8);
  EXPECT_EQ(report.time_ms.value_or(0), 1796191200250);
  EXPECT_TRUE(report.time_has_subseconds);
  EXPECT_EQ(report.file_name, "A.PNG");
  EXPECT_EQ(report.sha256.size(), 64u);
}

TEST(FrameCheckTest, ExposureToleranceIsOneSixthStop) {
  FrameChecker checker;
  // 1/125 s is 6.97 stops below 1 s; 0.15 stop off passes, 0.2 fails.
  const double within = (1.0 / 125) * std::pow(2.0, 0.15);
  const double beyond = (1.0 / 125) * std::pow(2.0, -0.2);
  EXPECT_EQ(
      Verdict(checker.Check(kSet, ReadCameraReport(Stamped(
                                      At(within, 100, 8, "1"), 1, "A.PNG")))),
      "ok");
  std::optional<Mismatch> off = checker.Check(
      kSet, ReadCameraReport(Stamped(At(beyond, 100, 8, "2"), 2, "B.PNG")));
  ASSERT_TRUE(off.has_value());
  EXPECT_EQ(off->kind, store::EventKind::kWrongExposure);
  EXPECT_THAT(off->message, HasSubstr("not the 1/125 s set"));
  EXPECT_THAT(off->message, HasSubstr("0.20 stops off"));
}

TEST(FrameCheckTest, AnotherIsoOrFNumberIsCaughtNamingBothValues) {
  FrameChecker checker;
  std::optional<Mismatch> iso = checker.Check(
      kSet, ReadCameraReport(Stamped(At(1.0 / 125, 200, 8, "1"), 1, "A.PNG")));
  ASSERT_TRUE(iso.has_value());
  EXPECT_EQ(iso->kind, store::EventKind::kWrongIso);
  EXPECT_THAT(iso->message, HasSubstr("ISO 200, not the ISO 100 set"));
  std::optional<Mismatch> f = checker.Check(
      kSet,
      ReadCameraReport(Stamped(At(1.0 / 125, 100, 5.6, "1"), 1, "A.PNG")));
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->kind, store::EventKind::kWrongAperture);
  EXPECT_THAT(f->message, HasSubstr("f/5.6, not the f/8 set"));
  // Settings left "as is" (0) are not checked.
  EXPECT_EQ(
      Verdict(checker.Check(
          {.exposure_s = 1.0 / 125,
           .iso = 0,
           .aperture_f = 0,
           .format = std::nullopt},
          ReadCameraReport(Stamped(At(1.0 / 125, 3200, 2, "1"), 1, "A.PNG")))),
      "ok");
}

TEST(FrameCheckTest, ThePreviousFileAgainIsCaughtThreeWays) {
  FrameChecker checker;
  const hardware::Frame first =
      Stamped(At(1.0 / 125, 100, 8, "100"), 1, "IMG_0001.PNG");
  checker.Remember(ReadCameraReport(first));
  // The same bytes.
  std::optional<Mismatch> again = checker.Check(kSet, ReadCameraReport(first));
  ASSERT_TRUE(again.has_value());
  EXPECT_EQ(again->kind, store::EventKind::kPreviousFile);
  EXPECT_THAT(again->message, HasSubstr("IMG_0001.PNG, identical bytes"));
  // Other bytes (re-encoded) but the same sub-second camera time.
  std::optional<Mismatch> same_time =
      checker.Check(kSet, ReadCameraReport(Stamped(At(1.0 / 125, 100, 8, "100"),
                                                   2, "IMG_0002.PNG")));
  ASSERT_TRUE(same_time.has_value());
  EXPECT_EQ(same_time->kind, store::EventKind::kPreviousFile);
  // The same name and whole-second time (no sub-seconds).
  io::ExifInfo coarse = At(1.0 / 125, 100, 8, "");
  checker.Remember(ReadCameraReport(Stamped(coarse, 3, "capt0000.jpg")));
  EXPECT_TRUE(
      checker.Check(kSet, ReadCameraReport(Stamped(coarse, 4, "capt0000.jpg")))
          .has_value());
  // A camera that names every RAM capture capt0000.jpg is fine as long as
  // the frames are new.
  coarse.date_time_original = "2026:12:02 06:00:01";
  EXPECT_EQ(Verdict(checker.Check(
                kSet, ReadCameraReport(Stamped(coarse, 5, "capt0000.jpg")))),
            "ok");
}

TEST(FrameCheckTest, AFileOnTheCardIsCaught) {
  FrameChecker checker;
  hardware::Frame frame =
      Stamped(At(1.0 / 125, 100, 8, "1"), 1, "IMG_0001.PNG");
  frame.stored_to = hardware::StoredTo::kCard;
  std::optional<Mismatch> m = checker.Check(kSet, ReadCameraReport(frame));
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->kind, store::EventKind::kCardTarget);
  EXPECT_THAT(m->message, HasSubstr("IMG_0001.PNG on its card, not in RAM"));
}

// A real bracket (Olympus TG-4, 1/1250, 1/320, 1/40 s at f/2, ISO 100 per the
// folder's README): each frame passes against its own exposure and fails
// against its neighbour's (2 stops apart).
TEST(FrameCheckRealDataTest, OlympusBracketMatchesItsOwnExposureOnly) {
  const fs::path dir =
      fs::path(HDRSTEREO_SHARED_DIR) / "data/unis-bracket-jpeg";
  if (!fs::exists(dir)) GTEST_SKIP() << dir << " is absent";
  const std::pair<const char*, double> files[] = {{"UNIS_EV-2.jpg", 1.0 / 1250},
                                                  {"UNIS_EV0.jpg", 1.0 / 320},
                                                  {"UNIS_EV2.jpg", 1.0 / 40}};
  FrameChecker checker;
  for (size_t i = 0; i < 3; ++i) {
    std::ifstream in(dir / files[i].first, std::ios::binary);
    std::stringstream bytes;
    bytes << in.rdbuf();
    hardware::Frame frame;
    frame.bytes = bytes.str();
    frame.format = hardware::ImageFormat::kJpeg;
    frame.camera_file_name = files[i].first;
    const CameraReport report = ReadCameraReport(frame);
    const hardware::ExposureSettings own{.exposure_s = files[i].second,
                                         .iso = 100,
                                         .aperture_f = 2,
                                         .format = std::nullopt};
    EXPECT_EQ(Verdict(checker.Check(own, report)), "ok") << files[i].first;
    hardware::ExposureSettings other = own;
    other.exposure_s = files[(i + 1) % 3].second;
    std::optional<Mismatch> m = checker.Check(other, report);
    ASSERT_TRUE(m.has_value()) << files[i].first;
    EXPECT_EQ(m->kind, store::EventKind::kWrongExposure);
    checker.Remember(report);
  }
}

}  // namespace
}  // namespace hdrstereo::jobs
