// Probe volumes, traced (prt/precompute.h compute_probe_transfer; the data
// and relighting in prt/probes.h, docs/PROBES.md).
#include <prt/precompute.h>

#include <prt/error.h>
#include <prt/sh.h>

#include "progress_ticker.h"
#include "random.h"
#include "ray_scene.h"
#include "transfer_impl.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>

namespace prt {

namespace {

// One probe's result before the stored ones are packed.
struct ProbeRecord {
  ProbeState state = ProbeState::Sky;
  glm::vec3 position{0.0f};
  std::vector<std::uint16_t> nodes, partial_nodes;
  std::vector<std::uint16_t> partial_mask;
  bool complement = false;
  std::vector<std::uint16_t> depth;
  std::vector<float> bounce;
};

void check_probe_options(const ProbeOptions& o) {
  if (o.mode != TransferMode::Shadowed && o.mode != TransferMode::Interreflected)
    throw Error("--probes: --mode shadowed or interreflected (probes are occluded by the scene)");
  if (o.bands < 1 || o.bands > 8) throw Error(fmt::format("--probes: --bands {} (1 to 8)", o.bands));
  if (o.cube_res < 4 || o.cube_res > 64 || !std::has_single_bit(unsigned(o.cube_res)))
    throw Error(fmt::format("--probe-cube {} (a power of two, 4 to 64)", o.cube_res));
  if (o.depth_res < 2 || o.depth_res > 32) throw Error(fmt::format("probe depth map size {} (2 to 32)", o.depth_res));
  const int k = int(std::lround(std::sqrt(double(o.rays_per_texel))));
  if (o.rays_per_texel < 1 || k * k != o.rays_per_texel || k > 8)
    throw Error(fmt::format("--probe-rays {} (a square: 1, 4, 9, ... 64)", o.rays_per_texel));
  // The bounce bands' range holds whatever the mode (as the command's --bounce-bands 1 to 16).
  if (o.bounce_bands < 1 || o.bounce_bands > 16) throw Error(fmt::format("--bounce-bands {} (1 to 16)", o.bounce_bands));
  if (o.mode == TransferMode::Interreflected && (o.bounces < 1 || o.bounces > kMaxProbeBounces))
    throw Error(fmt::format("--bounces {} (1 to {} for probes)", o.bounces, kMaxProbeBounces));
  if (o.threads < 0 || o.threads > kMaxThreads)
    throw Error(fmt::format("--threads must be between 0 (every core) and {}, got {}", kMaxThreads, o.threads));
}

// The header of the probe volume compute_probe_transfer returns, its depth
// cap and bounce channels; `smallest`: the grid's smallest nonzero spacing.
ProbeTransfer probe_header(const Scene& scene, const ProbeGrid& grid, const ProbeOptions& o, double& smallest) {
  ProbeTransfer t;
  t.grid = grid;
  t.bands = o.bands;
  t.cube_res = o.cube_res;
  t.depth_res = o.depth_res;
  t.mode = o.mode;
  t.rays_per_texel = o.rays_per_texel;
  t.seed = o.seed;
  t.scene_hash = scene.hash();
  const glm::dvec3 sp = grid.spacing();
  const double largest = std::max({sp.x, sp.y, sp.z});
  smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (sp[a] > 0) smallest = std::min(smallest, sp[a]);
  if (!std::isfinite(smallest)) smallest = largest > 0 ? largest : 1.0;
  // A cell's diagonal is at most sqrt(3) x its longest side: every corner
  // probe of a query's cell lies within the cap.
  t.depth_cap = float(2.0 * (largest > 0 ? largest : smallest));
  // Albedo of the bounce matrices: grey everywhere -> one channel.
  bool grey = true;
  if (o.mode == TransferMode::Interreflected) {
    t.bounces = o.bounces;
    t.bounce_bands = o.bounce_bands;
    if (o.override_albedo) {
      grey = o.albedo.x == o.albedo.y && o.albedo.y == o.albedo.z;
    } else {
      // The materials' base colours; a texture varies inside a triangle: coloured.
      for (const Material& m : scene.materials)
        if (m.base_color.x != m.base_color.y || m.base_color.y != m.base_color.z || m.base_color_texture >= 0) grey = false;
    }
    t.channels = grey ? 1 : 3;
  }
  return t;
}

// What tracing a probe needs: the scene and its rays, the volume's header,
// the cube sizes. Traced at base = r / 4 with kk^2 rays per texel; a base
// texel that is neither all visible nor all blocked is traced again at r,
// one ray per finest texel.
struct ProbeTracing {
  const Scene& scene;
  const detail::RayScene& rays;
  const ProbeOptions& o;
  const ProbeTransfer& t;
  float offset;
  int r, kk, N;  // cube resolution, sqrt(rays per base texel), depth map size
  int nc, nb;  // coefficients of the transfer and (interreflected) of the bounce light
  int base, refine;
  std::size_t words;  // of the visibility bits
  double lift;  // a probe nearer a surface than this is moved 2 x this off it
};

// One worker's scratch, reset for each probe, and the probe's ray counts.
struct ProbeScratch {
  explicit ProbeScratch(const ProbeTracing& tr)
      : bits(tr.words), cls(std::size_t(6) * tr.base * tr.base), m1(std::size_t(tr.N) * tr.N),
        m2(std::size_t(tr.N) * tr.N), count(std::size_t(tr.N) * tr.N),
        bounce(std::size_t(tr.t.channels) * tr.nc * tr.nb), yk(static_cast<std::size_t>(tr.nc)),
        yj(static_cast<std::size_t>(std::max(tr.nb, 1))) {}

