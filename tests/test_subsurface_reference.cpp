// Tests of prt/subsurface_reference.h, the translucent reference
// (docs/SUBSURFACE.md "The reference"): a thick slab against the closed
// form, a material whose light crosses the whole mesh against the plain
// sum over uniform surface samples, two seeds against each other, and the
// refusals.
#include "test_meshes.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/reference.h>
#include <prt/subsurface.h>
#include <prt/subsurface_reference.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

namespace prt::subsurface_reference_test {  // named: the unity build joins this file with others

constexpr double kPi = 3.14159265358979323846;

// Standard errors an unbiased estimate stays within: 4 (a normal variable
// leaves it with probability 6e-5; the seeds are fixed, so a pass is a pass).
constexpr double kSigmas = 4.0;

EnvMap constant_map(float value) {
  return make_latlong(32, 16, std::vector<float>(32 * 16 * 3, value), "constant");
}

// A closed box [-w, w] x [-h, h] x [-w, w], each face its own vertices (flat
// normals: no averaging at the edges), the top face split into k x k cells
// with a vertex at its centre (index 0's face; returned in `centre`).
Mesh box(float w, float h, int k, std::uint32_t& centre) {
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  auto face = [&](glm::vec3 o, glm::vec3 du, glm::vec3 dv, int n) {  // o + [0,1]^2 spanned, front = du x dv
    const unsigned base = unsigned(p.size());
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) p.push_back(o + du * (float(i) / n) + dv * (float(j) / n));
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const unsigned a = base + unsigned(j * (n + 1) + i), b = a + 1, c = a + unsigned(n + 1), d = c + 1;
        t.emplace_back(a, b, c);
        t.emplace_back(b, d, c);
      }
  };
  face({-w, h, w}, {2 * w, 0, 0}, {0, 0, -2 * w}, k);  // top, +Y
  centre = unsigned(k / 2 * (k + 1) + k / 2);
  face({-w, -h, -w}, {2 * w, 0, 0}, {0, 0, 2 * w}, 2);   // bottom, -Y
  face({-w, -h, w}, {2 * w, 0, 0}, {0, 2 * h, 0}, 2);    // +Z
  face({w, -h, -w}, {-2 * w, 0, 0}, {0, 2 * h, 0}, 2);   // -Z
  face({w, -h, w}, {0, 0, -2 * w}, {0, 2 * h, 0}, 2);    // +X
  face({-w, -h, -w}, {0, 0, 2 * w}, {0, 2 * h, 0}, 2);   // -X
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, "box");
}

TEST(SubsurfaceReference, AThickSlabLeavesTheTotalReflectance) {
  // A box 100 mm wide and 50 mm thick (50 mm a unit), skin1 (light goes
  // 1/sigma_tr = 3.7 mm in red): at the top's centre L_o = R_d,total K_0 L / pi
  // (every point of a convex box sees an open hemisphere, E_t = K_0 L; what
  // lies past the top's edge, 50 mm away, weighs e^(-0.27 x 50) < 2e-6).
  std::uint32_t centre = 0;
  const Mesh m = box(1.0f, 0.5f, 8, centre);
  const EnvMap map = constant_map(2.0f);
  SubsurfaceRecord rec{*subsurface_preset("skin1"), 50.0};
  ReferenceOptions o;
  o.samples = 1024;
  const ReferenceResult r = render_subsurface_reference(m, map, o, rec, std::vector<std::uint32_t>{centre});
  const glm::dvec3 want = subsurface_total_reflectance(rec.material) * fresnel_cosine_factors(rec.material.eta, 1)[0] *
                          2.0 / kPi;
  for (int c = 0; c < 3; ++c) {
    const double got = r.radiance[0][c], se = r.std_error[0][c];
    std::printf("channel %d: %.6f against %.6f (%+.3f%%), standard error %.3f%%\n", c, got, want[c],
                100 * (got / want[c] - 1), 100 * se / want[c]);
    // Measured: standard errors 0.45% (green) to 0.85% (red) of the value
    // (held to 1.5%: the comparison resolves a few percent at 4 of them).
    EXPECT_LT(se, 0.015 * want[c]) << "channel " << c;
    EXPECT_NEAR(got, want[c], kSigmas * se) << "channel " << c;
  }
}

