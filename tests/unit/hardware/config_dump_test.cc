// SPDX-License-Identifier: GPL-3.0-or-later
//
// The `gphoto2 --list-all-config` reader and the replay camera on small
// dumps written the way real ones are (the real ones are replayed in
// gphoto2_dump_test.cc): every widget type, Readonly lines, "(null)",
// German labels with decimal commas, CRLF, bytes that are not UTF-8.
#include "hardware/gphoto2/config_dump.h"

#include <gmock/gmock.h>
#include <gphoto2/gphoto2-port-result.h>
#include <gphoto2/gphoto2-result.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_replace.h"
#include "hardware/gphoto2/gphoto2_camera.h"
#include "hardware/gphoto2/replay_api.h"
#include "hardware/gphoto2/widgets.h"
#include "hardware/reconnecting_camera.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::gphoto2 {
namespace {

// The settings to configure (format left as is).
hardware::ExposureSettings Exposure(double seconds, int iso = 0,
                                    double aperture_f = 0) {
  hardware::ExposureSettings s;
  s.exposure_s = seconds;
  s.iso = iso;
  s.aperture_f = aperture_f;
  return s;
}

using ::hdrstereo::testing::IsOk;
using ::hdrstereo::testing::StatusIs;
using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A German Nikon dump in the newer format (Readonly lines), cut down.
constexpr char kGermanNikon[] = R"(Kamerazusammenfassung:
Hersteller: Nikon Corporation
Modell: D750
  Seriennummer: 0000000000000000000000000nnnnnnn

/main/actions/bulb
Label: Langzeit Belichtungsmodus
Readonly: 0
Type: TOGGLE
Current: 2
/main/settings/datetime
Label: Kamera Datum und Zeit
Readonly: 0
Type: DATE
Current: 1417637635
Printable: Mi 03 Dez 2014 21:13:55 CET
Help: Use 'now' as the current time when setting.

/main/settings/capturetarget
Label: Aufnahmeziel
Readonly: 0
Type: RADIO
Current: Speicherkarte
Choice: 0 interner Speicher
Choice: 1 Speicherkarte
/main/status/serialnumber
Label: Seriennummer
Readonly: 1
Type: TEXT
Current: 6012345
/main/capturesettings/shutterspeed
Label: Belichtungszeit
Readonly: 0
Type: RADIO
Current: 0,0400s
Choice: 0 0,0005s
Choice: 1 0,0010s
Choice: 2 0,0020s
Choice: 3 0,0040s
Choice: 4 0,0080s
Choice: 5 0,0166s
Choice: 6 0,0333s
Choice: 7 0,0400s
Choice: 8 429496,7295s
/main/imgsettings/iso
Label: ISO-Geschwindigkeit
Readonly: 0
Type: RADIO
Current: 200
Choice: 0 100
Choice: 1 200
Choice: 2 Unbekannter Wert 0002
/main/capturesettings/f-number
Label: F-Nummer
Readonly: 0
Type: RADIO
Current: f/3,5
Choice: 0 f/3,5
Choice: 1 f/5,6
Choice: 2 f/8
/main/capturesettings/exposurecompensation
Label: Belichtungskorrektur
Readonly: 0
Type: RANGE
Current: -0,5
Bottom: -5,0
Top: 5,0
Step: 0,3
/main/capturesettings/focusmode
Label: Fokusmodus
Readonly: 0
Type: MENU
Current: (null)
Choice: 0 AF-S
Choice: 1 MF
END
)";