  std::vector<std::uint32_t> bits;  // the finest texels that see the map
  std::vector<std::uint8_t> cls;  // per base texel: 0 all blocked, 1 all visible, 2 mixed
  std::vector<double> m1, m2, count;  // depth moments per octahedral texel
  std::vector<double> bounce;
  std::vector<double> yk, yj;
  std::size_t back = 0, hit_count = 0, total = 0;
  glm::vec3 dirs[8];
  detail::Hit hits[8];
};

glm::vec3 lift_off_surfaces(const ProbeTracing& tr, glm::vec3 x) {
  return detail::lift_off_surfaces(tr.rays, tr.scene.mesh, tr.lift, x);
}

void set_bit(const ProbeTracing& tr, ProbeScratch& sc, int face, int u, int v) {
  const std::size_t i2 = (std::size_t(face) * tr.r + std::size_t(v)) * tr.r + std::size_t(u);
  sc.bits[i2 >> 5] |= 1u << (i2 & 31);
}

// A diffuse path from the front hit of the probe's ray in direction d: its
// escape lights the probe through the band-limited map (albedo x Y_k(d)
// omega x Y_j(w)).
void trace_bounce_path(const ProbeTracing& tr, ProbeScratch& sc, detail::Rng& rng, glm::vec3 x, const glm::dvec3& d,
                       const detail::Hit& hit, double omega) {
  const ProbeOptions& o = tr.o;
  const Mesh& mesh = tr.scene.mesh;
  const int nc = tr.nc, nb = tr.nb, channels = tr.t.channels;
  sh::eval(o.bands, d.x, d.y, d.z, sc.yk.data());
  glm::dvec3 weight(omega);
  glm::dvec3 origin = glm::dvec3(x) + d * double(hit.t);
  detail::Hit h = hit;
  for (int bounce_i = 0; bounce_i < o.bounces; ++bounce_i) {
    const glm::uvec3& tri = mesh.triangles[h.triangle];
    const float w0 = 1.0f - h.u - h.v;
    glm::dvec3 ns = glm::dvec3(mesh.normals[tri[0]] * w0 + mesh.normals[tri[1]] * h.u + mesh.normals[tri[2]] * h.v);
    if (!(glm::length(ns) > 0)) {
      const glm::vec3 a = mesh.positions[tri[0]], b = mesh.positions[tri[1]], c = mesh.positions[tri[2]];
      ns = glm::dvec3(glm::cross(b - a, c - a));
    }
    if (!(glm::length(ns) > 0)) break;
    ns = glm::normalize(ns);
    const glm::vec3 albedo = o.override_albedo ? o.albedo : glm::clamp(tr.scene.albedo(h.triangle, h.u, h.v), 0.0f, 1.0f);
    weight *= glm::dvec3(albedo);
    const glm::dvec3 w = detail::sample_cosine(rng, ns);
    const glm::vec3 from = glm::vec3(origin + ns * double(tr.offset));
    h = tr.rays.intersect1(from, glm::vec3(w), tr.offset);
    if (!h.hit()) {
      sh::eval(o.bounce_bands, w.x, w.y, w.z, sc.yj.data());
      for (int c = 0; c < channels; ++c) {
        const double wc = channels == 1 ? weight.x : weight[c];
        double* B = sc.bounce.data() + std::size_t(c) * nc * nb;
        for (int kq = 0; kq < nc; ++kq)
          for (int jq = 0; jq < nb; ++jq)
            B[std::size_t(kq) * nb + std::size_t(jq)] += wc * sc.yk[std::size_t(kq)] * sc.yj[std::size_t(jq)];
      }
      break;
    }
    if (!h.front) break;  // back faces are black
    origin = glm::dvec3(from) + w * double(h.t);
  }
}

// One ray of the base cube: depth moments, back faces, the bounce paths.
void take_ray(const ProbeTracing& tr, ProbeScratch& sc, detail::Rng& rng, glm::vec3 x, const glm::dvec3& d,
              const detail::Hit& hit, double omega) {
  const int N = tr.N;
  ++sc.total;
  double depth = tr.t.depth_cap;
  if (hit.hit()) {
    ++sc.hit_count;
    depth = std::min(double(hit.t), double(tr.t.depth_cap));
    if (!hit.front) ++sc.back;
  }
  const glm::dvec2 uv = octahedral_encode(d);
  const std::size_t o2 =
      std::size_t(std::clamp(int(uv.y * N), 0, N - 1)) * N + std::size_t(std::clamp(int(uv.x * N), 0, N - 1));
  sc.m1[o2] += depth;
  sc.m2[o2] += depth * depth;
  sc.count[o2] += 1;
  if (tr.nb == 0 || !hit.hit() || !hit.front) return;
  trace_bounce_path(tr, sc, rng, x, d, hit, omega);
}

// The base cube: kk^2 jittered rays per texel, each texel classed (0 all
// blocked, 1 all visible, 2 mixed).
void trace_base_cube(const ProbeTracing& tr, ProbeScratch& sc, detail::Rng& rng, glm::vec3 x) {
  const int kk = tr.kk, base = tr.base;
  for (int face = 0; face < 6; ++face)
    for (int v = 0; v < base; ++v)
      for (int u = 0; u < base; ++u) {
        const double omega = cube_texel_solid_angle(u, v, base) / (kk * kk);
        int escapes = 0;
        for (int s0 = 0; s0 < kk * kk; s0 += 8) {
          const int n = std::min(8, kk * kk - s0);
          for (int q = 0; q < n; ++q) {
            const int a = (s0 + q) % kk, b = (s0 + q) / kk;
            const double s1 = 2.0 * (u + (a + rng.uniform()) / kk) / base - 1.0;
            const double t1 = 2.0 * (v + (b + rng.uniform()) / kk) / base - 1.0;
            sc.dirs[q] = glm::vec3(glm::normalize(cube_direction(face, s1, t1)));
          }
          tr.rays.intersect8(x, sc.dirs, n, tr.offset, sc.hits);
          for (int q = 0; q < n; ++q) {
            escapes += !sc.hits[q].hit();
            take_ray(tr, sc, rng, x, glm::dvec3(sc.dirs[q]), sc.hits[q], omega);
          }
        }
        sc.cls[(std::size_t(face) * base + std::size_t(v)) * base + std::size_t(u)] =
            std::uint8_t(escapes == kk * kk ? 1 : escapes == 0 ? 0 : 2);
      }
}

// Finest texel (fu, fv) of `face`: 2 x 2 jittered rays, visible when all
// escape; when some do, 4 x 4 more, one per sub-texel (partial_mask).
void refine_texel(const ProbeTracing& tr, ProbeScratch& sc, detail::Rng& rng, glm::vec3 x, int face, int fu, int fv,
                  ProbeRecord& rec) {
  const int r = tr.r;
  glm::vec3* dirs = sc.dirs;
  for (int q = 0; q < 4; ++q) {
    const double s1 = 2.0 * (fu + ((q & 1) + rng.uniform()) * 0.5) / r - 1.0;
    const double t1 = 2.0 * (fv + ((q >> 1) + rng.uniform()) * 0.5) / r - 1.0;
    dirs[q] = glm::vec3(glm::normalize(cube_direction(face, s1, t1)));
  }
  const std::uint32_t blocked = tr.rays.occluded8(x, dirs, 4, tr.offset);
  const int open = 4 - std::popcount(blocked);
  if (open == 4) {
    set_bit(tr, sc, face, fu, fv);
  } else if (open > 0) {
    // An edge crosses it: which of its 4 x 4 sub-texels see the map.
    std::uint16_t mask = 0;
    for (int h = 0; h < 2; ++h) {
      for (int q = 0; q < 8; ++q) {
        const int cq = h * 8 + q;
        const double s1 = 2.0 * (fu + ((cq & 3) + rng.uniform()) * 0.25) / r - 1.0;
        const double t1 = 2.0 * (fv + ((cq >> 2) + rng.uniform()) * 0.25) / r - 1.0;
        dirs[q] = glm::vec3(glm::normalize(cube_direction(face, s1, t1)));
      }
      const std::uint32_t occ = tr.rays.occluded8(x, dirs, 8, tr.offset);
      for (int q = 0; q < 8; ++q)
        if (!((occ >> q) & 1u)) mask = std::uint16_t(mask | (1u << (h * 8 + q)));
    }
    if (mask == 0xffff) {
      set_bit(tr, sc, face, fu, fv);
    } else if (mask != 0) {
      rec.partial_nodes.push_back(probe_node_id(r, face, 0, fu, fv));
      rec.partial_mask.push_back(mask);
    }
  }
}

// Refined at the finest texels, one jittered ray each: mixed base texels
// and those beside a texel of another class (an edge that slipped between
// the base rays: a sliver of sky at a grazing angle).
void refine_edges(const ProbeTracing& tr, ProbeScratch& sc, detail::Rng& rng, glm::vec3 x, ProbeRecord& rec) {
  const int kk = tr.kk, base = tr.base, refine = tr.refine;
  for (int face = 0; face < 6; ++face)
    for (int v = 0; v < base; ++v)
      for (int u = 0; u < base; ++u) {
        const std::uint8_t c0 = sc.cls[(std::size_t(face) * base + std::size_t(v)) * base + std::size_t(u)];
        bool edge = c0 == 2 || kk == 1;
        for (int dv = -1; dv <= 1 && !edge; ++dv)
          for (int du = -1; du <= 1 && !edge; ++du) {
            const int nu = u + du, nv = v + dv;
            if (nu < 0 || nv < 0 || nu >= base || nv >= base) continue;
            edge = sc.cls[(std::size_t(face) * base + std::size_t(nv)) * base + std::size_t(nu)] != c0;
          }
        if (!edge) {
          if (c0 == 1)
            for (int y = 0; y < refine; ++y)
              for (int x2 = 0; x2 < refine; ++x2) set_bit(tr, sc, face, u * refine + x2, v * refine + y);
          continue;
        }
        for (int y = 0; y < refine; ++y)
          for (int x2 = 0; x2 < refine; ++x2) refine_texel(tr, sc, rng, x, face, u * refine + x2, v * refine + y, rec);
      }
}

// The probe's state and, stored, its visibility nodes, depth moments and
// bounce matrices.
void finish_record(const ProbeTracing& tr, const ProbeScratch& sc, ProbeRecord& rec) {
  const int N = tr.N;
  if (2 * sc.back > sc.total) {
    rec.state = ProbeState::Invalid;
  } else if (sc.hit_count == 0) {
    rec.state = ProbeState::Sky;
  } else {
    rec.state = ProbeState::Stored;
    bool complement = false;
    rec.nodes = probe_visibility_nodes(sc.bits, tr.r, complement);
    rec.complement = complement;
    rec.depth.resize(2 * std::size_t(N) * N);
    const double cap = tr.t.depth_cap;
    for (std::size_t i2 = 0; i2 < std::size_t(N) * N; ++i2) {
      const double mean = sc.count[i2] > 0 ? sc.m1[i2] / sc.count[i2] : cap,
                   mean2 = sc.count[i2] > 0 ? sc.m2[i2] / sc.count[i2] : cap * cap;
      rec.depth[2 * i2] = std::uint16_t(std::lround(std::clamp(mean / cap, 0.0, 1.0) * 65535.0));
      rec.depth[2 * i2 + 1] = std::uint16_t(std::lround(std::clamp(mean2 / (cap * cap), 0.0, 1.0) * 65535.0));
    }
    rec.bounce.assign(sc.bounce.begin(), sc.bounce.end());
  }
}

// Probe p of the grid, traced into rec.
void trace_probe(const ProbeTracing& tr, ProbeScratch& sc, std::size_t p, ProbeRecord& rec) {
  const ProbeGrid& grid = tr.t.grid;
  const int i = int(p % std::size_t(grid.dims[0]));
  const int j = int((p / std::size_t(grid.dims[0])) % std::size_t(grid.dims[1]));
  const int k = int(p / (std::size_t(grid.dims[0]) * std::size_t(grid.dims[1])));
  const glm::vec3 x = lift_off_surfaces(tr, glm::vec3(grid.position(i, j, k)));
  rec.position = x;
  detail::Rng rng(tr.o.seed, p);
  std::fill(sc.bits.begin(), sc.bits.end(), 0u);
  std::fill(sc.m1.begin(), sc.m1.end(), 0.0);
  std::fill(sc.m2.begin(), sc.m2.end(), 0.0);
  std::fill(sc.count.begin(), sc.count.end(), 0.0);
  std::fill(sc.bounce.begin(), sc.bounce.end(), 0.0);
  sc.back = sc.hit_count = sc.total = 0;
  trace_base_cube(tr, sc, rng, x);
  refine_edges(tr, sc, rng, x, rec);
  finish_record(tr, sc, rec);
}

// The probes' records packed into t, in grid order.
void pack_records(ProbeTransfer& t, const std::vector<ProbeRecord>& records) {
  const std::size_t P = records.size();
  t.state.resize(P);
  t.positions.resize(P);
  t.vis_offsets.assign(1, 0);
  t.partial_offsets.assign(1, 0);
  for (std::size_t p = 0; p < P; ++p) {
    const ProbeRecord& rec = records[p];
    t.state[p] = rec.state;
    t.positions[p] = rec.position;
    if (rec.state != ProbeState::Stored) continue;
    t.vis_nodes.insert(t.vis_nodes.end(), rec.nodes.begin(), rec.nodes.end());
    t.vis_offsets.push_back(t.vis_nodes.size());
    t.vis_complement.push_back(rec.complement ? 1 : 0);
    t.partial_nodes.insert(t.partial_nodes.end(), rec.partial_nodes.begin(), rec.partial_nodes.end());
    t.partial_mask.insert(t.partial_mask.end(), rec.partial_mask.begin(), rec.partial_mask.end());
    t.partial_offsets.push_back(t.partial_nodes.size());
    t.depth.insert(t.depth.end(), rec.depth.begin(), rec.depth.end());
    t.bounce.insert(t.bounce.end(), rec.bounce.begin(), rec.bounce.end());
  }
}

}  // namespace

ProbeTransfer compute_probe_transfer(const Scene& scene, const ProbeGrid& grid, const ProbeOptions& o,
                                     const Progress& progress) {
  check_probe_options(o);
  // Before anything is allocated per probe (a hand-made grid has not been through probe_grid).
  if (const std::string p = probe_dims_problem(grid.dims); !p.empty()) throw Error("probe grid: " + p);
  const Mesh& mesh = scene.mesh;
  detail::check_ray_offset(o.offset, mesh, "--offset");
  std::unique_ptr<tbb::global_control> limit;
  if (o.threads > 0) limit = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism, o.threads);
  const detail::RayScene rays(mesh, /*robust=*/true);
  const float offset = float(o.offset > 0 ? o.offset : detail::default_ray_offset(mesh));
  double smallest = 0.0;
  ProbeTransfer t = probe_header(scene, grid, o, smallest);
  (void)smallest;  // the lift below is a twentieth of it (detail::probe_lift)

