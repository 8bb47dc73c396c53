// Monte Carlo ground truth of a translucent mesh's exit radiance: see
// prt/subsurface_reference.h for the quantity and the estimator (the
// profile importance-sampled by probe rays, as pbrt-v3's BSSRDF sampling;
// the transmitted irradiance by prt/reference.h's estimator with the kernel
// T(eta, cos) cos).
#include <prt/subsurface_reference.h>

#include <prt/error.h>
#include <prt/precompute.h>

#include "env_light.h"
#include "progress_ticker.h"
#include "random.h"
#include "ray_scene.h"

#include <fmt/format.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <string>

namespace prt {

// Named, not anonymous: the unity build joins this file with reference.cpp,
// whose anonymous namespace has names of its own (kPi, its helpers).
namespace subsurface_reference_impl {

using detail::Rng;
constexpr double kPi = 3.14159265358979323846;

// The axes' probabilities: the normal, then the two tangents.
constexpr std::array<double, 3> kAxisProbability = {0.5, 0.25, 0.25};
// Hits whose largest weight R_d,c / (pi q) is under this share of the
// channel's R_d,total / pi take their E_t by Russian roulette.
constexpr double kRoulette = 0.02;
// Quantiles tabulated per channel to start the inversion of the CDF.
constexpr int kQuantiles = 128;
// Strata of the axis' choice in one iteration at a receiver (with
// kAxisProbability: 2 probes along n, one along each tangent).
constexpr int kAxisStrata = 4;

// ---- the environment: prt/reference.h's lookup and importance sampling ----------
// (A copy of reference.cpp's EnvLight, whose class is private to that file.)

using detail::EnvLight;
using detail::mis_over_pdf;


// ---- one channel's profile as a distribution of the radius -----------------------

// p(r) = R_d(r) 2 pi r / disc(r_max) on [0, r_max] (mm), sampled by inverting
// disc(r) / disc(r_max): a table of quantiles brackets the root, safeguarded
// Newton (derivative R_d(r) 2 pi r) refines it to 1e-13 relative.
class RadialProfile {
 public:
  RadialProfile(const Dipole& d, double r_max) : d_(d), r_max_(r_max), disc_max_(d.disc(r_max)) {
    quantile_.assign(kQuantiles + 1, 0.0);
    quantile_[kQuantiles] = r_max;
    for (int k = 1; k < kQuantiles; ++k) {
      const double target = disc_max_ * k / kQuantiles;
      double lo = quantile_[k - 1], hi = r_max;
      for (int it = 0; it < 200 && hi - lo > 1e-14 * hi; ++it) {
        const double mid = 0.5 * (lo + hi);
        (d_.disc(mid) < target ? lo : hi) = mid;
      }
      quantile_[k] = 0.5 * (lo + hi);
    }
  }

  bool usable() const { return disc_max_ > 0 && std::isfinite(disc_max_); }
  double disc_max() const { return disc_max_; }
  // The density on the plane (1/mm^2) of a point sampled at radius r:
  // p(r) / (2 pi r) = R_d(r) / disc(r_max).
  double plane_density(double r) const { return d_.rd(r) / disc_max_; }
  double rd(double r) const { return d_.rd(r); }

  double sample(double u) const {
    const double target = u * disc_max_;
    const int k = std::clamp(int(u * kQuantiles), 0, kQuantiles - 1);
    double lo = quantile_[std::size_t(k)], hi = quantile_[std::size_t(k) + 1];
    double r = 0.5 * (lo + hi);
    for (int it = 0; it < 100; ++it) {
      const double f = d_.disc(r) - target;
      (f > 0 ? hi : lo) = r;
      const double slope = d_.rd(r) * 2.0 * kPi * r;
      double next = slope > 0 ? r - f / slope : 0.5 * (lo + hi);
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      const bool done = std::abs(next - r) <= 1e-13 * hi || hi - lo <= 1e-13 * hi;
      r = next;
      if (done) break;
    }
    return std::clamp(r, 0.0, r_max_);
  }

