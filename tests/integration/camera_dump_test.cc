// SPDX-License-Identifier: GPL-3.0-or-later
//
// `hdrstereod --hardware real --camera-dump FILE`: the real daemon and CLI
// drive "a Nikon D750" (its real, German `gphoto2 --list-all-config` dump
// from ../shared/data/gphoto2-config-dumps) through the real gphoto2
// driver; frames come from the simulator at the shutter speed the driver
// chose among the D750's own choices.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "absl/strings/match.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"
#include "tests/support/daemon_fixture.h"
#include "tests/support/status_matchers.h"
#include "tests/support/subprocess.h"

namespace hdrstereo {
namespace {

namespace fs = std::filesystem;
using ::hdrstereo::testing::CommandResult;
using ::testing::HasSubstr;
using ::testing::StartsWith;

fs::path NikonD750() {
  return fs::path(HDRSTEREO_SHARED_DIR) / "data" / "gphoto2-config-dumps" /
         "cameras" / "nikon-d750.txt";
}

class CameraDumpTest : public ::hdrstereo::testing::DaemonFixture {
 protected:
  void SetUp() override {
    if (!fs::exists(NikonD750())) {
      GTEST_SKIP() << NikonD750() << " is absent (no ../shared/data)";
    }
  }

  // The value printed after `key` in the CLI's "key  value" output.
  static std::string Field(const std::string& out, const std::string& key) {
    for (absl::string_view line : absl::StrSplit(out, '\n')) {
      if (absl::ConsumePrefix(&line, key) && absl::StartsWith(line, " ")) {
        return std::string(absl::StripAsciiWhitespace(line));
      }
    }
    ADD_FAILURE() << "no " << key << " line in\n" << out;
    return "";
  }

