// SPDX-License-Identifier: GPL-3.0-or-later
//
// A fresh folder under $TMPDIR (or /tmp), removed with everything in it when
// the object goes away.
#ifndef HDRSTEREO_TESTS_SUPPORT_TEMP_DIR_H_
#define HDRSTEREO_TESTS_SUPPORT_TEMP_DIR_H_

#include <filesystem>
#include <string>

namespace hdrstereo::testing {

class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const {
    return path_ / name;
  }

 private:
  std::filesystem::path path_;
};

// Reads a whole file; fails the current test if it cannot.
std::string ReadFileOrDie(const std::filesystem::path& path);

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_TEMP_DIR_H_
