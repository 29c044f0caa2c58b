// The scattering models against what they must satisfy whatever their parameters: sampled
// directions distributed as pdf() says (a chi-square test over the hemisphere, as pbrt and Mitsuba
// test theirs), f symmetric in its directions, the GGX distribution and its visible normals
// normalised, and no reflection of more light than arrives (the white furnace), with GGX's loss
// from single scattering equal to the quadrature of f.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "renderer/material/metallic_roughness.h"
#include "renderer/material/modified_phong.h"
#include "renderer/material/rough_dielectric.h"
#include "tests/renderer/material/chi_square.h"

namespace caustica {
namespace {

// Every test below runs a few dozen chi-square tests; each must pass at this level, so that the
// whole file fails by chance with probability about 1%.
constexpr double kSignificance = 0.01 / 60;

std::vector<MetallicRoughnessBsdf> metallic_roughness_cases() {
  std::vector<MetallicRoughnessBsdf> out;
  for (float roughness : {0.3f, 0.6f, 1.0f})
    for (float metallic : {0.0f, 0.5f, 1.0f})
      out.push_back({Vec3f(0.9f, 0.6f, 0.2f), metallic, roughness});
  return out;
}

std::vector<ModifiedPhongBsdf> phong_cases() {
  return {{Vec3f(0.5f), Vec3f(0.4f), 2.0f},
          {Vec3f(0.3f, 0.2f, 0.1f), Vec3f(0.6f), 20.0f},
          {Vec3f(0.0f), Vec3f(0.9f), 60.0f},
          {Vec3f(0.8f), Vec3f(0.0f), 10.0f}};
}

TEST(MetallicRoughness, SamplesFollowThePdf) {
  uint32_t seed = 1;
  for (const MetallicRoughnessBsdf& m : metallic_roughness_cases()) {
    for (double theta : {0.0, 35.0, 70.0, 85.0}) {
      const double p = chi_square_p_value(m, direction_at(theta), 400000, seed++);
      EXPECT_GT(p, kSignificance) << "roughness " << m.roughness << " metallic " << m.metallic
                                  << " theta " << theta;
    }
  }
}

TEST(ModifiedPhong, SamplesFollowThePdf) {
  uint32_t seed = 100;
  for (const ModifiedPhongBsdf& m : phong_cases()) {
    for (double theta : {0.0, 35.0, 70.0, 85.0}) {
      const double p = chi_square_p_value(m, direction_at(theta), 400000, seed++);
      EXPECT_GT(p, kSignificance) << "exponent " << m.exponent << " theta " << theta;
    }
  }
}

// The test's power: a sampler whose lobe is a little too wide fails it.
TEST(ChiSquare, RejectsASamplerThatDoesNotMatchItsPdf) {
  struct Wider {
    ModifiedPhongBsdf drawn{Vec3f(0.0f), Vec3f(0.9f), 18.0f};
    ModifiedPhongBsdf claimed{Vec3f(0.0f), Vec3f(0.9f), 20.0f};
    BsdfSample sample(Vec3f wo, float uc, float u0, float u1) const {
      return drawn.sample(wo, uc, u0, u1);
    }
    float pdf(Vec3f wo, Vec3f wi) const { return claimed.pdf(wo, wi); }
    uint32_t flags() const { return claimed.flags(); }
  };
  EXPECT_LT(chi_square_p_value(Wider{}, direction_at(30.0), 400000, 7), 1e-6);
}

template <typename Bsdf>
void expect_reciprocal(const Bsdf& bsdf, const std::string& label) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 2000; ++i) {
    const Vec3f a = sample_cosine_hemisphere(u(rng), u(rng));
    const Vec3f b = sample_cosine_hemisphere(u(rng), u(rng));
    const Vec3f ab = bsdf.f(a, b), ba = bsdf.f(b, a);
    for (int c = 0; c < 3; ++c)
      ASSERT_NEAR(ab[c], ba[c], 1e-5f * std::max(1.0f, std::fabs(ab[c]))) << label << " " << i;
  }
}

TEST(MetallicRoughness, IsReciprocal) {
  for (const MetallicRoughnessBsdf& m : metallic_roughness_cases())
    expect_reciprocal(m, "roughness " + std::to_string(m.roughness));
}

TEST(ModifiedPhong, IsReciprocal) {
  for (const ModifiedPhongBsdf& m : phong_cases())
    expect_reciprocal(m, "exponent " + std::to_string(m.exponent));
}