  const int r = o.cube_res, base = std::max(1, r / 4);
  const ProbeTracing tr{scene,
                        rays,
                        o,
                        t,
                        offset,
                        r,
                        int(std::lround(std::sqrt(double(o.rays_per_texel)))),
                        o.depth_res,
                        sh::num_coeffs(o.bands),
                        o.mode == TransferMode::Interreflected ? sh::num_coeffs(o.bounce_bands) : 0,
                        base,
                        r / base,
                        (std::size_t(6) * r * r + 31) / 32,
                        detail::probe_lift(grid)};
  const std::size_t P = grid.count();
  std::vector<ProbeRecord> records(P);
  detail::ProgressTicker ticker(progress, P, "probes");
  ticker.start();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, P, 16), [&](const tbb::blocked_range<std::size_t>& range) {
    detail::enable_ftz_daz();
    ProbeScratch sc(tr);
    for (std::size_t p = range.begin(); p < range.end(); ++p) {
      if (ticker.cancelled()) return;
      trace_probe(tr, sc, p, records[p]);
      ticker.tick(1);
    }
  });
  ticker.finish();
  pack_records(t, records);
  if (const std::string problem = probe_transfer_problem(t); !problem.empty())
    throw Error("computed probe volume is inconsistent (a bug): " + problem);
  return t;
}

