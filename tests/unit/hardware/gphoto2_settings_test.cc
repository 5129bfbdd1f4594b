// SPDX-License-Identifier: GPL-3.0-or-later
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hardware/gphoto2/settings.h"

namespace hdrstereo::gphoto2 {
namespace {

using hardware::ImageFormat;
using ::testing::DoubleNear;
using ::testing::HasSubstr;
using ::testing::Optional;

TEST(ShutterSpeedTest, ParsesEveryVendorSpelling) {
  struct Case {
    const char* text;
    double seconds;
  };
  for (const Case& c : std::vector<Case>{
           {"1/8000", 1.0 / 8000}, {"1/125", 1.0 / 125}, {"1/125s", 1.0 / 125},
           {"1/3", 1.0 / 3},       {" 1/3 ", 1.0 / 3},   {"0.3", 0.3},
           {"0.5", 0.5},           {"2.5", 2.5},         {"2.5s", 2.5},
           {"2.5 sec", 2.5},       {"30", 30},           {"30s", 30},
           {"30\"", 30},           {"1\"", 1},           {"1\"3", 1.3},
           {"0\"5", 0.5},          {"2.5\"", 2.5},       {"10/13", 10.0 / 13},
           {"0.0002s", 0.0002},
       }) {
    EXPECT_THAT(ParseShutterSpeed(c.text),
                Optional(DoubleNear(c.seconds, 1e-9)))
        << c.text;
  }
}

TEST(ShutterSpeedTest, BulbTimeAutoAndGarbageAreNotTimed) {
  for (const char* text :
       {"Bulb",   "bulb",   "BULB", "Time", "auto",   "",    "s",      "\"",
        "1/",     "/125",   "1/0",  "0",    "-1/125", "abc", "1/125x", "1..5",
        "1\"3\"", "1.5\"3", "\"3",  "nan",  "inf",    "1e3"}) {
    EXPECT_EQ(ParseShutterSpeed(text), std::nullopt) << text;
  }
  EXPECT_TRUE(IsBulb("Bulb"));
  EXPECT_TRUE(IsBulb(" bulb "));
  EXPECT_FALSE(IsBulb("30"));
}

// Spellings of the real dumps in ../shared/data/gphoto2-config-dumps.
TEST(ShutterSpeedTest, ParsesLocalisedAndMinuteSpellings) {
  struct Case {
    const char* text;
    double seconds;
  };
  for (const Case& c : std::vector<Case>{
           {"0,0002s", 0.0002},      // German Nikon D750
           {"30,0000s", 30},         //
           {"0,0400s", 0.04},        //
           {"3,2000s", 3.2},         //
           {"32/10", 3.2},           // Sony
           {"60m", 3600},            // Fuji X-T4
           {"2m", 120},              //
           {"2.5s", 2.5},            //
           {"10.3", 10.3},           // Canon EOS R5
           {"1/32000", 1.0 / 32000}  // Fuji electronic shutter
       }) {
    EXPECT_THAT(ParseShutterSpeed(c.text),
                Optional(DoubleNear(c.seconds, 1e-9)))
        << c.text;
  }
}

TEST(ShutterSpeedTest, SpecialCodesOfRealCamerasAreNotTimed) {
  // Sony 0xFFFFFFFx and Nikon 0xFFFFFFFF / 10000 s stand for bulb, time or
  // auto, as do the words; none of them may ever be set as an exposure.
  for (const char* text :
       {"65535/65535", "65535/65534", "65535/65533", "429496.7295s",
        "429496,7295s", "429496.7293s", "x 200", "Composite", "Time", "auto",
        "Unknown value 1500", "Unknown value 00a8", "1,000,0s"}) {
    EXPECT_EQ(ParseShutterSpeed(text), std::nullopt) << text;
  }
  EXPECT_EQ(NearestShutterSpeed({"65535/65533", "1/2", "2"}, 1)->choice, "1/2");
}

TEST(ShutterSpeedTest, FormatsSeconds) {
  EXPECT_EQ(FormatSeconds(1.0 / 125), "1/125 s");
  EXPECT_EQ(FormatSeconds(1.0 / 8000), "1/8000 s");
  EXPECT_EQ(FormatSeconds(0.3), "0.3 s");
  EXPECT_EQ(FormatSeconds(30), "30 s");
}

const std::vector<std::string> kCanonShutter = {
    "bulb",  "30",    "15",    "8",      "4",      "2",      "1",
    "0.5",   "0.3",   "1/4",   "1/8",    "1/15",   "1/30",   "1/60",
    "1/125", "1/250", "1/500", "1/1000", "1/2000", "1/4000", "1/8000"};

TEST(NearestShutterSpeedTest, PicksTheNearestInStopsAndReportsIt) {
  absl::StatusOr<ShutterChoice> exact =
      NearestShutterSpeed(kCanonShutter, 1.0 / 125);
  ASSERT_TRUE(exact.ok()) << exact.status();
  EXPECT_EQ(exact->choice, "1/125");

  // 1/100 s lies 0.32 stops from 1/125 and 0.68 from 1/60.
  absl::StatusOr<ShutterChoice> near =
      NearestShutterSpeed(kCanonShutter, 1.0 / 100);
  ASSERT_TRUE(near.ok());
  EXPECT_EQ(near->choice, "1/125");
  EXPECT_DOUBLE_EQ(near->seconds, 1.0 / 125);

  // In stops, not seconds: 0.4 s is nearer 0.5 (0.32 stops) than 0.3 (0.42).
  EXPECT_EQ(NearestShutterSpeed(kCanonShutter, 0.4)->choice, "0.5");
  EXPECT_EQ(NearestShutterSpeed(kCanonShutter, 20)->choice, "15");
  EXPECT_EQ(NearestShutterSpeed(kCanonShutter, 25)->choice, "30");
  EXPECT_EQ(NearestShutterSpeed(kCanonShutter, 1.0 / 8000)->choice, "1/8000");
}

TEST(NearestShutterSpeedTest, TiesGoToTheShorterExposure) {
  // sqrt(2)/8 s is exactly half a stop from 1/8 and from 1/4.
  EXPECT_EQ(NearestShutterSpeed({"1/4", "1/8"}, std::sqrt(2.0) / 8)->choice,
            "1/8");
}

TEST(NearestShutterSpeedTest, NeverUsesBulbAndRejectsOutOfRange) {
  // 5 minutes: bulb would be the only way; refused with the range named.
  absl::StatusOr<ShutterChoice> too_long =
      NearestShutterSpeed(kCanonShutter, 300);
  EXPECT_EQ(too_long.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(too_long.status().message()),
              HasSubstr("1/8000 s .. 30 s"));
  EXPECT_EQ(NearestShutterSpeed(kCanonShutter, 1.0 / 20000).status().code(),
            absl::StatusCode::kInvalidArgument);
  // Within half a stop of the end still maps to it.
  EXPECT_EQ(NearestShutterSpeed(kCanonShutter, 40)->choice, "30");
  for (double bad : {0.0, -1.0, std::nan("")}) {
    EXPECT_EQ(NearestShutterSpeed(kCanonShutter, bad).status().code(),
              absl::StatusCode::kInvalidArgument);
  }
  EXPECT_THAT(
      std::string(NearestShutterSpeed({"Bulb", "Time"}, 1).status().message()),
      HasSubstr("no timed shutter speed"));
}

TEST(NearestShutterSpeedTest, NikonAndSonySpellings) {
  EXPECT_EQ(NearestShutterSpeed(
                {"1/4000", "1/2", "1\"3", "1\"6", "2\"", "30\"", "Bulb"}, 1.4)
                ->choice,
            "1\"3");
  EXPECT_EQ(NearestShutterSpeed({"0.0002s", "0.0080s", "1.0000s", "30.0000s"},
                                1.0 / 125)
                ->choice,
            "0.0080s");
}

TEST(IsoTest, ParsesAndMatchesExactly) {
  EXPECT_THAT(ParseIso("100"), Optional(100));
  EXPECT_THAT(ParseIso("ISO 200"), Optional(200));
  EXPECT_EQ(ParseIso("Auto"), std::nullopt);
  EXPECT_EQ(ParseIso("-100"), std::nullopt);
  EXPECT_EQ(ParseIso("Unknown value 007b"), std::nullopt);
  EXPECT_EQ(ParseIso("Unbekannter Wert 0002"), std::nullopt);
  EXPECT_EQ(ParseIso("100 Multi Frame Noise Reduction"), std::nullopt);
  EXPECT_EQ(*MatchIso({"100 Multi Frame Noise Reduction", "100"}, 100), "100");
  std::vector<std::string> choices = {"Auto", "100", "200", "400"};
  EXPECT_EQ(*MatchIso(choices, 200), "200");
  absl::StatusOr<std::string> missing = MatchIso(choices, 250);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(missing.status().message()),
              HasSubstr("\"Auto\", \"100\", \"200\", \"400\""));
}

TEST(ApertureTest, ParsesAndMatchesNominalValues) {
  EXPECT_THAT(ParseAperture("f/5.6"), Optional(DoubleNear(5.6, 1e-9)));
  EXPECT_THAT(ParseAperture("F8"), Optional(DoubleNear(8, 1e-9)));
  EXPECT_THAT(ParseAperture("2.8"), Optional(DoubleNear(2.8, 1e-9)));
  EXPECT_EQ(ParseAperture("implicit auto"), std::nullopt);
  EXPECT_THAT(ParseAperture("f/3,5"), Optional(DoubleNear(3.5, 1e-9)));
  EXPECT_THAT(ParseAperture("22.0"), Optional(DoubleNear(22, 1e-9)));
  EXPECT_EQ(ParseAperture("Unknown value 0f00"), std::nullopt);
  std::vector<std::string> choices = {"f/4", "f/5.6", "f/8", "f/11"};
  EXPECT_EQ(*MatchAperture(choices, 5.6), "f/5.6");
  EXPECT_EQ(*MatchAperture(choices, 5.66), "f/5.6");
  absl::StatusOr<std::string> missing = MatchAperture(choices, 2.8);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(missing.status().message()), HasSubstr("\"f/11\""));
}