// D cos integrates to one over the hemisphere, and so do the normals each direction sees.
TEST(TrowbridgeReitz, DistributionAndVisibleNormalsAreNormalised) {
  for (float alpha : {0.05f, 0.2f, 0.5f, 1.0f}) {
    const TrowbridgeReitz d{alpha};
    // Isotropic: 2 pi times the integral over z = cos theta of D z, in fine steps near z = 1
    // where a small alpha puts nearly all of it.
    double projected = 0.0;
    const int n = 200000;
    for (int i = 0; i <= n; ++i) {
      const double z = double(i) / n, w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
      const float r = float(std::sqrt(std::max(0.0, 1.0 - z * z)));
      projected += w * d.D(Vec3f(r, 0.0f, float(z))) * z;
    }
    projected *= 2 * kPiD / (3.0 * n);
    EXPECT_NEAR(projected, 1.0, 1e-3) << "alpha " << alpha;
    if (alpha < 0.2f) continue;  // too sharp for the hemisphere quadrature below
    for (double theta : {0.0, 45.0, 80.0}) {
      const Vec3f w = direction_at(theta);
      const double visible =
          hemisphere_integral([&](Vec3f wm) { return double(d.visible_D(w, wm)); }, 40, 40, 4);
      EXPECT_NEAR(visible, 1.0, 2e-3) << "alpha " << alpha << " theta " << theta;
    }
  }
}

// At the smallest alpha the models use, the distribution's peak is 1 / (pi alpha^2) and a metal's
// samples have finite densities and weights: its denominator once cancelled to zero there, and a
// roughness map's smoothest texels made NaN paths.
TEST(TrowbridgeReitz, StaysFiniteAtTheSmallestAlpha) {
  const TrowbridgeReitz d{kMinMicrofacetAlpha};
  const double peak = 1.0 / (kPiD * double(kMinMicrofacetAlpha) * kMinMicrofacetAlpha);
  EXPECT_NEAR(d.D(Vec3f(0.0f, 0.0f, 1.0f)) / peak, 1.0, 1e-5);
  const MetallicRoughnessBsdf metal{Vec3f(0.9f), 1.0f, 0.0f};
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int finite = 0;
  for (double theta : {0.0, 30.0, 60.0}) {
    const Vec3f wo = direction_at(theta);
    for (int i = 0; i < 10000; ++i) {
      const BsdfSample b = metal.sample(wo, u(rng), u(rng), u(rng));
      if (!b.valid()) continue;
      ASSERT_TRUE(std::isfinite(b.pdf)) << "theta " << theta;
      ASSERT_TRUE(is_finite(b.weight())) << "theta " << theta;
      ++finite;
    }
  }
  EXPECT_GT(finite, 29000);
}

// The white furnace: a metal of base colour 1 has Fresnel 1, so it reflects what GGX's single
// scattering keeps, which f's quadrature gives; every sample's weight is at most 1 (it is
// G(wo, wi) / G1(wo) for visible normals), and the mean of the weights is the quadrature. The
// smoother the surface, the nearer to 1.
TEST(MetallicRoughness, WhiteFurnaceLosesOnlyWhatSingleScatteringLoses) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  double smooth_albedo = 0.0;
  for (float roughness : {0.2f, 0.5f, 1.0f}) {
    const MetallicRoughnessBsdf metal{Vec3f(1.0f), 1.0f, roughness};
    for (double theta : {0.0, 45.0, 80.0}) {
      const Vec3f wo = direction_at(theta);
      constexpr int kSamples = 200000;
      double sum = 0.0, sum2 = 0.0, worst = 0.0;
      for (int i = 0; i < kSamples; ++i) {
        const BsdfSample s = metal.sample(wo, u(rng), u(rng), u(rng));
        const double w = s.valid() ? double(s.weight().y) : 0.0;
        sum += w;
        sum2 += w * w;
        worst = std::max(worst, w);
      }
      const double mean = sum / kSamples;
      const double sigma = std::sqrt(std::max(0.0, sum2 / kSamples - mean * mean) / kSamples);
      EXPECT_LE(worst, 1.0 + 1e-4) << "roughness " << roughness << " theta " << theta;
      if (roughness >= 0.5f) {
        const double quadrature = hemisphere_integral(
            [&](Vec3f wi) { return double(metal.f(wo, wi).y) * wi.z; }, 40, 40, 4);
        EXPECT_NEAR(mean, quadrature, 4 * sigma + 1e-3)
            << "roughness " << roughness << " theta " << theta;
        EXPECT_LT(quadrature, 1.0);
      }
      if (roughness == 0.2f && theta == 0.0) smooth_albedo = mean;
    }
  }
  EXPECT_GT(smooth_albedo, 0.99);
}