 private:
  Dipole d_;
  double r_max_, disc_max_;
  std::vector<double> quantile_;
};

// ---- the integrator --------------------------------------------------------------

struct Frame {
  glm::dvec3 axis[3];  // n, t, b
};

Frame frame_of(const glm::dvec3& n) {
  Frame f;
  f.axis[0] = n;
  detail::basis(n, f.axis[1], f.axis[2]);
  return f;
}

struct ProbeHit {
  glm::dvec3 x;   // the point
  glm::dvec3 ns;  // the interpolated (shading) normal
  glm::dvec3 w;   // R_d,c(S |x_o - x|) / (pi q(x)) per channel
};

struct Integrator {
  const Mesh& mesh;
  const EnvLight& env;
  const detail::RayScene& scene;
  std::vector<RadialProfile> profiles;  // one per channel
  std::vector<int> channels;            // those with a usable profile
  glm::dvec3 total{0.0};                // R_d,total per channel
  double eta = 1.3;
  double S = 1.0;       // mm per mesh unit
  double R = 1.0;       // mesh units: the probes' ball
  double offset = 0.0;  // ray offset
  bool interreflect = false;
  int bounces = 0;

  // Point, interpolated normal and geometric normal at a hit; false for a
  // degenerate triangle.
  bool surface(const detail::Hit& h, glm::dvec3& q, glm::dvec3& ns, glm::dvec3& ng) const {
    const glm::uvec3 tri = mesh.triangles[h.triangle];
    const double b1 = h.u, b2 = h.v, b0 = 1.0 - b1 - b2;
    const glm::dvec3 p0(mesh.positions[tri.x]), p1(mesh.positions[tri.y]), p2(mesh.positions[tri.z]);
    q = b0 * p0 + b1 * p1 + b2 * p2;
    ng = glm::cross(p1 - p0, p2 - p0);
    const double lg = glm::length(ng);
    if (!(lg > 0)) return false;
    ng /= lg;
    ns = b0 * glm::dvec3(mesh.normals[tri.x]) + b1 * glm::dvec3(mesh.normals[tri.y]) +
         b2 * glm::dvec3(mesh.normals[tri.z]);
    const double len = glm::length(ns);
    ns = len > 1e-6 ? ns / len : ng;
    return true;
  }

  // q(x) of the header, 1/mm^2, for a hit at x (geometric normal ng) of the
  // probes about x_o with frame f.
  double density(const glm::dvec3& xo, const Frame& f, const glm::dvec3& x, const glm::dvec3& ng) const {
    const glm::dvec3 d = x - xo;
    const double d2 = glm::dot(d, d);
    double q = 0.0;
    for (int a = 0; a < 3; ++a) {
      const double c = std::abs(glm::dot(ng, f.axis[a]));
      if (c == 0) continue;
      const double along = glm::dot(d, f.axis[a]);
      const double r = S * std::sqrt(std::max(0.0, d2 - along * along));
      double p = 0.0;
      for (int ch : channels) p += profiles[std::size_t(ch)].plane_density(r);
      q += kAxisProbability[std::size_t(a)] * c * p / double(channels.size());
    }
    return q;
  }

  // One probe about x_o (frame f), its axis picked by ua (uniform in [0, 1):
  // the normal below 1/2, t below 3/4, b above) and sampling channel ch's
  // profile: every hit of its segment with its weight.
  void probe(Rng& rng, const glm::dvec3& xo, const Frame& f, double ua, int ch, std::vector<ProbeHit>& hits) const {
    hits.clear();
    const double ur = rng.uniform(), uphi = rng.uniform();
    const int a = ua < kAxisProbability[0] ? 0 : ua < kAxisProbability[0] + kAxisProbability[1] ? 1 : 2;
    const double rho = profiles[std::size_t(ch)].sample(ur) / S;  // mesh units
    const double phi = 2.0 * kPi * uphi;
    const glm::dvec3& axis = f.axis[a];
    const glm::dvec3& u = f.axis[(a + 1) % 3];
    const glm::dvec3& w = f.axis[(a + 2) % 3];
    const double h = std::sqrt(std::max(0.0, R * R - rho * rho));
    const glm::dvec3 start = xo + rho * (std::cos(phi) * u + std::sin(phi) * w) + h * axis;
    thread_local std::vector<detail::Hit> crossed;
    scene.intersect_all(glm::vec3(start), glm::vec3(-axis), 0.0f, float(2.0 * h), crossed);
    for (const detail::Hit& hit : crossed) {
      ProbeHit p;
      glm::dvec3 ng;
      if (!surface(hit, p.x, p.ns, ng)) continue;
      const double q = density(xo, f, p.x, ng);
      if (!(q > 0)) continue;
      const double dist = S * glm::length(p.x - xo);
      for (int c = 0; c < 3; ++c) p.w[c] = profiles[std::size_t(c)].usable() ? profiles[std::size_t(c)].rd(dist) / (kPi * q) : 0.0;
      hits.push_back(p);
    }
  }

