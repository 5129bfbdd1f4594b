// SPDX-License-Identifier: GPL-3.0-or-later
//
// Scene files are shared between labs: every size and count a scene
// declares is bounded before anything is allocated or looped over, so that
// neither parsing nor rendering a hostile scene runs out of memory or time
// (a 1e9 x 1e9 camera, a million objects, numbers beyond double), and the
// refusal names the field, its value and the limit in a bounded message.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "hardware/sim/scene.h"
#include "processing/io/atomic_file.h"
#include "tests/support/status_matchers.h"
#include "tests/support/temp_dir.h"
#include "tests/unit/sim/test_scenes.h"

namespace hdrstereo::sim {
namespace {

using ::hdrstereo::sim::testing::SmallSceneJson;
using ::hdrstereo::testing::StatusIs;
using ::testing::HasSubstr;

constexpr char kPlane[] =
    R"({"type": "plane", "center_mm": [0, 0, 1000], "normal": [0, 0, -1]})";

// `n` copies of `element`, comma-separated.
std::string Repeat(const std::string& element, size_t n) {
  return absl::StrJoin(std::vector<std::string>(n, element), ",");
}

void ExpectRefused(const std::string& json, const std::string& message) {
  const absl::StatusOr<Scene> scene = ParseScene(json);
  EXPECT_THAT(scene,
              StatusIs(absl::StatusCode::kInvalidArgument, HasSubstr(message)))
      << json.substr(0, 200);
  EXPECT_LT(scene.status().message().size(), 400u) << message;
}

TEST(SceneLimitsTest, TheCameraIsWithinOpenCVsImageLimits) {
  ExpectRefused(
      SmallSceneJson(
          kPlane, R"("camera": {"width": 1000000000, "height": 1000000000})"),
      "camera.width: 1000000000 is outside [8, 1048576]");
  ExpectRefused(
      SmallSceneJson(kPlane, R"("camera": {"width": 16000, "height": 16000})"),
      "camera pixels (width x height): 16000 x 16000 is more than the limit "
      "of 67108864");
  ExpectRefused(SmallSceneJson(kPlane, R"("camera": {"fx": 1e300})"),
                "camera.fx: must be in (0, 1e+07], got 1e+300");
  // A 61 MP sensor fits.
  EXPECT_OK(ParseScene(
      SmallSceneJson(kPlane, R"("camera": {"width": 9504, "height": 6336})")));
}

TEST(SceneLimitsTest, TheProjectorIsAtMostWhatADisplayCanBe) {
  ExpectRefused(SmallSceneJson(kPlane, R"("projector": {"width": 100000})"),
                "projector.width: 100000 is outside [2, 16384]");
  ExpectRefused(
      SmallSceneJson(kPlane,
                     R"("projector": {"width": 16384, "height": 16384})"),
      "projector pixels (width x height): 16384 x 16384 is more than the "
      "limit of 134217728");
  EXPECT_OK(ParseScene(SmallSceneJson(
      kPlane, R"("projector": {"width": 15360, "height": 8640})")));  // 16K
}

TEST(SceneLimitsTest, CountsAreBoundedBeforeTheElementsAreRead) {
  // The elements are not even objects: the count is refused first.
  ExpectRefused(SmallSceneJson(Repeat("0", 257)),
                "objects: 257 elements, more than the limit of 256");
  ExpectRefused(SmallSceneJson(kPlane, absl::StrCat(R"("lights": [)",
                                                    Repeat("0", 17), "]")),
                "lights: 17 elements, more than the limit of 16");
  ExpectRefused(
      SmallSceneJson(
          kPlane, absl::StrCat(R"("faults": {"stage": {"stall": {"calls": [)",
                               Repeat("1", 1001), "]}}}")),
      "faults.stage.stall.calls: 1001 elements, more than the limit of 1000");
  ExpectRefused(
      SmallSceneJson(
          R"({"name": "board", "type": "plane", "center_mm": [0, 0, 1000]})",
          absl::StrCat(R"("calibration_board": {"objects": ["board"],
                                                 "poses": [)",
                       Repeat("{}", 65), "]}")),
      "calibration_board.poses: 65 elements, more than the limit of 64");
  // A million objects is refused by the file's size before it is parsed.
  ExpectRefused(SmallSceneJson(Repeat(kPlane, 1000000)),
                "more than the limit of 1048576");
}

// Call numbers were read as int64 and cast to int: 4294967297 became call 1.
TEST(SceneLimitsTest, CallNumbersDoNotWrap) {
  ExpectRefused(
      SmallSceneJson(
          kPlane,
          R"("faults": {"camera": {"timeout": {"calls": [4294967297]}}})"),
      "faults.camera.timeout.calls[0]: 4294967297 is outside [1, "
      "1000000000]");
  ExpectRefused(SmallSceneJson(kPlane,
                               R"("faults": {"camera": {"busy_first_calls":
                                              18446744073709551615}})"),
                "faults.camera.busy_first_calls: 18446744073709551615 is "
                "outside [0, 1000000]");
}