TEST(ConfigDumpTest, ReadsEveryWidgetTypeOfAGermanDump) {
  ASSERT_OK_AND_ASSIGN(CameraDump dump,
                       ParseCameraDump(kGermanNikon, "nikon-d750.txt"));
  EXPECT_EQ(dump.model, "Nikon Corporation D750");
  EXPECT_THAT(dump.summary, HasSubstr("Seriennummer"));
  ASSERT_EQ(dump.widgets.size(), 9u);

  const ConfigWidget* bulb = FindWidget(dump.widgets, "bulb");
  ASSERT_NE(bulb, nullptr);
  EXPECT_EQ(bulb->type, WidgetType::kToggle);
  EXPECT_EQ(bulb->path, "/main/actions/bulb");
  EXPECT_EQ(bulb->label, "Langzeit Belichtungsmodus");
  EXPECT_EQ(bulb->value, "2");

  const ConfigWidget* date = FindWidget(dump.widgets, "datetime");
  ASSERT_NE(date, nullptr);
  EXPECT_EQ(date->type, WidgetType::kDate);
  EXPECT_EQ(date->value, "1417637635");

  const ConfigWidget* serial = FindWidget(dump.widgets, "serialnumber");
  ASSERT_NE(serial, nullptr);
  EXPECT_EQ(serial->type, WidgetType::kText);
  EXPECT_TRUE(serial->read_only);
  EXPECT_FALSE(FindWidget(dump.widgets, "shutterspeed")->read_only);

  const ConfigWidget* shutter = FindWidget(dump.widgets, "shutterspeed");
  EXPECT_EQ(shutter->type, WidgetType::kRadio);
  EXPECT_EQ(shutter->value, "0,0400s");
  EXPECT_EQ(shutter->choices.size(), 9u);
  EXPECT_EQ(shutter->choices[0], "0,0005s");

  // RANGE: decimal commas read, the value as the library reports it.
  const ConfigWidget* ev = FindWidget(dump.widgets, "exposurecompensation");
  ASSERT_NE(ev, nullptr);
  EXPECT_EQ(ev->type, WidgetType::kRange);
  EXPECT_FLOAT_EQ(ev->min, -5.0f);
  EXPECT_FLOAT_EQ(ev->max, 5.0f);
  EXPECT_FLOAT_EQ(ev->step, 0.3f);
  EXPECT_EQ(ev->value, "-0.5");

  const ConfigWidget* focus = FindWidget(dump.widgets, "focusmode");
  ASSERT_NE(focus, nullptr);
  EXPECT_EQ(focus->type, WidgetType::kMenu);
  EXPECT_EQ(focus->value, "");  // "(null)"
  EXPECT_THAT(focus->choices, ElementsAre("AF-S", "MF"));
}

TEST(ConfigDumpTest, CrlfLineEndsReadTheSame) {
  const std::string crlf = absl::StrReplaceAll(kGermanNikon, {{"\n", "\r\n"}});
  ASSERT_OK_AND_ASSIGN(CameraDump dump, ParseCameraDump(crlf, "crlf.txt"));
  ASSERT_OK_AND_ASSIGN(CameraDump plain,
                       ParseCameraDump(kGermanNikon, "plain.txt"));
  ASSERT_EQ(dump.widgets.size(), plain.widgets.size());
  for (size_t i = 0; i < dump.widgets.size(); ++i) {
    EXPECT_EQ(dump.widgets[i].value, plain.widgets[i].value);
    EXPECT_EQ(dump.widgets[i].choices, plain.widgets[i].choices);
    EXPECT_EQ(dump.widgets[i].label, plain.widgets[i].label);
  }
  EXPECT_EQ(dump.model, "Nikon Corporation D750");
}

TEST(ConfigDumpTest, InvalidUtf8BecomesReplacementCharacters) {
  // A Latin-1 label and a serial number with a stray 0xD4 byte.
  const std::string text =
      "/main/status/serialnumber\nLabel: Num\xe9ro de s\xe9rie\nType: "
      "TEXT\nCurrent: ABC\xd4\x01\n";
  ASSERT_OK_AND_ASSIGN(CameraDump dump, ParseCameraDump(text, "fuji.txt"));
  ASSERT_EQ(dump.widgets.size(), 1u);
  EXPECT_EQ(dump.widgets[0].label, "Num\xEF\xBF\xBDro de s\xEF\xBF\xBDrie");
  EXPECT_EQ(dump.widgets[0].value, "ABC\xEF\xBF\xBD\x01");
  EXPECT_EQ(ValidUtf8("f\xc3\xbcr \xc2\xa0ok"), "f\xc3\xbcr \xc2\xa0ok");
  EXPECT_EQ(ValidUtf8("\xc0\xaf"), "\xEF\xBF\xBD\xEF\xBF\xBD");  // overlong
  // Without a summary the model falls back to the cameramodel widget.
  ASSERT_OK_AND_ASSIGN(
      CameraDump named,
      ParseCameraDump("/main/status/cameramodel\nLabel: Model\nType: "
                      "TEXT\nCurrent: X-T4\n",
                      "cameras/fuji-xt4.txt"));
  EXPECT_EQ(named.model, "X-T4");
}