TEST(FormatChoiceTest, ClassifiesVendorNames) {
  struct Case {
    const char* text;
    std::optional<ImageFormat> format;
  };
  for (const Case& c : std::vector<Case>{
           {"RAW", ImageFormat::kRaw},
           {"raw", ImageFormat::kRaw},
           {"mRAW", ImageFormat::kRaw},
           {"NEF (Raw)", ImageFormat::kRaw},
           {"Large Fine JPEG", ImageFormat::kJpeg},
           {"Smaller JPEG", ImageFormat::kJpeg},
           {"JPEG Fine", ImageFormat::kJpeg},
           {"Extra Fine", ImageFormat::kJpeg},
           {"RAW + Large Fine JPEG", ImageFormat::kRawAndJpeg},
           {"cRAW + Large Fine JPEG", ImageFormat::kRawAndJpeg},
           {"NEF+Fine", ImageFormat::kRawAndJpeg},
           {"NEF+Fein", ImageFormat::kRawAndJpeg},
           {"JPEG Fein", ImageFormat::kJpeg},
           {"RAW+JPEG", ImageFormat::kRawAndJpeg},
           {"TIFF (RGB)", std::nullopt},
           {"", std::nullopt},
       }) {
    EXPECT_EQ(ClassifyFormatChoice(c.text), c.format) << c.text;
  }
}