// Lengths within 10 km and features of at least 1 um keep the renderer's
// arithmetic (texture cells as int64, normalised directions) finite.
TEST(SceneLimitsTest, LengthsAndFeatureSizesAreBounded) {
  ExpectRefused(
      SmallSceneJson(R"({"type": "plane", "center_mm": [1e300, 0, 1000]})"),
      "objects[0].center_mm[0]: must be in [-1e+07, 1e+07], got "
      "1e+300");
  ExpectRefused(SmallSceneJson(R"({"type": "plane", "center_mm": [0, 0, 1],
                                   "normal": [1e308, 1e308, 0]})"),
                "objects[0].normal[0]: must be in [-1e+07, 1e+07]");
  ExpectRefused(
      SmallSceneJson(R"({"type": "plane", "center_mm": [0, 0, 1],
                         "material": {"texture": {"kind": "checker",
                                                  "square_mm": 1e-300}}})"),
      "objects[0].material.texture.square_mm: must be in [0.001, 1e+07], got "
      "1e-300");
  ExpectRefused(SmallSceneJson(R"({"type": "sphere", "center_mm": [0, 0, 1],
                         "radius_mm": 1e12})"),
                "objects[0].radius_mm: must be in (0, 1e+07], got 1e+12");
  ExpectRefused(
      SmallSceneJson(kPlane, R"("timing": {"stage_speed_mm_s": 1e-300})"),
      "timing.stage_speed_mm_s: must be in [0.001, 1e+06], got "
      "1e-300");
  ExpectRefused(SmallSceneJson(kPlane, R"("sensor": {"full_well_e": 1e300})"),
                "sensor.full_well_e: must be in (0, 1e+09], got 1e+300");
}

// A number beyond double is not a parse_error but an out_of_range: it
// escaped ParseScene as an exception.
TEST(SceneLimitsTest, ANumberBeyondDoubleIsNotJson) {
  ExpectRefused(SmallSceneJson(kPlane, R"("ambient_lux": 1e999)"),
                "scene is not valid JSON: [json.exception.out_of_range.406] "
                "number overflow parsing \"1e999\"");
  ExpectRefused(SmallSceneJson(kPlane, "\"ambient_lux\": NaN"),
                "scene is not valid JSON");
}

TEST(SceneLimitsTest, StringsAndTheirQuotesAreBounded) {
  ExpectRefused(absl::StrCat(R"({"name": ")", std::string(300, 'n'), R"("})"),
                "name: \"nnnn");
  ExpectRefused(absl::StrCat(R"({"name": ")", std::string(300, 'n'), R"("})"),
                "... (300 bytes) is longer than the limit of 256 bytes");
  ExpectRefused(absl::StrCat(R"({")", std::string(100000, 'k'), R"(": 1})"),
                "scene: unknown field \"kkkk");
  ExpectRefused(
      SmallSceneJson(absl::StrCat(R"({"type": ")", std::string(200, 't'),
                                  R"(", "center_mm": [0, 0, 1]})")),
      "objects[0].type: expected plane, box or sphere, got \"tttt");
  ExpectRefused(
      SmallSceneJson(absl::StrCat(R"({"type": ")", std::string(100000, 't'),
                                  R"(", "center_mm": [0, 0, 1]})")),
      "objects[0].type: \"tttt");
  ExpectRefused(absl::StrCat(R"({"name": ")", std::string(100000, 'x')),
                "scene is not valid JSON");
}

// Refused by the file's size before it is read (a sparse file: no disk
// used), not by ParseScene's check of the text.
TEST(SceneLimitsTest, AHugeSceneFileIsRefusedUnread) {
  ::hdrstereo::testing::TempDir dir;
  const std::filesystem::path file = dir / "scene.json";
  ASSERT_OK(io::WriteFileAtomically(file, "{"));
  std::filesystem::resize_file(file, 2 << 20);
  EXPECT_THAT(LoadSceneFile(file),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       file.string() +
                           ": scene file of 2097152 bytes, more than the limit "
                           "of 1048576; not read"));
}

// Zero is not a positive number, and the range the message gives says so.
TEST(SceneLimitsTest, PositiveNumbersRefuseZero) {
  ExpectRefused(SmallSceneJson(kPlane, R"("camera": {"fx": 0})"),
                "camera.fx: must be in (0, 1e+07], got 0");
  ExpectRefused(SmallSceneJson(kPlane, R"("camera": {"fx": -5})"),
                "camera.fx: must be in (0, 1e+07], got -5");
  EXPECT_OK(ParseScene(SmallSceneJson(kPlane, R"("camera": {"fx": 1e7})")));
}

// A file is named in front of the parser's errors; a missing one is
// NOT_FOUND.
TEST(SceneLimitsTest, AFileIsNamedInItsErrors) {
  ::hdrstereo::testing::TempDir dir;
  const std::filesystem::path file = dir / "scene.json";
  ASSERT_OK(io::WriteFileAtomically(file, R"({"objects": 3})"));
  EXPECT_THAT(LoadSceneFile(file),
              StatusIs(absl::StatusCode::kInvalidArgument,
                       file.string() + ": scene: objects: expected an array"));
  EXPECT_THAT(LoadSceneFile(dir / "none.json"),
              StatusIs(absl::StatusCode::kNotFound,
                       "cannot open " + (dir / "none.json").string() +
                           ": No such file or directory"));
}

}  // namespace
}  // namespace hdrstereo::sim
