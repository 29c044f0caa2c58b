// Piecewise-constant distributions over [0, 1) and [0, 1)^2 (pbrt-v4 A.5.1 and A.5.6): sampled by
// inverting their cumulative sums, so a function tabulated on a grid is drawn in proportion to its
// values. Built on the host into plain arrays; the views read them on either backend.
#pragma once

#include <cstdint>
#include <vector>

#include "renderer/base/vec.h"

namespace caustica {

// n values f_i over [i / n, (i + 1) / n), their cumulative sums cdf_0 = 0 ... cdf_n = 1 and the
// integral (the mean of the values). A function that is zero everywhere is drawn uniformly.
struct PiecewiseConstant1D {
  const float* func = nullptr;
  const float* cdf = nullptr;  // n + 1
  uint32_t n = 0;
  float integral = 0.0f;

  // x in [0, 1) drawn in proportion to f, its density f(x) / integral, and its piece.
  CAUSTICA_HDI float sample(float u, float* pdf, uint32_t* piece) const {
    // The last i with cdf[i] <= u, by bisection.
    uint32_t lo = 0, hi = n;
    while (hi - lo > 1) {
      const uint32_t mid = (lo + hi) / 2;
      if (cdf[mid] <= u) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    const float width = cdf[lo + 1] - cdf[lo];
    const float du = width > 0.0f ? (u - cdf[lo]) / width : 0.0f;
    if (pdf != nullptr) *pdf = integral > 0.0f ? func[lo] / integral : 1.0f;
    if (piece != nullptr) *piece = lo;
    const float x = (float(lo) + min_f(du, 0.99999994f)) / float(n);
    return x < 1.0f ? x : 0.99999994f;
  }

  CAUSTICA_HDI float pdf(float x) const {
    uint32_t i = uint32_t(x * float(n));
    if (i >= n) i = n - 1;
    return integral > 0.0f ? func[i] / integral : 1.0f;
  }
};

// A 2D distribution: the marginal over rows v and, for each row, the conditional over u.
struct PiecewiseConstant2D {
  const float* func = nullptr;      // nv rows of nu values
  const float* row_cdfs = nullptr;  // nv rows of nu + 1 values
  const float* row_integrals = nullptr;
  const float* marginal_cdf = nullptr;  // nv + 1
  uint32_t nu = 0, nv = 0;
  float integral = 0.0f;

  CAUSTICA_HDI PiecewiseConstant1D row(uint32_t v) const {
    return {func + size_t(v) * nu, row_cdfs + size_t(v) * (nu + 1), nu, row_integrals[v]};
  }
  CAUSTICA_HDI PiecewiseConstant1D marginal() const {
    return {row_integrals, marginal_cdf, nv, integral};
  }

  // (u, v) in [0, 1)^2 drawn in proportion to f, and its density over [0, 1)^2.
  CAUSTICA_HDI Vec2f sample(float u0, float u1, float* pdf) const {
    float pdf_v, pdf_u;
    uint32_t v_piece;
    const float v = marginal().sample(u1, &pdf_v, &v_piece);
    const float u = row(v_piece).sample(u0, &pdf_u, nullptr);
    if (pdf != nullptr) *pdf = pdf_v * pdf_u;
    return {u, v};
  }

  CAUSTICA_HDI float pdf(Vec2f p) const {
    uint32_t iu = uint32_t(p.x * float(nu)), iv = uint32_t(p.y * float(nv));
    if (iu >= nu) iu = nu - 1;
    if (iv >= nv) iv = nv - 1;
    return integral > 0.0f ? func[size_t(iv) * nu + iu] / integral : 1.0f;
  }
};

// The arrays a PiecewiseConstant2D reads, built on the host from `func` (nv rows of nu values,
// none negative).
struct PiecewiseConstant2DData {
  std::vector<float> func, row_cdfs, row_integrals, marginal_cdf;
  uint32_t nu = 0, nv = 0;
  float integral = 0.0f;

  PiecewiseConstant2D view() const {
    return {func.data(), row_cdfs.data(), row_integrals.data(), marginal_cdf.data(), nu,
            nv,          integral};
  }
};

// The cumulative sums of `n` values (their mean in `integral`), uniform where all are zero.
inline void cumulative(const float* f, uint32_t n, float* cdf, float* integral) {
  double sum = 0.0;
  cdf[0] = 0.0f;
  for (uint32_t i = 0; i < n; ++i) {
    sum += double(f[i]) / n;
    cdf[i + 1] = float(sum);
  }
  *integral = float(sum);
  for (uint32_t i = 1; i <= n; ++i)
    cdf[i] = sum > 0.0 ? float(double(cdf[i]) / sum) : float(i) / float(n);
  cdf[n] = 1.0f;
}

inline PiecewiseConstant2DData build_piecewise_constant_2d(std::vector<float> func, uint32_t nu,
                                                           uint32_t nv) {
  PiecewiseConstant2DData d;
  d.func = std::move(func);
  d.nu = nu;
  d.nv = nv;
  d.row_cdfs.resize(size_t(nv) * (nu + 1));
  d.row_integrals.resize(nv);
  d.marginal_cdf.resize(nv + 1);
  for (uint32_t v = 0; v < nv; ++v)
    cumulative(d.func.data() + size_t(v) * nu, nu, d.row_cdfs.data() + size_t(v) * (nu + 1),
               &d.row_integrals[v]);
  cumulative(d.row_integrals.data(), nv, d.marginal_cdf.data(), &d.integral);
  return d;
}

}  // namespace caustica