  // One estimate of E_t at p (unit normal n) with surfaces hit at `depth`
  // or deeper bringing their L_o while depth < bounces.
  glm::dvec3 transmitted(Rng& rng, const glm::dvec3& p, const glm::dvec3& n, int depth) const {
    glm::dvec3 E(0.0);
    const glm::vec3 o(p + offset * n);
    const float tnear = float(offset);
    if (env.can_sample()) {
      std::size_t pixel = 0;
      const glm::dvec3 w = env.sample(rng, pixel);
      const double c = glm::dot(n, w);
      if (c > 0 && !scene.occluded1(o, glm::vec3(w), tnear))
        E += env.radiance(pixel) * (fresnel_transmittance(eta, c) * c * mis_over_pdf(env.pdf(pixel), c / kPi));
    }
    const glm::dvec3 w = detail::sample_cosine(rng, n);
    const double c = glm::dot(n, w);
    if (c <= 0) return E;
    const double kernel = fresnel_transmittance(eta, c) * c;
    if (interreflect && depth < bounces) {
      const detail::Hit hit = scene.intersect1(o, glm::vec3(w), tnear);
      if (hit.hit()) {
        glm::dvec3 y, ny, ng;
        if (hit.front && surface(hit, y, ny, ng))  // kernel / (c / pi) = T pi
          E += path_exit_radiance(rng, y, ny, depth + 1) * (fresnel_transmittance(eta, c) * kPi);
        return E;
      }
    } else if (scene.occluded1(o, glm::vec3(w), tnear)) {
      return E;
    }
    const std::size_t pixel = env.pixel_of(w);
    E += env.radiance(pixel) * (kernel * mis_over_pdf(c / kPi, env.pdf(pixel)));
    return E;
  }

  // One probe's estimate of L_o at x_o (unit normal n): every hit's weight
  // times E_t there (all_hits), or one hit picked uniformly times the count.
  glm::dvec3 exit_radiance(Rng& rng, const glm::dvec3& xo, const Frame& f, int depth, bool all_hits, double ua,
                           int ch) const {
    thread_local std::vector<ProbeHit> buffer;
    std::vector<ProbeHit> hits;
    hits.swap(buffer);  // reuse the thread's allocation; recursion finds it empty
    probe(rng, xo, f, ua, ch, hits);
    glm::dvec3 L(0.0);
    std::size_t first = 0, last = hits.size();
    double count = 1.0;
    if (!all_hits && !hits.empty()) {
      first = std::min(std::size_t(rng.uniform() * double(hits.size())), hits.size() - 1);
      last = first + 1;
      count = double(hits.size());
    }
    for (std::size_t i = first; i < last; ++i) {
      glm::dvec3 w = hits[i].w * count;
      // Russian roulette on the hits that carry little.
      double share = 0.0;
      for (int c = 0; c < 3; ++c)
        if (total[c] > 0) share = std::max(share, w[c] / (kRoulette * total[c] / kPi));
      if (share < 1.0) {
        if (!(rng.uniform() < share)) continue;
        w /= share;
      }
      L += w * transmitted(rng, hits[i].x, hits[i].ns, depth);
    }
    hits.clear();
    buffer.swap(hits);
    return L;
  }