// The plain estimator: L_o(x_o) = (1/pi) S^2 A mean_j R_d(S |x_o - x_j|) E(x_j)
// over N points x_j uniform on the surface (area A), E(x_j) the diffuse
// reference's irradiance there (with eta = 1, T = 1 and E_t = E), and the
// standard error of that mean.
struct SurfaceSamples {
  std::vector<glm::vec3> positions, normals;
  std::vector<glm::dvec3> e_over_pi;  // E / pi
  double area = 0;
};

SurfaceSamples surface_samples(const Mesh& m, const EnvMap& map, int N) {
  std::vector<double> cdf{0.0};
  for (const glm::uvec3& t : m.triangles) {
    const glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
    cdf.push_back(cdf.back() + 0.5 * glm::length(glm::cross(b - a, c - a)));
  }
  SurfaceSamples s;
  s.area = cdf.back();
  std::mt19937_64 gen(7);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  for (int j = 0; j < N; ++j) {
    const std::size_t i = std::size_t(std::upper_bound(cdf.begin(), cdf.end(), U(gen) * s.area) - cdf.begin()) - 1;
    const glm::uvec3 t = m.triangles[std::min(i, m.triangles.size() - 1)];
    double u = U(gen), v = U(gen);
    if (u + v > 1) u = 1 - u, v = 1 - v;
    const double w = 1 - u - v;
    s.positions.emplace_back(w * glm::dvec3(m.positions[t.x]) + u * glm::dvec3(m.positions[t.y]) +
                             v * glm::dvec3(m.positions[t.z]));
    s.normals.emplace_back(glm::normalize(w * glm::dvec3(m.normals[t.x]) + u * glm::dvec3(m.normals[t.y]) +
                                          v * glm::dvec3(m.normals[t.z])));
  }
  ReferenceOptions o;
  o.samples = 64;
  const std::vector<glm::vec3> white(s.positions.size(), glm::vec3(1.0f));
  const ReferenceResult E = render_reference_at_points(m, map, o, s.positions, s.normals, white);
  for (const glm::vec3& e : E.radiance) s.e_over_pi.emplace_back(e);
  return s;
}

struct Plain {
  glm::dvec3 mean{0.0}, se{0.0};
};

Plain uniform_sum(const SurfaceSamples& s, const SubsurfaceRecord& rec, const glm::dvec3& xo) {
  const double S = rec.length_scale;
  const double N = double(s.positions.size());
  glm::dvec3 sum(0.0), sum2(0.0);
  for (std::size_t j = 0; j < s.positions.size(); ++j) {
    // (1/pi) R_d S^2 A E = R_d (E / pi) S^2 A
    const glm::dvec3 x = subsurface_rd(rec.material, S * glm::length(glm::dvec3(s.positions[j]) - xo)) *
                         s.e_over_pi[j] * (S * S * s.area);
    sum += x;
    sum2 += x * x;
  }
  Plain p;
  p.mean = sum / N;
  p.se = glm::sqrt(glm::max(sum2 / N - p.mean * p.mean, 0.0) / (N - 1));
  return p;
}

