// SPDX-License-Identifier: GPL-3.0-or-later
//
// Real exposure stacks from ../shared/data (HDRSTEREO_SHARED_DIR/data): any
// folder below it holding an exposures.txt. For each 8-bit stack the
// recovered response must be monotonic over the well-exposed codes and the
// merge must be free of seams: wherever a single exposure is well exposed,
// the merged radiance must agree with that exposure's own estimate (a seam
// is exactly a place where the merge jumps away from the exposures it is
// blended from). Skipped, with a message, while no real stack exists.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <vector>

#include "processing/hdr/merge.h"
#include "processing/hdr/response.h"
#include "processing/hdr/stack.h"

namespace hdrstereo::hdr {
namespace {

std::vector<std::filesystem::path> RealStacks() {
  std::vector<std::filesystem::path> out;
  const std::filesystem::path root =
      std::filesystem::path(HDRSTEREO_SHARED_DIR) / "data";
  std::error_code ec;
  if (!std::filesystem::is_directory(root, ec)) return out;
  for (auto it = std::filesystem::recursive_directory_iterator(root, ec);
       !ec && it != std::filesystem::recursive_directory_iterator();
       it.increment(ec)) {
    if (it.depth() > 4) it.disable_recursion_pending();
    if (it->path().filename() == "exposures.txt") {
      out.push_back(it->path().parent_path());
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(RealDataTest, ResponseIsMonotonicAndMergeHasNoSeams) {
  const std::vector<std::filesystem::path> stacks = RealStacks();
  if (stacks.empty()) {
    GTEST_SKIP() << "no real exposure stack (folder with exposures.txt) under "
                 << HDRSTEREO_SHARED_DIR << "/data yet";
  }
  for (const auto& dir : stacks) {
    SCOPED_TRACE(dir.string());
    absl::StatusOr<ExposureStack> stack = LoadStack(dir);
    ASSERT_TRUE(stack.ok()) << stack.status();
    CameraResponse response = LinearResponse();
    if (stack->images[0].depth() == CV_8U) {
      absl::StatusOr<CameraResponse> r = RecoverResponse(*stack);
      ASSERT_TRUE(r.ok()) << r.status();
      for (int c = 0; c < r->log_inverse.channels(); ++c) {
        for (int z = 17; z <= 239; ++z) {
          ASSERT_GT(r->log_inverse.ptr<float>(z)[c],
                    r->log_inverse.ptr<float>(z - 1)[c])
              << "response not monotonic at code " << z << ", channel " << c;
        }
      }
      response = *r;
    }
    absl::StatusOr<MergeResult> m = MergeStack(*stack, response);
    ASSERT_TRUE(m.ok()) << m.status();
    // Each exposure's own estimate where it is well exposed (8-bit: codes
    // 30..225) vs the merge: median |ln ratio| <= 0.05 (5%).
    if (response.linear) continue;
    for (size_t j = 0; j < stack->images.size(); ++j) {
      const cv::Mat& img = stack->images[j];
      const int ch = img.channels();
      std::vector<float> diffs;
      for (int y = 0; y < img.rows; y += 2) {
        const uint8_t* src = img.ptr<uint8_t>(y);
        const float* rad = m->radiance.ptr<float>(y);
        for (int i = 0; i < img.cols * ch; i += 2) {
          const int z = src[i];
          if (z < 30 || z > 225) continue;
          const float own = response.log_inverse.ptr<float>(z)[i % ch] -
                            static_cast<float>(std::log(stack->exposure_s[j]));
          diffs.push_back(std::abs(std::log(rad[i]) - own));
        }
      }
      if (diffs.size() < 100) continue;
      std::nth_element(diffs.begin(), diffs.begin() + diffs.size() / 2,
                       diffs.end());
      EXPECT_LE(diffs[diffs.size() / 2], 0.05) << stack->Name(j);
    }
  }
}

}  // namespace
}  // namespace hdrstereo::hdr