TEST(ConfigDumpTest, ErrorsNameTheLineAndTheWidget) {
  EXPECT_THAT(ParseCameraDump("summary only\nModel: X\n", "a.txt"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("a.txt: no --list-all-config tree")));
  EXPECT_THAT(
      ParseCameraDump("x\n/main/a/shutterspeed\nLabel: S\nType: SLIDER\n",
                      "b.txt"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("b.txt:4: /main/a/shutterspeed: unknown widget Type "
                         "\"SLIDER\"")));
  EXPECT_THAT(ParseCameraDump("/main/a/iso\n/main/a/shutterspeed\n", "c"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c: only paths, no widget types or values")));
  EXPECT_THAT(
      ParseCameraDump("/main/a/ev\nType: RANGE\nCurrent: 0\nTop: 5\n", "d"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("/main/a/ev is a RANGE without numeric Bottom")));
  EXPECT_THAT(ParseCameraDump("/main/a/iso\nType: RADIO\nChoice: x 100\n", "e"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("e:3: /main/a/iso: malformed Choice line")));
  EXPECT_THAT(LoadCameraDump("/nonexistent/dump.txt"),
              StatusIs(absl::StatusCode::kNotFound,
                       HasSubstr("/nonexistent/dump.txt")));
}

// Refused by the file's size before it is read (a sparse file: no disk
// used), not by ParseCameraDump's check of the text.
TEST(ConfigDumpTest, AHugeDumpFileIsRefusedUnread) {
  ::hdrstereo::testing::TempDir dir;
  const std::filesystem::path file = dir / "dump.txt";
  { std::ofstream(file) << "/main/a/w\n"; }
  std::filesystem::resize_file(file, kMaxDumpBytes + 1);
  EXPECT_THAT(
      LoadCameraDump(file),
      StatusIs(absl::StatusCode::kInvalidArgument,
               file.string() + ": camera dump of 16777217 bytes, more than the "
                               "limit of 16777216; not read"));
}

// Older and odder dumps: tab-indented fields, a blank line and U+00A0
// padding after the path, entries without a Type (skipped).
TEST(ConfigDumpTest, ReadsOlderLayouts) {
  const std::string text =
      "/main/actions/autofocusdrive\n\tLabel: Drive Nikon DSLR "
      "Autofocus\n\tType: TOGGLE\n\tCurrent: 0\n"
      "/main/actions/sync\xc2\xa0\xc2\xa0\n\nLabel: Sync\nType: "
      "TOGGLE\nCurrent: 1\n"
      "/main/other/d209\nLabel: PTP \nChoice: 0 1\nEND\n"
      "/main/imgsettings/iso\n\tLabel: ISO\n\tType: RADIO\n\tCurrent: "
      "100\n\tChoice: 0 100\n\tChoice: 1 200\n";
  ASSERT_OK_AND_ASSIGN(CameraDump dump, ParseCameraDump(text, "old.txt"));
  ASSERT_EQ(dump.widgets.size(), 3u);
  EXPECT_EQ(dump.widgets[0].label, "Drive Nikon DSLR Autofocus");
  EXPECT_EQ(dump.widgets[1].path, "/main/actions/sync");
  EXPECT_EQ(dump.widgets[1].value, "1");
  EXPECT_THAT(dump.widgets[2].choices, ElementsAre("100", "200"));
  EXPECT_THAT(dump.skipped, ElementsAre("/main/other/d209 (line 10)"));
}

TEST(ConfigDumpTest, RepeatedPathsKeepTheFirstDump) {
  const std::string twice =
      "/main/i/iso\nType: RADIO\nCurrent: 100\nChoice: 0 100\n"
      "/main/i/iso\nType: RADIO\nCurrent: 200\nChoice: 0 200\n";
  ASSERT_OK_AND_ASSIGN(CameraDump dump, ParseCameraDump(twice, "two.txt"));
  ASSERT_EQ(dump.widgets.size(), 1u);
  EXPECT_EQ(dump.widgets[0].value, "100");
}

// Each limit on what a dump may hold, at the limit and one beyond.
TEST(ConfigDumpTest, DumpsBeyondTheLimitsAreRefusedNamingTheLimit) {
  EXPECT_THAT(
      ParseCameraDump(std::string(kMaxDumpBytes + 1, '\n'), "big.txt"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("big.txt: the dump is 16777217 bytes; the most is "
                         "16777216")));

  const std::string entry = "/main/a/w\nType: TEXT\nLabel: ";
  const std::string label(kMaxDumpLineBytes - 7, 'l');
  EXPECT_THAT(ParseCameraDump(entry + label + "\n", "line.txt"), IsOk());
  EXPECT_THAT(ParseCameraDump(entry + label + "l\n", "line.txt"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("line.txt:3: the line is 65537 bytes long; "
                                 "the most is 65536")));

  std::string entries;
  for (int64_t i = 0; i < kMaxDumpEntries; ++i) {
    absl::StrAppend(&entries, "/main/a/w", i, "\nType: TEXT\nCurrent: x\n");
  }
  ASSERT_OK_AND_ASSIGN(CameraDump many, ParseCameraDump(entries, "many.txt"));
  EXPECT_EQ(many.widgets.size(), static_cast<size_t>(kMaxDumpEntries));
  EXPECT_THAT(ParseCameraDump(entries + "/main/a/last\n", "many.txt"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("many.txt:24577: more than 8192 config "
                                 "entries")));

  const std::string path = "/main/" + std::string(kMaxWidgetPathBytes - 6, 'p');
  EXPECT_THAT(ParseCameraDump(path + "\nType: TEXT\n", "path.txt"), IsOk());
  absl::StatusOr<CameraDump> long_path =
      ParseCameraDump(path + "p\nType: TEXT\n", "path.txt");
  EXPECT_THAT(long_path,
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("\"... (257 bytes) is 257 bytes long; the "
                                 "most is 256")));
  EXPECT_LT(long_path.status().message().size(), 200u);

  std::string choices = "/main/a/iso\nType: RADIO\n";
  for (int64_t i = 0; i < kMaxWidgetChoices; ++i) {
    absl::StrAppend(&choices, "Choice: ", i, " ", i, "\n");
  }
  ASSERT_OK_AND_ASSIGN(CameraDump radio, ParseCameraDump(choices, "c.txt"));
  EXPECT_EQ(radio.widgets[0].choices.size(),
            static_cast<size_t>(kMaxWidgetChoices));
  EXPECT_THAT(ParseCameraDump(choices + "Choice: 0 x\n", "c.txt"),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("c.txt:65538: /main/a/iso: more than 65535 "
                                 "Choice lines")));
}

