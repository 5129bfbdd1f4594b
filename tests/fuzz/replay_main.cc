// SPDX-License-Identifier: GPL-3.0-or-later
//
// Runs a fuzz target's LLVMFuzzerTestOneInput over files, as libFuzzer does
// when given files instead of a corpus to grow, so that the normal (GCC)
// build replays the committed corpus and every crash ever found as a ctest.
//
//   <target>_replay FILE_OR_DIR...
//
// A missing directory is skipped with a note (a target may have no crash
// regressions); replaying no input at all is an error, so the test cannot
// pass by running nothing.
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {

namespace fs = std::filesystem;

bool Replay(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "cannot read %s\n", file.c_str());
    return false;
  }
  const std::string bytes((std::istreambuf_iterator<char>(in)),
                          std::istreambuf_iterator<char>());
  std::fprintf(stderr, "replaying %s (%zu bytes)\n", file.c_str(),
               bytes.size());
  // libFuzzer never passes a null pointer, also for empty inputs.
  static const uint8_t kEmpty = 0;
  const auto* data =
      bytes.empty() ? &kEmpty : reinterpret_cast<const uint8_t*>(bytes.data());
  LLVMFuzzerTestOneInput(data, bytes.size());
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  int replayed = 0;
  for (int i = 1; i < argc; ++i) {
    const fs::path path = argv[i];
    std::error_code error;
    if (!fs::exists(path, error)) {
      std::fprintf(stderr, "no %s: skipped\n", path.c_str());
      continue;
    }
    std::vector<fs::path> files;
    if (fs::is_directory(path)) {
      for (const fs::directory_entry& entry : fs::directory_iterator(path)) {
        if (entry.is_regular_file()) files.push_back(entry.path());
      }
    } else {
      files.push_back(path);
    }
    for (const fs::path& file : files) {
      if (!Replay(file)) return 1;
      ++replayed;
    }
  }
  if (replayed == 0) {
    std::fprintf(stderr, "no input replayed\n");
    return 1;
  }
  std::printf("replayed %d inputs without a crash\n", replayed);
  return 0;
}
