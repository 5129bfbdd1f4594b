// SPDX-License-Identifier: GPL-3.0-or-later
//
// A real small filesystem for tests of a full disk: a tmpfs of a given size
// mounted on a folder for the object's lifetime. Mounting needs root (CI
// runs as root); where it is not permitted, mounted() is false and error()
// says why, for GTEST_SKIP.
#ifndef HDRSTEREO_TESTS_SUPPORT_TMPFS_H_
#define HDRSTEREO_TESTS_SUPPORT_TMPFS_H_

#include <cstdint>
#include <filesystem>
#include <string>

namespace hdrstereo::testing {

class TmpfsMount {
 public:
  // Creates `dir` and mounts a tmpfs of `size_bytes` on it.
  TmpfsMount(std::filesystem::path dir, int64_t size_bytes);
  // Unmounts; whatever uses the folder (a daemon) must have ended.
  ~TmpfsMount();
  TmpfsMount(const TmpfsMount&) = delete;
  TmpfsMount& operator=(const TmpfsMount&) = delete;

  bool mounted() const { return mounted_; }
  const std::string& error() const { return error_; }

 private:
  std::filesystem::path dir_;
  bool mounted_ = false;
  std::string error_;
};

}  // namespace hdrstereo::testing

#endif  // HDRSTEREO_TESTS_SUPPORT_TMPFS_H_