// What a dump holds is quoted bounded and escaped; a RANGE of absurd bounds
// or step is kept as numbers (nothing loops or allocates per step), one
// whose numbers are not finite floats is refused; NUL bytes are text.
TEST(ConfigDumpTest, HostileValuesAreBoundedOrRefused) {
  absl::StatusOr<CameraDump> type = ParseCameraDump(
      "/main/a/w\nType: " + std::string(1000, '\x1b') + "\n", "t.txt");
  EXPECT_THAT(type, StatusIs(absl::StatusCode::kInvalidArgument,
                             HasSubstr("\\x1b\\x1b\"... (1000 bytes) "
                                       "(expected RADIO")));
  EXPECT_LT(type.status().message().size(), 400u);
  EXPECT_THAT(
      ParseCameraDump("/main/a/iso\nType: RADIO\nChoice: 99999999999 x\n", "o"),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("malformed Choice line \"Choice: 99999999999 x\"")));

  ASSERT_OK_AND_ASSIGN(
      CameraDump absurd,
      ParseCameraDump("/main/a/ev\nType: RANGE\nCurrent: 1e38\nBottom: "
                      "-3.4e38\nTop: 3.4e38\nStep: 1e-30\n",
                      "r.txt"));
  EXPECT_FLOAT_EQ(absurd.widgets[0].min, -3.4e38f);
  EXPECT_FLOAT_EQ(absurd.widgets[0].step, 1e-30f);
  EXPECT_EQ(absurd.widgets[0].value, "1e+38");
  for (const char* step : {"1e39", "nan", "inf", "-"}) {
    EXPECT_THAT(ParseCameraDump(absl::StrCat("/main/a/ev\nType: RANGE\n"
                                             "Bottom: 0\nTop: 1\nStep: ",
                                             step, "\n"),
                                "r.txt"),
                StatusIs(absl::StatusCode::kInvalidArgument,
                         HasSubstr("/main/a/ev is a RANGE without numeric "
                                   "Bottom, Top and Step")))
        << step;
  }

  ASSERT_OK_AND_ASSIGN(
      CameraDump nul,
      ParseCameraDump(std::string("/main/a/w\nType: TEXT\nCurrent: a\0b\n", 34),
                      "nul.txt"));
  EXPECT_EQ(nul.widgets[0].value, std::string("a\0b", 3));
}

