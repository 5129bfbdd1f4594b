// SPDX-License-Identifier: GPL-3.0-or-later
//
// What every fuzz target shares: the input as bytes or text, and FUZZ_CHECK
// for the properties a target asserts about what a parser accepted (a
// failed check aborts, which libFuzzer and the replay driver report as a
// crash with its input).
#ifndef HDRSTEREO_TESTS_FUZZ_FUZZ_SUPPORT_H_
#define HDRSTEREO_TESTS_FUZZ_FUZZ_SUPPORT_H_

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>

#include "absl/strings/string_view.h"

#define FUZZ_CHECK(condition)                                          \
  do {                                                                 \
    if (!(condition)) {                                                \
      std::fprintf(stderr, "%s:%d: FUZZ_CHECK failed: %s\n", __FILE__, \
                   __LINE__, #condition);                              \
      std::abort();                                                    \
    }                                                                  \
  } while (false)

namespace hdrstereo::fuzz {

inline absl::string_view AsText(const uint8_t* data, size_t size) {
  return absl::string_view(reinterpret_cast<const char*>(data), size);
}

}  // namespace hdrstereo::fuzz

#endif  // HDRSTEREO_TESTS_FUZZ_FUZZ_SUPPORT_H_