TEST(FormatChoiceTest, PicksFullSizeRawAndTheLargestFinestJpeg) {
  const std::vector<std::string> canon = {"Large Fine JPEG",
                                          "Large Normal JPEG",
                                          "Medium Fine JPEG",
                                          "Small Fine JPEG",
                                          "mRAW",
                                          "sRAW",
                                          "RAW + Large Normal JPEG",
                                          "RAW + Large Fine JPEG",
                                          "RAW",
                                          "mRAW + Large Fine JPEG"};
  EXPECT_EQ(*MatchFormatChoice(canon, ImageFormat::kRaw), "RAW");
  EXPECT_EQ(*MatchFormatChoice(canon, ImageFormat::kJpeg), "Large Fine JPEG");
  EXPECT_EQ(*MatchFormatChoice(canon, ImageFormat::kRawAndJpeg),
            "RAW + Large Fine JPEG");

  const std::vector<std::string> nikon = {"JPEG Basic", "JPEG Normal",
                                          "JPEG Fine",  "NEF (Raw)",
                                          "NEF+Basic",  "NEF+Fine"};
  EXPECT_EQ(*MatchFormatChoice(nikon, ImageFormat::kRaw), "NEF (Raw)");
  EXPECT_EQ(*MatchFormatChoice(nikon, ImageFormat::kJpeg), "JPEG Fine");
  EXPECT_EQ(*MatchFormatChoice(nikon, ImageFormat::kRawAndJpeg), "NEF+Fine");

  absl::StatusOr<std::string> none =
      MatchFormatChoice({"Large Fine JPEG"}, ImageFormat::kRaw);
  EXPECT_EQ(none.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_THAT(std::string(none.status().message()),
              HasSubstr("\"Large Fine JPEG\""));
  EXPECT_EQ(MatchFormatChoice(canon, ImageFormat::kPng8).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(FileNameTest, FormatFromExtension) {
  EXPECT_EQ(FormatFromFileName("IMG_0001.JPG"), ImageFormat::kJpeg);
  EXPECT_EQ(FormatFromFileName("capt0000.jpeg"), ImageFormat::kJpeg);
  EXPECT_EQ(FormatFromFileName("IMG_0001.CR2"), ImageFormat::kRaw);
  EXPECT_EQ(FormatFromFileName("DSC_0001.NEF"), ImageFormat::kRaw);
  EXPECT_EQ(FormatFromFileName("a.dng"), ImageFormat::kRaw);
  EXPECT_EQ(FormatFromFileName("MVI_0001.MOV"), std::nullopt);
  EXPECT_EQ(FormatFromFileName("noextension"), std::nullopt);
  EXPECT_EQ(FileExtension("IMG_0001.CR2"), "cr2");
  EXPECT_EQ(FileExtension("x."), "");
}

TEST(CaptureTargetTest, MatchesRamAndCard) {
  std::vector<std::string> choices = {"Internal RAM", "Memory card"};
  EXPECT_EQ(*MatchCaptureTarget(choices, CaptureTarget::kInternalRam),
            "Internal RAM");
  EXPECT_EQ(*MatchCaptureTarget(choices, CaptureTarget::kMemoryCard),
            "Memory card");
  EXPECT_EQ(
      MatchCaptureTarget({"SDRAM"}, CaptureTarget::kMemoryCard).status().code(),
      absl::StatusCode::kInvalidArgument);
  // German Nikon dumps, and Nikon's "card+sdram" (both) after the one meant.
  const std::vector<std::string> german = {"interner Speicher",
                                           "Speicherkarte"};
  EXPECT_EQ(*MatchCaptureTarget(german, CaptureTarget::kInternalRam),
            "interner Speicher");
  EXPECT_EQ(*MatchCaptureTarget(german, CaptureTarget::kMemoryCard),
            "Speicherkarte");
  const std::vector<std::string> nikon = {"card+sdram", "sdram", "card"};
  EXPECT_EQ(*MatchCaptureTarget(nikon, CaptureTarget::kInternalRam), "sdram");
  EXPECT_EQ(*MatchCaptureTarget(nikon, CaptureTarget::kMemoryCard), "card");
}

TEST(CaptureTargetTest, ParsesConfigText) {
  EXPECT_EQ(*ParseCaptureTarget("RAM"), CaptureTarget::kInternalRam);
  EXPECT_EQ(*ParseCaptureTarget("card"), CaptureTarget::kMemoryCard);
  EXPECT_EQ(*ParseCaptureTarget(""), CaptureTarget::kLeaveAsIs);
  EXPECT_EQ(ParseCaptureTarget("sdcard").status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(CameraPortTest, PtpIpPortsAreCheckedAndGetTheirEventPort) {
  EXPECT_EQ(*NormalizeCameraPort("usb:001,004"), "usb:001,004");
  EXPECT_EQ(*NormalizeCameraPort(""), "");
  EXPECT_EQ(*NormalizeCameraPort("ptpip:192.168.1.20"), "ptpip:192.168.1.20");
  EXPECT_EQ(*NormalizeCameraPort("ptpip:127.0.0.1:4000"),
            "ptpip:127.0.0.1:4000:4000");
  EXPECT_EQ(*NormalizeCameraPort("ptpip:127.0.0.1:4000:4001"),
            "ptpip:127.0.0.1:4000:4001");
  for (const char* bad :
       {"ptpip:", "ptpip:host.lab", "ptpip:::1", "ptpip:10.0.0.1:0",
        "ptpip:10.0.0.1:x", "ptpip:10.0.0.1:1:2:3"}) {
    EXPECT_EQ(NormalizeCameraPort(bad).status().code(),
              absl::StatusCode::kInvalidArgument)
        << bad;
  }
  EXPECT_TRUE(IsNetworkPort("ptpip:10.0.0.1"));
  EXPECT_FALSE(IsNetworkPort("usb:001,004"));
}

TEST(BatteryTest, ParsesPercentAndWords) {
  EXPECT_EQ(ParseBatteryPercent("100%"), 100);
  EXPECT_EQ(ParseBatteryPercent("75 %"), 75);
  EXPECT_EQ(ParseBatteryPercent("Full"), 100);
  EXPECT_EQ(ParseBatteryPercent("Low"), 10);
  EXPECT_EQ(ParseBatteryPercent("Unknown"), -1);
  EXPECT_EQ(ParseBatteryPercent("250%"), -1);
}

}  // namespace
}  // namespace hdrstereo::gphoto2