ProbeOcclusion::ProbeOcclusion(const Mesh& mesh, const ProbeGrid& grid)
    : rays_(std::make_unique<detail::RayScene>(mesh, /*robust=*/true)), offset_(detail::default_ray_offset(mesh)) {
  const glm::dvec3 sp = grid.spacing();
  double smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (sp[a] > 0) smallest = std::min(smallest, sp[a]);
  spread_ = std::isfinite(smallest) ? 0.1 * smallest : 0.0;
}

ProbeOcclusion::~ProbeOcclusion() = default;

double ProbeOcclusion::operator()(const glm::dvec3& probe, const glm::dvec3& p) const {
  check_ray_origin(p, 0, "probe visibility");  // the query point: a caller's, not the grid's
  detail::enable_ftz_daz();
  const glm::dvec3 axis = probe - p;
  const double len = glm::length(axis);
  if (!(len > 0)) return 1.0;
  glm::dvec3 t, b;
  detail::basis(axis / len, t, b);
  const glm::dvec3 ends[5] = {probe, probe + t * spread_, probe - t * spread_, probe + b * spread_, probe - b * spread_};
  int open = 0;
  for (const glm::dvec3& e : ends) {
    const glm::dvec3 d = e - p;
    const double dl = glm::length(d);
    open += dl <= 0 || !rays_->occluded1(glm::vec3(p), glm::vec3(d / dl), float(offset_), float(dl));
  }
  return open / 5.0;
}