// The replay answers like a camera: choices, bounds, read-only widgets.
TEST(ReplayApiTest, SetsValuesAsTheCameraWouldAndRefusesOthers) {
  ASSERT_OK_AND_ASSIGN(CameraDump dump,
                       ParseCameraDump(kGermanNikon, "nikon-d750.txt"));
  ReplayApi api(dump);
  std::vector<DetectedCamera> found;
  ASSERT_EQ(api.Autodetect(&found), GP_OK);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(found[0].model, "Nikon Corporation D750");
  EXPECT_EQ(found[0].port, "replay:nikon-d750.txt");
  EXPECT_EQ(api.Open(found[0].model, found[0].port), GP_OK);
  EXPECT_EQ(api.Open("Canon EOS R5", found[0].port), GP_ERROR_MODEL_NOT_FOUND);
  // The replay's libgphoto2 knows its own model only.
  EXPECT_EQ(api.CheckModel("nikon corporation d750"), GP_OK);
  EXPECT_EQ(api.CheckModel("Canon EOS R5"), GP_ERROR_MODEL_NOT_FOUND);

  EXPECT_EQ(api.SetConfigValue("shutterspeed", "0,0080s"), GP_OK);
  EXPECT_EQ(api.SetConfigValue("shutterspeed", "1/125"),
            GP_ERROR_BAD_PARAMETERS);
  EXPECT_THAT(api.ErrorText(GP_ERROR_BAD_PARAMETERS),
              HasSubstr("\"1/125\" is not a choice of "
                        "/main/capturesettings/shutterspeed"));
  EXPECT_EQ(api.SetConfigValue("serialnumber", "1"), GP_ERROR_NOT_SUPPORTED);
  EXPECT_EQ(api.SetConfigValue("exposurecompensation", "1.5"), GP_OK);
  EXPECT_EQ(api.SetConfigValue("exposurecompensation", "7"),
            GP_ERROR_BAD_PARAMETERS);
  EXPECT_EQ(api.SetConfigValue("bulb", "1"), GP_OK);
  EXPECT_EQ(api.SetConfigValue("bulb", "yes"), GP_ERROR_BAD_PARAMETERS);
  EXPECT_EQ(api.SetConfigValue("datetime", "now"), GP_ERROR_BAD_PARAMETERS);
  EXPECT_EQ(api.SetConfigValue("nosuchwidget", "1"), GP_ERROR_BAD_PARAMETERS);
  std::vector<ConfigWidget> widgets;
  ASSERT_EQ(api.GetConfig(&widgets), GP_OK);
  EXPECT_EQ(FindWidget(widgets, "shutterspeed")->value, "0,0080s");
  EXPECT_EQ(FindWidget(widgets, "exposurecompensation")->value, "1.5");
  EXPECT_EQ(FindWidget(widgets, "bulb")->value, "1");
  // No frame source: nothing to capture.
  std::string folder, name;
  EXPECT_EQ(api.Capture(&folder, &name), GP_ERROR_NOT_SUPPORTED);
}

