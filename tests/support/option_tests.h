// SPDX-License-Identifier: GPL-3.0-or-later
//
// Checks every option struct of processing/ passes (processing/base/
// options.h):
//
//   ExpectRulesNameTheirField<StereoOptions>({
//       {[](StereoOptions& o) { o.radius = 0; }, "radius is 0"}, ...});
//   ExpectJsonHasEveryField<StereoOptions>({
//       {"/radius", [](StereoOptions& o) { o.radius = 3; }}, ...});
//
// The first breaks one rule per case and expects INVALID_ARGUMENT whose
// message contains the text (which names the field); the second changes one
// field per case and expects the canonical JSON to change in exactly that
// field, so a field missing from the JSON (a cache key that ignores it) or
// two fields sharing a key fail.
#ifndef HDRSTEREO_TESTS_SUPPORT_OPTION_TESTS_H_
#define HDRSTEREO_TESTS_SUPPORT_OPTION_TESTS_H_

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "processing/base/options.h"
#include "tests/support/status_matchers.h"

namespace hdrstereo::testing {

template <typename T>
struct RuleCase {
  std::function<void(T&)> edit;
  std::string message;  // a part of the error, naming the field
};

template <typename T>
struct FieldCase {
  std::string pointer;  // the field's JSON pointer, "/guided/radius"
  std::function<void(T&)> edit;
};

// The JSON pointers whose values differ between `a` and `b`.
inline std::set<std::string> ChangedFields(const nlohmann::json& a,
                                           const nlohmann::json& b) {
  const nlohmann::json fa = a.flatten(), fb = b.flatten();
  std::set<std::string> out;
  for (const auto& [key, value] : fa.items()) {
    if (!fb.contains(key) || fb[key] != value) out.insert(key);
  }
  for (const auto& [key, value] : fb.items()) {
    if (!fa.contains(key)) out.insert(key);
  }
  return out;
}

// `key` is the field `pointer` or inside it ("/weights/3" in "/weights").
inline bool Within(const std::string& key, const std::string& pointer) {
  return key == pointer || key.rfind(pointer + "/", 0) == 0;
}

template <typename T>
void ExpectRulesNameTheirField(const std::vector<RuleCase<T>>& cases,
                               const T& valid = T()) {
  ASSERT_OK(valid.Validate());
  for (const RuleCase<T>& c : cases) {
    T options = valid;
    c.edit(options);
    EXPECT_THAT(options.Validate(), StatusIs(absl::StatusCode::kInvalidArgument,
                                             ::testing::HasSubstr(c.message)));
  }
}

template <typename T>
void ExpectJsonHasEveryField(const std::vector<FieldCase<T>>& cases,
                             const T& base = T()) {
  const nlohmann::json before = base;
  EXPECT_EQ(CanonicalJson(base), before.dump());
  for (const FieldCase<T>& c : cases) {
    T options = base;
    c.edit(options);
    const nlohmann::json after = options;
    const std::set<std::string> changed = ChangedFields(before, after);
    EXPECT_FALSE(changed.empty()) << c.pointer << " is not in the JSON";
    for (const std::string& key : changed) {
      EXPECT_TRUE(Within(key, c.pointer))
          << "changing " << c.pointer << " also changed " << key;
    }
    EXPECT_NE(CanonicalJson(options), CanonicalJson(base)) << c.pointer;
  }
  // Every field of the JSON form has a case.
  std::set<std::string> covered;
  for (const FieldCase<T>& c : cases) covered.insert(c.pointer);
  const nlohmann::json fields = before.flatten();
  for (const auto& [key, value] : fields.items()) {
    const bool listed =
        std::any_of(covered.begin(), covered.end(),
                    [&](const std::string& p) { return Within(key, p); });
    EXPECT_TRUE(listed) << key << " has no case";
  }
}

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_OPTION_TESTS_H_
