// SPDX-License-Identifier: GPL-3.0-or-later
#include "hardware/sim/noise.h"

#include <algorithm>

namespace hdrstereo::sim {
namespace {

double LatticeValue(int64_t ix, int64_t iy, uint64_t seed) {
  return UniformFromBits(HashCombine(
      HashCombine(seed, static_cast<uint64_t>(ix)), static_cast<uint64_t>(iy)));
}

double Fade(double t) { return t * t * t * (t * (t * 6 - 15) + 10); }

double ValueNoise(double x, double y, uint64_t seed) {
  const double fx = std::floor(x), fy = std::floor(y);
  const int64_t ix = static_cast<int64_t>(fx), iy = static_cast<int64_t>(fy);
  const double tx = Fade(x - fx), ty = Fade(y - fy);
  const double a = LatticeValue(ix, iy, seed),
               b = LatticeValue(ix + 1, iy, seed),
               c = LatticeValue(ix, iy + 1, seed),
               d = LatticeValue(ix + 1, iy + 1, seed);
  return (a * (1 - tx) + b * tx) * (1 - ty) + (c * (1 - tx) + d * tx) * ty;
}

}  // namespace

double FractalNoise2d(double x, double y, int octaves, uint64_t seed) {
  double sum = 0;
  double scale = 1.0;
  for (int k = 0; k < octaves; ++k) {
    sum += ValueNoise(x * scale, y * scale, HashCombine(seed, k));
    scale *= 0.5;
  }
  const double mean = sum / std::max(1, octaves);
  // Averaging narrows the distribution; stretch it back towards [0, 1].
  const double stretch = 1.0 + 0.6 * (octaves - 1);
  return std::clamp(0.5 + (mean - 0.5) * stretch, 0.0, 1.0);
}

}  // namespace hdrstereo::sim