// The real driver over the replay: the German dump configures, the bulb
// code is never chosen, and a capture downloads and deletes what the frame
// source made at the chosen exposure.
TEST(ReplayApiTest, TheDriverConfiguresAndCapturesThroughTheReplay) {
  ASSERT_OK_AND_ASSIGN(CameraDump dump,
                       ParseCameraDump(kGermanNikon, "nikon-d750.txt"));
  std::vector<double> rendered;
  auto api = std::make_unique<ReplayApi>(
      dump,
      [&](const hardware::ExposureSettings& s) -> absl::StatusOr<ReplayFile> {
        rendered.push_back(s.exposure_s);
        return ReplayFile{.bytes = "\xff\xd8 jpeg", .extension = "jpg"};
      });
  ReplayApi* replay = api.get();
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<Gphoto2Camera> camera,
                       Gphoto2Camera::OpenWithApi({}, std::move(api)));
  EXPECT_EQ(camera->model(), "Nikon Corporation D750");
  std::vector<ConfigWidget> widgets;
  replay->GetConfig(&widgets);
  EXPECT_EQ(FindWidget(widgets, "capturetarget")->value, "interner Speicher");

  // 1/60 s -> "0,0166s"; 1/3 s lies beyond the range.
  ASSERT_OK_AND_ASSIGN(hardware::ExposureSettings applied,
                       camera->Configure(Exposure(1.0 / 60, 100, 8)));
  EXPECT_DOUBLE_EQ(applied.exposure_s, 0.0166);
  EXPECT_EQ(applied.iso, 100);
  EXPECT_DOUBLE_EQ(applied.aperture_f, 8);
  EXPECT_THAT(camera->Configure(Exposure(1.0 / 3)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("shutterspeed (/main/capturesettings/"
                                 "shutterspeed): exposure 0.333333 s is "
                                 "outside the camera's range")));
  ASSERT_OK_AND_ASSIGN(hardware::Frame frame, camera->Capture());
  EXPECT_EQ(frame.bytes, "\xff\xd8 jpeg");
  EXPECT_EQ(frame.extension, "jpg");
  EXPECT_DOUBLE_EQ(frame.exposure_s, 0.0166);
  EXPECT_THAT(rendered, ElementsAre(0.0166));
  // The dump's capture target is "interner Speicher": the file was in RAM.
  EXPECT_EQ(frame.stored_to, hardware::StoredTo::kRam);
  std::vector<std::string> left;
  ASSERT_EQ(replay->ListFiles("/", &left), GP_OK);
  EXPECT_TRUE(left.empty()) << "the driver deletes what it downloaded";
}

// The replay's USB link: unplugged, the camera is gone from the bus and
// its old handle answers with I/O errors, as libgphoto2's would; plugged in
// again (when `plug_in` lets it), a new handle opens and the old one stays
// dead. Through the driver, the I/O error is a camera gone.
TEST(ReplayApiTest, TheLinkDropsTheCameraUntilItIsPluggedInAgain) {
  ASSERT_OK_AND_ASSIGN(CameraDump dump,
                       ParseCameraDump(kGermanNikon, "nikon-d750.txt"));
  absl::Status present = absl::OkStatus();
  int looks = 0;
  auto link = std::make_shared<ReplayLink>([&] {
    ++looks;
    return present;
  });
  auto first = std::make_unique<ReplayApi>(dump, nullptr, link);
  ReplayApi* old_handle = first.get();
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<Gphoto2Camera> camera,
                       Gphoto2Camera::OpenWithApi({}, std::move(first)));
  EXPECT_EQ(looks, 1) << "asked once, at the first look";
  ASSERT_THAT(camera->Settings(), IsOk());

  link->Unplug();
  present = absl::UnavailableError("still re-enumerating");
  std::vector<ConfigWidget> widgets;
  EXPECT_EQ(old_handle->GetConfig(&widgets), GP_ERROR_IO);
  EXPECT_THAT(old_handle->ErrorText(GP_ERROR_IO),
              HasSubstr("the replayed camera was unplugged (nikon-d750.txt)"));
  absl::Status gone = camera->Settings().status();
  EXPECT_THAT(gone, StatusIs(absl::StatusCode::kUnavailable,
                             HasSubstr("I/O error talking to the camera "
                                       "(disconnected?)")));
  EXPECT_TRUE(hardware::IsCameraGone(gone));

  ReplayApi second(dump, nullptr, link);
  std::vector<DetectedCamera> found;
  ASSERT_EQ(second.Autodetect(&found), GP_OK);
  EXPECT_TRUE(found.empty());
  EXPECT_EQ(second.Open("Nikon Corporation D750", "replay:nikon-d750.txt"),
            GP_ERROR_IO_USB_FIND);
  EXPECT_THAT(second.ErrorText(GP_ERROR_IO_USB_FIND),
              HasSubstr("still re-enumerating"));

  present = absl::OkStatus();
  ASSERT_EQ(second.Autodetect(&found), GP_OK);
  ASSERT_EQ(found.size(), 1u);
  EXPECT_EQ(second.Open(found[0].model, found[0].port), GP_OK);
  EXPECT_EQ(second.GetConfig(&widgets), GP_OK);
  EXPECT_EQ(old_handle->GetConfig(&widgets), GP_ERROR_IO)
      << "an old handle stays dead";
}