namespace detail {

double probe_lift(const ProbeGrid& grid) {
  const glm::dvec3 sp = grid.spacing();
  const double largest = std::max({sp.x, sp.y, sp.z});
  double smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (sp[a] > 0) smallest = std::min(smallest, sp[a]);
  if (!std::isfinite(smallest)) smallest = largest > 0 ? largest : 1.0;
  return 0.05 * smallest;
}

glm::vec3 lift_off_surfaces(const RayScene& rays, const Mesh& mesh, double lift, glm::vec3 x) {
  for (int move = 0; move < 4; ++move) {
    glm::dvec3 at;
    const std::uint32_t f = rays.closest_point(x, float(lift), at);
    if (f == ~0u) break;
    const glm::uvec3& tri = mesh.triangles[f];
    const glm::dvec3 a(mesh.positions[tri[0]]), b(mesh.positions[tri[1]]), c(mesh.positions[tri[2]]);
    glm::dvec3 n = glm::cross(b - a, c - a);
    if (!(glm::length(n) > 0)) break;
    n = glm::normalize(n);
    const double side = glm::dot(glm::dvec3(x) - at, n);
    const double sign = side < -1e-3 * lift ? -1.0 : 1.0;
    x = glm::vec3(glm::dvec3(x) + n * (sign * 2.0 * lift - side));
  }
  return x;
}

}  // namespace detail

}  // namespace prt
