// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/io/sha256.h"

#include <gtest/gtest.h>

#include "processing/io/atomic_file.h"
#include "tests/support/temp_dir.h"

namespace hdrstereo::io {
namespace {

// FIPS 180-2 test vectors.
TEST(Sha256Test, KnownVectors) {
  EXPECT_EQ(Sha256Hex(""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(Sha256Test, FileMatchesBytesAndMissingFileIsNotFound) {
  hdrstereo::testing::TempDir dir;
  const std::string data(3 << 20, 'q');  // larger than one read buffer
  ASSERT_TRUE(WriteFileAtomically(dir / "f", data).ok());
  absl::StatusOr<std::string> hash = Sha256HexOfFile(dir / "f");
  ASSERT_TRUE(hash.ok());
  EXPECT_EQ(*hash, Sha256Hex(data));
  EXPECT_EQ(Sha256HexOfFile(dir / "missing").status().code(),
            absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace hdrstereo::io