// A frame source that says the camera went away unplugs the link.
TEST(ReplayApiTest, ASourceThatLostTheCameraUnplugsTheLink) {
  ASSERT_OK_AND_ASSIGN(CameraDump dump,
                       ParseCameraDump(kGermanNikon, "nikon-d750.txt"));
  auto link = std::make_shared<ReplayLink>();
  ReplayApi api(
      dump,
      [](const hardware::ExposureSettings&) -> absl::StatusOr<ReplayFile> {
        return absl::AbortedError("camera disconnected during transfer");
      },
      link);
  std::vector<DetectedCamera> found;
  ASSERT_EQ(api.Autodetect(&found), GP_OK);
  ASSERT_EQ(api.Open(found[0].model, found[0].port), GP_OK);
  std::string folder, name;
  EXPECT_EQ(api.Capture(&folder, &name), GP_ERROR_IO);
  EXPECT_THAT(api.ErrorText(GP_ERROR_IO),
              HasSubstr("camera disconnected during transfer"));
  std::vector<ConfigWidget> widgets;
  EXPECT_EQ(api.GetConfig(&widgets), GP_ERROR_IO);
  // Without a plug-in check, the camera is back at the next look.
  ASSERT_OK_AND_ASSIGN(const int64_t connection, link->Find());
  EXPECT_EQ(connection, 2);
  EXPECT_TRUE(link->Up(2));
  EXPECT_FALSE(link->Up(1));
}

TEST(ReplayApiTest, RangeAperturesTakeANumberAndTextOnesAreRefused) {
  const std::string text =
      "/main/c/shutterspeed\nType: RADIO\nCurrent: 1/125\nChoice: 0 1/125\n"
      "/main/c/f-number\nLabel: F-Nummer\nType: RANGE\nCurrent: 2\n"
      "Bottom: 0\nTop: 655,35\nStep: 0,01\n";
  ASSERT_OK_AND_ASSIGN(CameraDump dump, ParseCameraDump(text, "sony-a7r.txt"));
  ASSERT_OK_AND_ASSIGN(
      std::unique_ptr<Gphoto2Camera> camera,
      Gphoto2Camera::OpenWithApi({}, std::make_unique<ReplayApi>(dump)));
  ASSERT_OK_AND_ASSIGN(hardware::ExposureSettings applied,
                       camera->Configure(Exposure(1.0 / 125, 0, 5.6)));
  EXPECT_DOUBLE_EQ(applied.aperture_f, 5.6);
  EXPECT_THAT(camera->Configure(Exposure(1.0 / 125, 0, 700)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("f-number (/main/c/f-number): 700 is outside "
                                 "its range [0, 655.35]")));
  EXPECT_THAT(
      camera->Configure(Exposure(1.0 / 125, 100)),
      StatusIs(absl::StatusCode::kInvalidArgument,
               HasSubstr("the camera has no ISO setting (iso, isospeed)")));

  // Fuji X-T4: a radio widget without choices, "Current: (null)".
  ASSERT_OK_AND_ASSIGN(
      CameraDump fuji,
      ParseCameraDump("/main/c/shutterspeed\nType: RADIO\nCurrent: "
                      "1/125\nChoice: 0 1/125\n/main/c/f-number\nType: "
                      "RADIO\nCurrent: (null)\nEND\n",
                      "fuji-xt4.txt"));
  ASSERT_OK_AND_ASSIGN(
      std::unique_ptr<Gphoto2Camera> xt4,
      Gphoto2Camera::OpenWithApi({}, std::make_unique<ReplayApi>(fuji)));
  EXPECT_THAT(xt4->Configure(Exposure(1.0 / 125, 0, 8)),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       HasSubstr("f-number (/main/c/f-number) offers no "
                                 "choices (current value \"\")")));
}

}  // namespace
}  // namespace hdrstereo::gphoto2