TEST(SubsurfaceReference, AgreesWithTheSumOverUniformSurfaceSamples) {
  // The open box (2 units wide, walls 1 high) at 1 mm a unit under a sun
  // and a sky: its floor is partly shadowed, so E_t varies over the
  // surface. The material's light goes 5-25 mm (sigma_s' 0.1 to 0.3 /mm):
  // the profile is wide against the 3 mm box, where the plain sum over
  // uniform samples converges (its standard error is measured beside).
  const Mesh m = test::open_box(1.0f);
  std::vector<float> rgb(64 * 32 * 3, 0.3f);
  for (int c = 0; c < 3; ++c) rgb[std::size_t((6 * 64 + 20) * 3 + c)] = 400.0f;  // a sun 34 degrees from the zenith
  const EnvMap map = make_latlong(64, 32, std::move(rgb), "sun and sky");
  SubsurfaceMaterial mat;
  mat.sigma_a = {0.01, 0.01, 0.02};
  mat.sigma_s = {0.1, 0.2, 0.3};
  mat.eta = 1.0;  // T = 1: the plain sum takes prt::render_reference_at_points' irradiance
  const SubsurfaceRecord rec{mat, 1.0};
  ReferenceOptions o;
  o.samples = 8192;
  const std::vector<std::uint32_t> receivers{0, 2, 7};  // the floor's centre and corner, a wall's top
  const ReferenceResult r = render_subsurface_reference(m, map, o, rec, receivers);
  const SurfaceSamples samples = surface_samples(m, map, 20000);
  for (std::size_t i = 0; i < receivers.size(); ++i) {
    const Plain p = uniform_sum(samples, rec, glm::dvec3(m.positions[receivers[i]]));
    for (int c = 0; c < 3; ++c) {
      const double se = std::hypot(double(r.std_error[i][c]), p.se[c]);
      std::printf("vertex %u channel %d: probes %.6f (se %.2f%%), uniform %.6f (se %.2f%%): %+.2f%%\n", receivers[i], c,
                  r.radiance[i][c], 100 * r.std_error[i][c] / r.radiance[i][c], p.mean[c], 100 * p.se[c] / p.mean[c],
                  100 * (r.radiance[i][c] / p.mean[c] - 1));
      // Measured: the probes' standard error 1.2-1.5%, the plain sum's 0.6%;
      // held to 2%, so that 4 of them resolve a bias of 8%.
      EXPECT_LT(se, 0.02 * p.mean[c]);
      EXPECT_NEAR(r.radiance[i][c], p.mean[c], kSigmas * se) << "vertex " << receivers[i] << " channel " << c;
    }
  }
}

TEST(SubsurfaceReference, TwoSurfacesAtOnePlaceBothCount) {
  // A quad and its reverse at the same place (a box's bottom on the floor
  // it stands on): under constant light each takes in the same irradiance,
  // so the quad's centre leaves twice what the quad alone leaves. A probe
  // that stepped from hit to hit found one of the two at each crossing
  // (the ratio was 1).
  const Mesh one = test::quad(4);
  std::vector<glm::vec3> p = one.positions;
  std::vector<glm::uvec3> t = one.triangles;
  for (const glm::uvec3& tri : one.triangles) {
    const unsigned n = unsigned(one.positions.size());
    t.emplace_back(tri.x + n, tri.z + n, tri.y + n);  // facing -y
  }
  p.insert(p.end(), one.positions.begin(), one.positions.end());
  const Mesh two = make_mesh(std::move(p), std::move(t), {}, {}, {}, "two quads at one place");
  const SubsurfaceRecord rec{*subsurface_preset("skin1"), 5.0};
  ReferenceOptions o;
  o.samples = 512;
  const std::vector<std::uint32_t> centre{12};
  const ReferenceResult a = render_subsurface_reference(one, constant_map(1.0f), o, rec, centre);
  const ReferenceResult b = render_subsurface_reference(two, constant_map(1.0f), o, rec, centre);
  for (int c = 0; c < 3; ++c) {
    const double se = std::hypot(2.0 * a.std_error[0][c], double(b.std_error[0][c]));
    std::printf("channel %d: one %.5f, two %.5f: ratio %.4f (se of the difference %.4f)\n", c, a.radiance[0][c],
                b.radiance[0][c], b.radiance[0][c] / a.radiance[0][c], se / a.radiance[0][c]);
    EXPECT_NEAR(b.radiance[0][c], 2.0 * a.radiance[0][c], kSigmas * se) << "channel " << c;
  }
}

