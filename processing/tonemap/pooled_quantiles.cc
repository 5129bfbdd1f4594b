// SPDX-License-Identifier: GPL-3.0-or-later
#include "processing/tonemap/pooled_quantiles.h"

#include <algorithm>

namespace hdrstereo::tonemap {

std::pair<float, float> PooledQuantiles(const std::vector<cv::Mat>& mats,
                                        double q_lo, double q_hi) {
  std::vector<float> pool;
  for (const cv::Mat& m : mats) {
    for (int y = 0; y < m.rows; y += 2) {
      const float* p = m.ptr<float>(y);
      for (int x = 0; x < m.cols; x += 2) pool.push_back(p[x]);
    }
  }
  const size_t n = pool.size();
  const size_t i_lo = std::min(n - 1, static_cast<size_t>(q_lo * (n - 1)));
  const size_t i_hi = std::min(n - 1, static_cast<size_t>(q_hi * (n - 1)));
  std::nth_element(pool.begin(), pool.begin() + i_hi, pool.end());
  const float v_hi = pool[i_hi];
  // Everything before i_hi is now <= v_hi: the lower quantile is among them.
  std::nth_element(pool.begin(), pool.begin() + i_lo, pool.begin() + i_hi + 1);
  return {pool[i_lo], v_hi};
}

}  // namespace hdrstereo::tonemap