// Every model reflects at most what arrives, at every angle and roughness, by quadrature of f cos
// and by the mean of sampled weights.
TEST(Materials, WhiteFurnaceShowsNoGain) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  const auto check = [&](const auto& bsdf, const std::string& label) {
    for (double theta : {0.0, 45.0, 75.0, 88.0}) {
      const Vec3f wo = direction_at(theta);
      constexpr int kSamples = 200000;
      double sum = 0.0;
      for (int i = 0; i < kSamples; ++i) {
        const BsdfSample s = bsdf.sample(wo, u(rng), u(rng), u(rng));
        if (s.valid()) sum += s.weight().y;
      }
      EXPECT_LT(sum / kSamples, 1.0 + 3e-3) << label << " theta " << theta;
      std::printf("%s, theta %g: albedo %.4f\n", label.c_str(), theta, sum / kSamples);
    }
  };
  for (float roughness : {0.3f, 0.6f, 1.0f})
    for (float metallic : {0.0f, 0.5f, 1.0f})
      check(MetallicRoughnessBsdf{Vec3f(1.0f), metallic, roughness},
            "metallic-roughness r " + std::to_string(roughness) + " m " + std::to_string(metallic));
  for (float exponent : {1.0f, 10.0f, 100.0f})
    check(ModifiedPhongBsdf{Vec3f(0.5f), Vec3f(0.5f), exponent},
          "phong n " + std::to_string(exponent));
}

std::vector<RoughDielectricBsdf> dielectric_cases(Transport transport) {
  std::vector<RoughDielectricBsdf> out;
  for (float ior : {1.5f, 1.33f})
    for (float roughness : {0.3f, 0.6f, 1.0f}) out.push_back({ior, roughness, transport});
  return out;
}

// From outside (0 to 70 degrees) and from inside (120 and 150), over the whole sphere.
TEST(RoughDielectric, SamplesFollowThePdf) {
  uint32_t seed = 200;
  for (const RoughDielectricBsdf& m : dielectric_cases(Transport::kRadiance)) {
    for (double theta : {0.0, 35.0, 70.0, 120.0, 150.0}) {
      const double p = chi_square_p_value(m, direction_at(theta), 400000, seed++);
      EXPECT_GT(p, kSignificance) << "ior " << m.ior << " roughness " << m.roughness << " theta "
                                  << theta;
    }
  }
}

// Reflection is reciprocal; transmission for radiance is the adjoint of transmission for
// importance: f_radiance(wo, wi) = f_importance(wi, wo).
TEST(RoughDielectric, RadianceIsTheAdjointOfImportance) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int transmissions = 0;
  for (const RoughDielectricBsdf& radiance : dielectric_cases(Transport::kRadiance)) {
    RoughDielectricBsdf importance = radiance;
    importance.transport = Transport::kImportance;
    for (int i = 0; i < 2000; ++i) {
      const Vec3f a = sample_uniform_sphere(u(rng), u(rng));
      const Vec3f b = sample_uniform_sphere(u(rng), u(rng));
      const float ab = radiance.f(a, b).x, ba = importance.f(b, a).x;
      ASSERT_NEAR(ab, ba, 2e-4f * std::max(1.0f, std::fabs(ab))) << radiance.roughness << " " << i;
      if (same_hemisphere(a, b)) {
        ASSERT_NEAR(ab, radiance.f(b, a).x, 2e-4f * std::max(1.0f, std::fabs(ab))) << i;
      } else if (ab > 0.0f) {
        ++transmissions;
      }
    }
  }
  EXPECT_GT(transmissions, 1000);
}

// The white furnace, carrying importance (as photons do): no sample's weight is above 1 (it is
// G(wo, wi) / G1(wo)), and a nearly smooth boundary at normal incidence reflects the Fresnel
// reflectance ((ior - 1) / (ior + 1))^2 and transmits the rest.
TEST(RoughDielectric, WhiteFurnaceAndFresnel) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (const RoughDielectricBsdf& m : dielectric_cases(Transport::kImportance)) {
    for (double theta : {0.0, 45.0, 80.0, 130.0}) {
      const Vec3f wo = direction_at(theta);
      double sum = 0.0, worst = 0.0;
      constexpr int kSamples = 100000;
      for (int i = 0; i < kSamples; ++i) {
        const BsdfSample s = m.sample(wo, u(rng), u(rng), u(rng));
        if (!s.valid()) continue;
        sum += s.weight().x;
        worst = std::max(worst, double(s.weight().x));
      }
      EXPECT_LE(worst, 1.0 + 1e-4) << "ior " << m.ior << " roughness " << m.roughness;
      EXPECT_LE(sum / kSamples, 1.0) << "ior " << m.ior << " roughness " << m.roughness;
    }
  }
  const RoughDielectricBsdf smooth{1.5f, 0.05f, Transport::kImportance};
  double reflected = 0.0, transmitted = 0.0;
  constexpr int kSamples = 200000;
  for (int i = 0; i < kSamples; ++i) {
    const BsdfSample s = smooth.sample(direction_at(0.0), u(rng), u(rng), u(rng));
    if (!s.valid()) continue;
    (s.wi.z > 0.0f ? reflected : transmitted) += s.weight().x;
  }
  EXPECT_NEAR(reflected / kSamples, 0.04, 0.002);
  EXPECT_NEAR(transmitted / kSamples, 0.96, 0.005);
}

}  // namespace
}  // namespace caustica