TEST(SubsurfaceReference, TwoSeedsAgreeWithinTheirStandardErrors) {
  // A ball over a floor (shadows, curvature, two bodies), marble at 10 mm
  // a unit, under a sun: the difference of two seeds' results against their
  // standard errors, over every vertex, shadowed and interreflected.
  const Mesh m = test::ball_over_floor(6, 8, 12, 0.4f, {0.0f, 0.5f, 0.0f});
  std::vector<float> rgb(32 * 16 * 3, 0.2f);
  for (int c = 0; c < 3; ++c) rgb[std::size_t((3 * 32 + 10) * 3 + c)] = 100.0f;
  const EnvMap map = make_latlong(32, 16, std::move(rgb), "sun and sky");
  const SubsurfaceRecord rec{*subsurface_preset("marble"), 10.0};
  for (const TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    ReferenceOptions o;
    o.samples = 64;
    o.mode = mode;
    const ReferenceResult a = render_subsurface_reference(m, map, o, rec);
    o.seed = 2;
    const ReferenceResult b = render_subsurface_reference(m, map, o, rec);
    double chi2 = 0, d2 = 0, v2 = 0;
    int n = 0;
    for (std::size_t v = 0; v < a.radiance.size(); ++v)
      for (int c = 0; c < 3; ++c) {
        const double se2 = double(a.std_error[v][c]) * a.std_error[v][c] + double(b.std_error[v][c]) * b.std_error[v][c];
        const double d = double(a.radiance[v][c]) - b.radiance[v][c];
        d2 += d * d;
        v2 += double(a.radiance[v][c]) * a.radiance[v][c];
        if (se2 > 0) chi2 += d * d / se2, ++n;
      }
    // The mean of the squared differences over their variances is 1 for
    // calibrated standard errors; with n of them (n = 3 x 61 here) it
    // stays within 1 +- 4 sqrt(2 / n) for independent normal ones.
    const double mean = chi2 / n;
    std::printf("mode %d: %d values, mean squared difference / variance %.3f, relative RMS difference %.2f%%\n",
                int(mode), n, mean, 100 * std::sqrt(d2 / v2));
    EXPECT_NEAR(mean, 1.0, 4.0 * std::sqrt(2.0 / n));
  }
}

TEST(SubsurfaceReference, SameSeedSameBitsAtListedVertices) {
  const Mesh m = test::floor_and_ball(4);
  const EnvMap map = constant_map(1.0f);
  const SubsurfaceRecord rec{*subsurface_preset("ketchup"), 20.0};
  ReferenceOptions o;
  o.samples = 4;
  const ReferenceResult all = render_subsurface_reference(m, map, o, rec);
  const std::vector<std::uint32_t> some{30, 3, 17};
  const ReferenceResult part = render_subsurface_reference(m, map, o, rec, some);
  for (std::size_t i = 0; i < some.size(); ++i) {
    EXPECT_EQ(part.radiance[i], all.radiance[some[i]]);
    EXPECT_EQ(part.std_error[i], all.std_error[some[i]]);
  }
}

TEST(SubsurfaceReference, RefusesWhatDoesNotApply) {
  const Mesh m = test::quad(2);
  const EnvMap map = constant_map(1.0f);
  const SubsurfaceRecord rec{*subsurface_preset("marble"), 10.0};
  auto refused = [&](ReferenceOptions o, const SubsurfaceRecord& r, const std::string& what) {
    try {
      render_subsurface_reference(m, map, o, r);
      ADD_FAILURE() << "not refused: " << what;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  ReferenceOptions o;
  o.samples = 2;
  o.mode = TransferMode::Unshadowed;
  refused(o, rec, "unshadowed mode does not apply");
  o = {};
  o.glossy = true;
  refused(o, rec, "not glossy");
  o = {};
  o.lights.push_back(Light{});
  refused(o, rec, "lights are not supported");
  o = {};
  o.vertex_colors = true;
  refused(o, rec, "vertex colours do not apply");
  SubsurfaceRecord bad = rec;
  bad.length_scale = 0;
  refused({}, bad, "length scale");
  bad = rec;
  bad.material.eta = 0.5;
  refused({}, bad, "subsurface reference: the material");
}

}  // namespace prt::subsurface_reference_test