  // A path's estimate of L_o at a surface hit (interreflected): one probe,
  // its axis and channel at random, one of its hits.
  glm::dvec3 path_exit_radiance(Rng& rng, const glm::dvec3& y, const glm::dvec3& n, int depth) const {
    const double ua = rng.uniform(), uc = rng.uniform();
    const int ch = channels[std::min(std::size_t(uc * double(channels.size())), channels.size() - 1)];
    return exit_radiance(rng, y, frame_of(n), depth, false, ua, ch);
  }

  // One iteration at a receiver: a probe for each of kAxisStrata strata of
  // the axis' uniform variable (2 along n, one along t, one along b, their
  // azimuth, radius... random) and each channel: the mean of their
  // estimates (each the one-sample MIS estimate of L_o, stratified).
  glm::dvec3 iteration(Rng& rng, const glm::dvec3& xo, const Frame& f) const {
    glm::dvec3 L(0.0);
    for (int j = 0; j < kAxisStrata; ++j)
      for (int ch : channels) L += exit_radiance(rng, xo, f, 0, true, (j + rng.uniform()) / kAxisStrata, ch);
    return L / double(kAxisStrata * channels.size());
  }
};

void validate(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& o, const SubsurfaceRecord& rec) {
  if (map.is_cube())
    throw Error("subsurface reference: " + map.source + " is a cube map; the reference renderer needs a lat-long map");
  if (map.width < 1 || map.height < 1 || map.rgb.size() != std::size_t(map.width) * map.height * 3)
    throw Error("subsurface reference: " + map.source + ": empty or malformed lat-long map");
  require_finite(map);
  if (o.samples < 2 || o.samples > kMaxSamples)
    throw Error(fmt::format("subsurface reference: samples must be 2 (the standard error needs two) to {}, got {}",
                            kMaxSamples, o.samples));
  if (o.mode == TransferMode::Unshadowed)
    throw Error("subsurface reference: unshadowed mode does not apply (a translucent transfer is shadowed or "
                "interreflected)");
  if (o.mode != TransferMode::Shadowed && o.mode != TransferMode::Interreflected)
    throw Error(fmt::format("subsurface reference: unknown transfer mode {}", std::uint32_t(o.mode)));
  if (o.bounces < 0 || o.bounces > kMaxReferenceBounces)
    throw Error(fmt::format("subsurface reference: bounces must be from 0 to {}, got {}", kMaxReferenceBounces,
                            o.bounces));
  if (o.glossy) throw Error("subsurface reference: a translucent material is not glossy");
  if (!o.lights.empty())
    throw Error("subsurface reference: lights are not supported (the map's light only; a translucent transfer is "
                "relit by SH lighting)");
  if (o.vertex_colors) throw Error("subsurface reference: vertex colours do not apply (the material's profile is its colour)");
  detail::check_ray_offset(o.offset, mesh, "subsurface reference: ray offset (--offset)");
  const glm::dmat3 I = glm::transpose(o.rotation) * o.rotation;
  double err = std::abs(glm::determinant(o.rotation) - 1.0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) err = std::max(err, std::abs(I[i][j] - (i == j ? 1.0 : 0.0)));
  if (!(err <= 1e-6)) throw Error("subsurface reference: the lighting rotation is not a proper rotation matrix");
  check_subsurface_material(rec.material, "subsurface reference: the material");
  if (!(rec.length_scale > 0 && std::isfinite(rec.length_scale)))
    throw Error(fmt::format("subsurface reference: the length scale must be a finite number > 0 (mm per mesh unit), "
                            "got {:g}",
                            rec.length_scale));
}

// The receivers: vertices (all, or those listed) or points on the surface.
struct Receivers {
  const std::vector<std::uint32_t>* vertices = nullptr;
  const std::vector<glm::vec3>* positions = nullptr;  // points: these, with normals
  const std::vector<glm::vec3>* normals = nullptr;
};

ReferenceResult render(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                       const SubsurfaceRecord& rec, const Receivers& at, const Progress& progress) {
  validate(mesh, map, options, rec);
  const std::vector<std::uint32_t>* vertices = at.vertices;
  if (vertices)
    for (std::uint32_t v : *vertices)
      if (v >= mesh.vertex_count())
        throw Error(fmt::format("subsurface reference: vertex {} is out of range (the mesh has {})", v,
                                mesh.vertex_count()));
  if (at.positions && at.normals->size() != at.positions->size())
    throw Error(fmt::format("subsurface reference: {} points and {} normals", at.positions->size(), at.normals->size()));
  const std::size_t n = at.positions ? at.positions->size() : vertices ? vertices->size() : mesh.vertex_count();
  ReferenceResult result;
  result.radiance.assign(n, glm::vec3(0.0f));
  result.std_error.assign(n, glm::vec3(0.0f));

  const EnvLight env(map, options.rotation);
  // Watertight: a probe slipping between triangles would lose a hit; every
  // hit of a probe's segment, two triangles at the same place included.
  const detail::RayScene scene(mesh, true, true);
  const double diag = mesh.diagonal();
  const SubsurfaceMaterial& m = rec.material;
  Integrator integ{mesh, env, scene};
  integ.eta = m.eta;
  integ.S = rec.length_scale;
  integ.R = 1.001 * diag;
  integ.offset = options.offset > 0 ? options.offset : detail::default_ray_offset(mesh);
  integ.interreflect = options.mode == TransferMode::Interreflected;
  integ.bounces = options.bounces;
  for (int c = 0; c < 3; ++c) {
    const Dipole d(m.sigma_a[c], m.sigma_s[c], m.eta);
    integ.profiles.emplace_back(d, integ.R * integ.S);
    integ.total[c] = d.total();
    if (integ.profiles.back().usable()) integ.channels.push_back(c);
  }

  detail::ProgressTicker ticker(progress, n, "subsurface reference");
  ticker.start();
  if (integ.channels.empty()) {  // no channel scatters: no light leaves
    ticker.finish();
    return result;
  }
  const int N = options.samples;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 1), [&](const tbb::blocked_range<std::size_t>& r) {
    detail::enable_ftz_daz();
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      if (ticker.cancelled()) return;
      const std::size_t v = vertices ? (*vertices)[i] : i;
      glm::dvec3 nv(at.positions ? (*at.normals)[i] : mesh.normals[v]);
      if (!(glm::dot(nv, nv) > 0)) continue;
      nv = glm::normalize(nv);
      const glm::dvec3 p(at.positions ? (*at.positions)[i] : mesh.positions[v]);
      Rng rng(options.seed, v);
      const Frame f = frame_of(nv);
      glm::dvec3 mean(0.0), m2(0.0);
      for (int s = 0; s < N; ++s) {
        const glm::dvec3 x = integ.iteration(rng, p, f);
        const glm::dvec3 d = x - mean;
        mean += d / double(s + 1);
        m2 += d * (x - mean);
      }
      result.radiance[i] = glm::vec3(mean);
      result.std_error[i] = glm::vec3(glm::sqrt(glm::max(m2, 0.0) / (double(N - 1) * N)));
    }
    ticker.tick(r.size());
  });
  ticker.finish();
  return result;
}

}  // namespace subsurface_reference_impl

ReferenceResult render_subsurface_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                            const SubsurfaceRecord& record, const Progress& progress) {
  return subsurface_reference_impl::render(mesh, map, options, record, {}, progress);
}

ReferenceResult render_subsurface_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                            const SubsurfaceRecord& record,
                                            const std::vector<std::uint32_t>& vertices, const Progress& progress) {
  subsurface_reference_impl::Receivers at;
  at.vertices = &vertices;
  return subsurface_reference_impl::render(mesh, map, options, record, at, progress);
}

ReferenceResult render_subsurface_reference_at_points(const Mesh& mesh, const EnvMap& map,
                                                      const ReferenceOptions& options, const SubsurfaceRecord& record,
                                                      const std::vector<glm::vec3>& positions,
                                                      const std::vector<glm::vec3>& normals, const Progress& progress) {
  subsurface_reference_impl::Receivers at;
  at.positions = &positions;
  at.normals = &normals;
  return subsurface_reference_impl::render(mesh, map, options, record, at, progress);
}

}  // namespace prt