  // A stereo capture at `exposures` (left at 0 mm, right at 50 mm) into a
  // new `session`, which must succeed.
  void CaptureStereo(const std::string& session, const std::string& exposures) {
    ASSERT_EQ(Cli({"session", "create", session}).exit_code, 0);
    nlohmann::json job =
        CliJson({"capture", "stereo", session, "--exposures", exposures,
                 "--baseline-mm", "50", "--no-ambient"});
    ASSERT_TRUE(job.contains("id")) << job.dump();
    const int64_t id = ::hdrstereo::testing::JsonInt(job["id"]);
    ASSERT_TRUE(WaitForJobState(id, "succeeded"))
        << CliJson({"jobs", "show", std::to_string(id)}).dump(2)
        << daemon_log();
  }
};

TEST_F(CameraDumpTest, TheDaemonDrivesAReplayedNikonD750) {
  StartDaemon(
      {"--hardware", "real", "--camera-dump", NikonD750().string(),
       "--sim-scene",
       WriteScene("lab-lamp", ::hdrstereo::testing::SmallLabLamp()).string()});
  CommandResult status = Cli({"hw", "status"});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  EXPECT_EQ(Field(status.out, "mode"), "real");
  EXPECT_THAT(Field(status.out, "camera"), StartsWith("connected  D750"));
  EXPECT_THAT(Field(status.out, "stage"), StartsWith("connected"));

  // The dump's current settings: 1/25 s ("0,0400s"), ISO 200, f/3.5.
  CommandResult get = Cli({"hw", "camera", "get"});
  ASSERT_EQ(get.exit_code, 0) << get.err;
  EXPECT_EQ(Field(get.out, "exposure"), "1/25 s");
  EXPECT_EQ(Field(get.out, "iso"), "200");
  EXPECT_EQ(Field(get.out, "aperture"), "f/3.5");

  // 1/90 s is nearest "0,0100s" (0.15 stop; 1/80 s is 0.17 away).
  CommandResult set = Cli({"hw", "camera", "set", "--exposure", "1/90", "--iso",
                           "400", "--aperture", "8"});
  ASSERT_EQ(set.exit_code, 0) << set.err;
  EXPECT_EQ(Field(set.out, "exposure"), "1/100 s");
  EXPECT_EQ(Field(set.out, "iso"), "400");
  EXPECT_EQ(Field(set.out, "aperture"), "f/8");

  // What the D750 does not offer is refused by name, and nothing changes.
  CommandResult bad =
      Cli({"hw", "camera", "set", "--exposure", "1/125", "--iso", "123"});
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_THAT(bad.err, HasSubstr("iso (/main/imgsettings/iso): the camera "
                                 "does not offer ISO 123"));
  EXPECT_EQ(Field(Cli({"hw", "camera", "get"}).out, "exposure"), "1/100 s");

  // A capture: the frames are simulated, at the D750's choices nearest
  // 1/90 and 1/210 s: "0,0100s" and "0,0050s".
  ASSERT_NO_FATAL_FAILURE(CaptureStereo("d750", "1/90,1/210"));
  EXPECT_EQ(Sql("SELECT COUNT(*) FROM frames"), "4");
  EXPECT_EQ(Sql("SELECT COUNT(DISTINCT exposure_s) FROM frames"), "2");
  EXPECT_EQ(Sql("SELECT MAX(exposure_s) FROM frames"), "0.01");
  EXPECT_EQ(Sql("SELECT MIN(exposure_s) FROM frames"), "0.005");
  // The dump's image quality is "NEF+Fein" (RAW+JPEG): RAW frames, which
  // the simulator writes as DNG.
  EXPECT_EQ(Sql("SELECT COUNT(*) FROM frames WHERE format = 'raw' AND path "
                "LIKE '%.dng'"),
            "4");
  EXPECT_EQ(StopDaemon(), 0);
}

// The replayed D750 drops off its (replayed) USB link mid-capture: the
// simulator's disconnect fault on the third frame makes the replay unplug
// the camera, so that the driver's capture fails with libgphoto2's I/O
// error; two reopen attempts find no camera, the third finds it again by
// its serial number, and the capture goes on with every frame once.
TEST_F(CameraDumpTest, TheReplayedCameraDropsMidCaptureAndComesBack) {
  nlohmann::json scene = ::hdrstereo::testing::SmallLabLamp();
  scene["faults"] = {
      {"camera",
       {{"disconnect", {{"calls", {3}}}}, {"disconnect_failed_reopens", 2}}}};
  StartDaemon({"--hardware", "real", "--camera-dump", NikonD750().string(),
               "--sim-scene", WriteScene("lab-lamp", scene).string(),
               "--camera-reconnect-first-s", "0.05", "--camera-reconnect-max-s",
               "0.2"});
  ASSERT_NO_FATAL_FAILURE(CaptureStereo("drop", "1/90,1/210,1/500"));

  // Every planned frame exactly once (3 exposures x 2 views), files and
  // rows in agreement.
  ExpectConsistentStore("drop", 6);
  EXPECT_EQ(Sql("SELECT count(DISTINCT exposure_s || '/' || view_index) FROM "
                "frames"),
            "6");
  // One drop, seen as gphoto2 sees a camera gone from USB; one suspension
  // and one resumption.
  EXPECT_EQ(EventsLike("the camera dropped (capture: I/O error talking to "
                       "the camera (disconnected?)"),
            1);
  EXPECT_EQ(EventsLike("suspended: camera disconnected, reconnecting"), 1);
  EXPECT_EQ(EventsLike("resumed: "), 1);
  // While it was away, the reopen looked for the D750 by its serial number.
  EXPECT_THAT(daemon_log(), HasSubstr("no camera with serial number "
                                      "\"0000000000000000000000000nnnnnnn\""));
  EXPECT_THAT(daemon_log(), HasSubstr("camera: reconnected (drop 1)"));
  nlohmann::json status = CliJson({"hw", "status"});
  EXPECT_EQ(status["camera"]["state"], "DEVICE_STATE_CONNECTED");
  EXPECT_EQ(::hdrstereo::testing::JsonInt(status["camera"]["disconnects"]), 1);
  EXPECT_EQ(StopDaemon(), 0);
}

TEST_F(CameraDumpTest, BadDumpsAndModesAreRefusedAtStart) {
  const fs::path empty = dir_ / "empty.txt";
  { std::ofstream(empty) << "Camera summary:\nModel: X\n"; }
  ASSERT_OK_AND_ASSIGN(
      CommandResult no_tree,
      ::hdrstereo::testing::RunCommand(
          {HDRSTEREOD, "--hardware", "real", "--camera-dump", empty.string(),
           "--listen", "127.0.0.1:0", "--data-root", (dir_ / "d1").string()}));
  EXPECT_NE(no_tree.exit_code, 0);
  EXPECT_THAT(no_tree.err, HasSubstr("no --list-all-config tree"));

  ASSERT_OK_AND_ASSIGN(
      CommandResult sim,
      ::hdrstereo::testing::RunCommand(
          {HDRSTEREOD, "--hardware", "sim", "--camera-dump",
           NikonD750().string(), "--data-root", (dir_ / "d2").string()}));
  EXPECT_NE(sim.exit_code, 0);
  EXPECT_THAT(sim.err, HasSubstr("use it with --hardware real"));

  // A model the replay does not hold can never be found: a configuration
  // error, not a camera to wait for.
  ASSERT_OK_AND_ASSIGN(
      CommandResult other_model,
      ::hdrstereo::testing::RunCommand(
          {HDRSTEREOD, "--hardware", "real", "--camera-dump",
           NikonD750().string(), "--camera-model", "Canon EOS R5", "--listen",
           "127.0.0.1:0", "--data-root", (dir_ / "d3").string()}));
  EXPECT_NE(other_model.exit_code, 0);
  EXPECT_THAT(other_model.err,
              HasSubstr("no camera can match --camera-model \"Canon EOS R5\": "
                        "look up camera model \"Canon EOS R5\": libgphoto2 "
                        "knows no such camera model"));
}

}  // namespace
}  // namespace hdrstereo
