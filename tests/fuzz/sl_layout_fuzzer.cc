// SPDX-License-Identifier: GPL-3.0-or-later
// Structured-light layout files describing another lab's capture, and the
// file names their `files` template makes.
#include <string>

#include "processing/structured_light/frame_layout.h"
#include "tests/fuzz/fuzz_support.h"

namespace {

// Every frame of a layout that parsed has a file name, a short relative
// path inside the capture folder.
void CheckFileName(const absl::StatusOr<std::string>& file_name) {
  FUZZ_CHECK(file_name.ok());
  const std::string& name = *file_name;
  FUZZ_CHECK(!name.empty() && name.size() <= 4096);
  FUZZ_CHECK(name.front() != '/');
  FUZZ_CHECK(name != ".." && name.rfind("../", 0) != 0 &&
             name.find("/../") == std::string::npos &&
             (name.size() < 3 || name.compare(name.size() - 3, 3, "/..") != 0));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using hdrstereo::structured_light::CodeLayout;
  absl::StatusOr<hdrstereo::structured_light::FrameLayout> layout =
      hdrstereo::structured_light::ParseFrameLayout(
          hdrstereo::fuzz::AsText(data, size));
  if (!layout.ok()) return 0;
  for (const std::string& view : layout->views) {
    CheckFileName(layout->FileName(layout->white, view));
    CheckFileName(layout->FileName(layout->black, view));
    for (const CodeLayout* code : {&layout->columns, &layout->rows}) {
      for (int bit = 0; bit < code->bits; ++bit) {
        CheckFileName(layout->FileName(code->Frame(bit, false), view));
        CheckFileName(layout->FileName(code->Frame(bit, true), view));
      }
    }
  }
  return 0;
}
