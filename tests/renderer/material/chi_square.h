// Helpers of the material tests: directions by angle, integrals over the hemisphere by Simpson's
// rule, and the chi-square test of a sampler against the density it claims.
#pragma once

#include <algorithm>
#include <boost/math/special_functions/gamma.hpp>
#include <cmath>
#include <functional>
#include <random>
#include <vector>

#include "renderer/material/bsdf.h"

namespace caustica {

constexpr double kPiD = 3.14159265358979323846;

inline Vec3f direction_at(double theta_degrees, double phi = 0.3) {
  const double t = theta_degrees * kPiD / 180.0;
  return Vec3f(float(std::sin(t) * std::cos(phi)), float(std::sin(t) * std::sin(phi)),
               float(std::cos(t)));
}

// The integral over the upper hemisphere of g(w) dw by Simpson's rule in (cos theta, phi), each
// of `z_cells` x `phi_cells` cells cut in `sub` x `sub` panels.
inline double hemisphere_integral(const std::function<double(Vec3f)>& g, int z_cells, int phi_cells,
                                  int sub, double z0 = 0.0, double z1 = 1.0) {
  const int nz = 2 * sub * z_cells, nphi = 2 * sub * phi_cells;
  const double hz = (z1 - z0) / nz, hphi = 2.0 * kPiD / nphi;
  double sum = 0.0;
  for (int i = 0; i <= nz; ++i) {
    const double z = z0 + i * hz;
    const double wz = (i == 0 || i == nz) ? 1.0 : (i % 2 ? 4.0 : 2.0);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    for (int j = 0; j <= nphi; ++j) {
      const double phi = j * hphi;
      const double wphi = (j == 0 || j == nphi) ? 1.0 : (j % 2 ? 4.0 : 2.0);
      sum += wz * wphi * g(Vec3f(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z)));
    }
  }
  return sum * hz * hphi / 9.0;
}

// A chi-square test of `sample` against `pdf` for outgoing direction `wo`: `samples` directions
// counted in cells of equal cos theta and phi over the upper hemisphere (the whole sphere for
// models that transmit), plus one cell for the draws that gave no direction, against the counts
// the pdf's integral over each cell expects. Returns the p-value of the counts under the
// hypothesis that the sampler draws from pdf.
template <typename Bsdf>
double chi_square_p_value(const Bsdf& bsdf, Vec3f wo, int samples, uint32_t seed) {
  const bool sphere = (bsdf.flags() & kBsdfTransmission) != 0;
  const double z_min = sphere ? -1.0 : 0.0, z_cell = (1.0 - z_min) / (sphere ? 20 : 10);
  const int kZ = sphere ? 20 : 10;
  constexpr int kPhi = 20;
  std::vector<double> observed(kZ * kPhi + 1, 0.0);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < samples; ++i) {
    const BsdfSample s = bsdf.sample(wo, u(rng), u(rng), u(rng));
    if (!s.valid()) {
      observed[kZ * kPhi] += 1;
      continue;
    }
    const int zi = std::max(0, std::min(kZ - 1, int((s.wi.z - z_min) / z_cell)));
    double phi = std::atan2(double(s.wi.y), double(s.wi.x));
    if (phi < 0) phi += 2 * kPiD;
    const int pi = std::min(kPhi - 1, int(phi / (2 * kPiD) * kPhi));
    observed[zi * kPhi + pi] += 1;
  }
  std::vector<double> expected(kZ * kPhi + 1, 0.0);
  double total = 0.0;
  for (int zi = 0; zi < kZ; ++zi) {
    for (int pi = 0; pi < kPhi; ++pi) {
      // One cell: z in z_min + [zi, zi + 1) z_cell and phi in [pi, pi + 1) 2 pi / kPhi, by
      // Simpson's rule over theta (d omega = sin theta d theta d phi), whose even steps resolve
      // lobes at the poles that steps even in z would not.
      // The cells at the poles, where a lobe of a direction along the normal peaks, in finer
      // steps of theta.
      constexpr int kSub = 40;
      const int theta_sub = (zi == 0 || zi == kZ - 1) ? 8 * kSub : kSub;
      const double t_low = std::acos(std::min(1.0, z_min + (zi + 1) * z_cell));
      const double t_high = std::acos(std::max(-1.0, z_min + zi * z_cell));
      const double ht = (t_high - t_low) / (2 * theta_sub);
      const double p0 = 2 * kPiD * pi / kPhi, hp = 2 * kPiD / kPhi / (2 * kSub);
      double sum = 0.0;
      for (int a = 0; a <= 2 * theta_sub; ++a) {
        const double theta = t_low + a * ht, r = std::sin(theta), z = std::cos(theta);
        const double wa = (a == 0 || a == 2 * theta_sub) ? 1.0 : (a % 2 ? 4.0 : 2.0);
        for (int b = 0; b <= 2 * kSub; ++b) {
          const double phi = p0 + b * hp;
          const double wb = (b == 0 || b == 2 * kSub) ? 1.0 : (b % 2 ? 4.0 : 2.0);
          const Vec3f wi(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
          sum += wa * wb * bsdf.pdf(wo, wi) * r;
        }
      }
      expected[zi * kPhi + pi] = sum * ht * hp / 9.0 * samples;
      total += expected[zi * kPhi + pi];
    }
  }
  expected[kZ * kPhi] = std::max(0.0, samples - total);
  // Cells expecting fewer than 5 draws are pooled, as the test's approximation needs.
  double chi2 = 0.0, pooled_observed = 0.0, pooled_expected = 0.0;
  int cells = 0;
  for (size_t c = 0; c < expected.size(); ++c) {
    if (expected[c] < 5.0) {
      pooled_observed += observed[c];
      pooled_expected += expected[c];
      continue;
    }
    chi2 += (observed[c] - expected[c]) * (observed[c] - expected[c]) / expected[c];
    ++cells;
  }
  if (pooled_expected >= 5.0) {
    chi2 +=
        (pooled_observed - pooled_expected) * (pooled_observed - pooled_expected) / pooled_expected;
    ++cells;
  } else if (pooled_observed > 10.0 * std::max(pooled_expected, 1.0)) {
    return 0.0;  // draws where the pdf says there are none
  }
  return boost::math::gamma_q(0.5 * (cells - 1), 0.5 * chi2);
}

}  // namespace caustica
