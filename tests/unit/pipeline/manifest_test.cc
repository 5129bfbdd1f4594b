// SPDX-License-Identifier: GPL-3.0-or-later
//
// The manifest a computed step writes (pipeline/<step>.json) is JSON built
// with nlohmann-json: names with quotes, backslashes, control characters or
// bytes that are not UTF-8, and NaN parameters, still give a valid document
// that parses back to what was written.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "processing/pipeline/pipeline.h"

namespace hdrstereo::pipeline {
namespace {

Artifact Output(const std::string& path, const std::string& sha256) {
  Artifact a;
  a.step = "step";
  a.kind = "hdr";
  a.path = path;
  a.sha256 = sha256;
  return a;
}

TEST(PipelineManifestTest, HostileNamesRoundTrip) {
  const std::string step = "tone\"map\\\n\t\x01";
  const std::string path = "hdr/a \"b\"\\c\r\n\x1f.exr";
  const nlohmann::json params = {
      {"label", "quote \" backslash \\ bell \a"},
      {"sigma", std::numeric_limits<double>::quiet_NaN()},
      {"limit", std::numeric_limits<double>::infinity()},
      {"radius", 9}};
  const std::vector<Artifact> outputs = {Output(path, "ab\"cd"),
                                         Output("plain.exr", "00")};
  const std::string text = StepManifestJson(step, "h\\ash", params, outputs);
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');

  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << text;
  EXPECT_EQ(j.at("step"), step);
  EXPECT_EQ(j.at("input_hash"), "h\\ash");
  EXPECT_TRUE(j.at("version").is_string());
  EXPECT_EQ(j.at("params").at("label"), "quote \" backslash \\ bell \a");
  EXPECT_EQ(j.at("params").at("radius"), 9);
  // nlohmann writes NaN and infinity as null.
  EXPECT_TRUE(j.at("params").at("sigma").is_null());
  EXPECT_TRUE(j.at("params").at("limit").is_null());
  const nlohmann::json& files = j.at("outputs");
  ASSERT_EQ(files.size(), 2u);
  EXPECT_EQ(files.at(0).at("path"), path);
  EXPECT_EQ(files.at(0).at("sha256"), "ab\"cd");
  EXPECT_EQ(files.at(1).at("path"), "plain.exr");
}

// Text that is not UTF-8 is replaced by U+FFFD instead of throwing.
TEST(PipelineManifestTest, BytesThatAreNotUtf8AreReplaced) {
  const std::string text =
      StepManifestJson("step", "hash", nlohmann::json::object(),
                       {Output("bad\xff\xfe.png", "")});
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << text;
  EXPECT_EQ(j.at("outputs").at(0).at("path"),
            "bad\xEF\xBF\xBD\xEF\xBF\xBD.png");
}

TEST(PipelineManifestTest, AStepWithoutOutputsListsNone) {
  const nlohmann::json j = nlohmann::json::parse(
      StepManifestJson("sl_groundtruth", "hash", nullptr, {}), nullptr, false);
  ASSERT_FALSE(j.is_discarded());
  EXPECT_EQ(j.at("outputs"), nlohmann::json::array());
  EXPECT_TRUE(j.at("params").is_null());
}

}  // namespace
}  // namespace hdrstereo::pipeline
