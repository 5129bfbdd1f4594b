// SPDX-License-Identifier: GPL-3.0-or-later
//
// Counter-based random numbers: every value is a pure function of a seed and
// a position, so results do not depend on thread scheduling.
#ifndef HDRSTEREO_HARDWARE_SIM_NOISE_H_
#define HDRSTEREO_HARDWARE_SIM_NOISE_H_

#include <cmath>
#include <cstdint>

namespace hdrstereo::sim {

inline uint64_t SplitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

inline uint64_t HashCombine(uint64_t a, uint64_t b) {
  return SplitMix64(a ^ (SplitMix64(b) + 0x632be59bd9b4e019ULL));
}

// Uniform in (0, 1).
inline double UniformFromBits(uint64_t bits) {
  return (static_cast<double>(bits >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

// Smooth value noise in [0, 1] at (x, y) in lattice units; `octaves` layers,
// each twice as coarse as the previous, equally weighted, contrast-stretched.
double FractalNoise2d(double x, double y, int octaves, uint64_t seed);

}  // namespace hdrstereo::sim

#endif  // HDRSTEREO_HARDWARE_SIM_NOISE_H_
