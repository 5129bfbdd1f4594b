// SPDX-License-Identifier: GPL-3.0-or-later
#include "tests/support/tmpfs.h"

#include <gtest/gtest.h>
#include <sys/mount.h>

#include <cerrno>
#include <cstring>

#include "absl/strings/str_cat.h"

namespace hdrstereo::testing {

TmpfsMount::TmpfsMount(std::filesystem::path dir, int64_t size_bytes)
    : dir_(std::move(dir)) {
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  const std::string options = absl::StrCat("size=", size_bytes);
  if (ec) {
    error_ = absl::StrCat("cannot create ", dir_.string(), ": ", ec.message());
  } else if (::mount("tmpfs", dir_.c_str(), "tmpfs", MS_NOSUID | MS_NODEV,
                     options.c_str()) != 0) {
    error_ =
        absl::StrCat("cannot mount a tmpfs (", options, ") on ", dir_.string(),
                     " (needs root): ", std::strerror(errno));
  } else {
    mounted_ = true;
  }
}

TmpfsMount::~TmpfsMount() {
  if (mounted_ && ::umount(dir_.c_str()) != 0) {
    ADD_FAILURE() << "cannot unmount " << dir_ << ": " << std::strerror(errno);
  }
}

}  // namespace hdrstereo::testing
