// prt_probe_figures: the figures of docs/PROBES.md. For a scene, a map and
// a grid (shadowed probes), against a ground truth computed here by tracing
// one ray per map pixel from each point (no visibility cube, no SH):
//   truth(p, n)  = (1/pi) sum_pixels V(p, w) L w.n+ omega        E(p, n)/pi
//   ideal(p)     = sum_pixels V(p, w) L Y_k(w) omega              the exact n-band SH of the occluded light
// it prints
//   * at probe positions: the relative RMS error of the probes against the
//     truth, and that of the ideal n-band output (the intrinsic error), over
//     all stored probes and over the dim ones (truth below a tenth of the
//     median), each with 6 axis normals;
//   * between probes: at random points in cells whose 8 probes are all
//     stored (in the air), and at points near surfaces (within a quarter of
//     the smallest spacing), the error of the probes (visibility-aware
//     weights) and of the ideal probes trilinearly interpolated;
//   * inside closed geometry (points of the box --box x0,y0,z0,x1,y1,z1
//     whose 6 axis rays all meet a back face first): the mean relit value
//     over the mean over free space;
//   * --spacing: the between-probe error for several grids.
// usage: prt_probe_figures SCENE MAP NXxNYxNZ [--rotate y,p,r] [--box ...] [--points N] [--spacing]
//        prt_probe_figures SCENE MAP PROBES.prt [--frame MESH]   (the volume's relighting time,
//          against a diffuse PRT frame of MESH in the same process; PRT_PROBE_VOLUME_ONLY=1 with a
//          grid precomputes it first)
#include <prt/envmap.h>
#include <prt/precompute.h>
#include <prt/probes.h>
#include <prt/rotation.h>
#include <prt/scene.h>
#include <prt/sh.h>
#include <prt/filter.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/transfer_file.h>

#include "synthetic_transfer.h"

#include "ray_scene.h"

#include <fmt/core.h>
#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <optional>
#include <random>
#include <string>
#include <vector>

using namespace prt;

namespace {

struct Pixel {
  glm::vec3 dir;
  glm::dvec3 power;  // L x omega
  // Bright pixels (over a 1e-4 share of the map's power): 4 x 4 directions
  // across the pixel, the visible share of which is its visibility (the
  // area visibility a Monte Carlo estimate converges to; one ray through
  // the centre would decide a partly hidden sun all or nothing).
  std::vector<glm::vec3> spread;
};

// The truth's rays: one per map pixel (downsampled to --truth-width, 1024 by default)
// The map's pixels (downsampled 2 x 2 until at most `width` wide), rotated.
std::vector<Pixel> map_pixels(const EnvMap& map, const glm::dmat3& R, int width) {
  int f = 1;
  while (map.width / (2 * f) >= width && map.width % (2 * f) == 0 && map.height % (2 * f) == 0) f *= 2;
  std::vector<Pixel> out;
  std::vector<std::pair<int, int>> pixel_block;
  for (int by = 0; by < map.height; by += f)
    for (int bx = 0; bx < map.width; bx += f) {
      glm::dvec3 d(0.0), p(0.0);
      for (int y = by; y < by + f; ++y)
        for (int x = bx; x < bx + f; ++x) {
          const double w = latlong_pixel_solid_angle(y, map.width, map.height);
          d += latlong_direction(x + 0.5, y + 0.5, map.width, map.height) * w;
          const float* c = map.rgb.data() + (std::size_t(y) * map.width + std::size_t(x)) * 3;
          p += glm::dvec3(c[0], c[1], c[2]) * w;
        }
      out.push_back({glm::vec3(R * glm::normalize(d)), p, {}});
      pixel_block.push_back({bx, by});
    }
  glm::dvec3 total(0.0);
  for (const Pixel& q : out) total += q.power;
  const double share = 1e-4 * (total.x + total.y + total.z);
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (out[i].power.x + out[i].power.y + out[i].power.z <= share) continue;
    for (int sy = 0; sy < 4; ++sy)
      for (int sx = 0; sx < 4; ++sx)
        out[i].spread.push_back(glm::vec3(R * latlong_direction(pixel_block[i].first + f * (sx + 0.5) / 4.0,
                                                               pixel_block[i].second + f * (sy + 0.5) / 4.0, map.width, map.height)));
  }
  return out;
}

struct Truth {
  std::vector<glm::dvec3> sh;  // n^2: the exact SH of the occluded light
  std::vector<float> visible;  // per pixel, 0..1
};

Truth trace_truth(const detail::RayScene& rays, const std::vector<Pixel>& px, const glm::vec3& p, int bands, float offset) {
  Truth t;
  const int nc = bands * bands;
  t.sh.assign(std::size_t(nc), glm::dvec3(0.0));
  t.visible.resize(px.size());
  std::vector<double> y(static_cast<std::size_t>(nc));
  glm::vec3 dirs[8];
  for (std::size_t i = 0; i < px.size(); i += 8) {
    const int n = int(std::min<std::size_t>(8, px.size() - i));
    for (int q = 0; q < n; ++q) dirs[q] = px[i + std::size_t(q)].dir;
    const std::uint32_t occ = rays.occluded8(p, dirs, n, offset);
    for (int q = 0; q < n; ++q) {
      const Pixel& pix = px[i + std::size_t(q)];
      float vis = (occ >> q) & 1u ? 0.0f : 1.0f;
      if (!pix.spread.empty()) {
        std::uint32_t open = 0;
        for (std::size_t a = 0; a < pix.spread.size(); a += 8) {
          const int m = int(std::min<std::size_t>(8, pix.spread.size() - a));
          open += std::uint32_t(m - std::popcount(rays.occluded8(p, pix.spread.data() + a, m, offset)));
        }
        vis = float(open) / float(pix.spread.size());
      }
      t.visible[i + std::size_t(q)] = vis;
      if (vis == 0) continue;
      const glm::dvec3 d(dirs[q]);
      sh::eval(bands, d.x, d.y, d.z, y.data());
      for (int k = 0; k < nc; ++k) t.sh[std::size_t(k)] += y[std::size_t(k)] * pix.power * double(vis);
    }
  }
  return t;
}

glm::dvec3 truth_lambert(const Truth& t, const std::vector<Pixel>& px, const glm::dvec3& n) {
  glm::dvec3 e(0.0);
  for (std::size_t i = 0; i < px.size(); ++i)
    if (t.visible[i] > 0) e += std::max(0.0, glm::dot(glm::dvec3(px[i].dir), n)) * px[i].power * double(t.visible[i]);
  return e / M_PI;
}

glm::dvec3 sh_lambert(const std::vector<glm::dvec3>& sh, int bands, const glm::dvec3& n) {
  std::vector<glm::vec3> f(sh.size());
  for (std::size_t i = 0; i < sh.size(); ++i) f[i] = glm::vec3(sh[i]);
  return lambert_from_sh(f, bands, n);
}

// Relative RMS of a against b (sum |a-b|^2 / sum |b|^2).
struct Err {
  double num = 0, den = 0;
  std::size_t n = 0;
  void add(const glm::dvec3& a, const glm::dvec3& b) {
    num += glm::dot(a - b, a - b);
    den += glm::dot(b, b);
    ++n;
  }
  double rel() const { return den > 0 ? std::sqrt(num / den) : 0; }
};

const glm::dvec3 kAxes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

// A diffuse 3-band RGB PRT frame of `path` at 512 x 512 (background and
// mesh, waited for): the median of 20, after one to warm up. With a 3-band
// volume and its relit probes, also the GPU's share of a probe-lit object:
// the upload of every relit probe (set_probe_lighting, waited for by the
// next frame) and the frame with the same mesh drawn again as a probe-lit
// object (its per-vertex interpolation pass), medians of 20.
struct FrameFigures {
  double frame = 0, upload_and_frame = 0, object_frame = 0;
};
double median_ms(std::vector<double> ms) {
  std::nth_element(ms.begin(), ms.begin() + std::ptrdiff_t(ms.size() / 2), ms.end());
  return ms[ms.size() / 2];
}
FrameFigures frame_figures(const std::string& path, const EnvMap& map, const ProbeTransfer* probes,
                           const std::vector<glm::vec3>& lit) {
  Renderer r;
  const Mesh m = load_mesh(path);
  r.set_mesh(m, bench::synthetic_transfer(m, 3, 3));
  r.set_environment(map);
  r.set_lighting(project(map, 3));
  r.set_shading(Shading::Transfer);
  const Camera cam = default_camera(m);
  const auto time = [&](const std::function<void()>& before) {
    r.draw_only(cam, 512, 512);
    std::vector<double> ms;
    for (int i = 0; i < 20; ++i) {
      const auto a = std::chrono::steady_clock::now();
      before();
      r.draw_only(cam, 512, 512);
      ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - a).count());
    }
    return median_ms(ms);
  };
  FrameFigures f;
  f.frame = time([] {});
  if (probes && probes->bands == 3) {
    r.set_probe_object(m, *probes, glm::vec3(0.8f));
    // The mesh scaled into the volume's centre cell region (where it is drawn
    // does not change the per-vertex work).
    glm::dvec3 lo(m.positions[0]), hi = lo;
    for (const glm::vec3& p : m.positions) {
      lo = glm::min(lo, glm::dvec3(p));
      hi = glm::max(hi, glm::dvec3(p));
    }
    const glm::dvec3 centre = 0.5 * (probes->grid.min + probes->grid.max);
    const double scale = 2.0 * glm::length(probes->grid.spacing()) / std::max(glm::length(hi - lo), 1e-30);
    glm::mat4 model = glm::mat4(float(scale));
    model[3] = glm::vec4(glm::vec3(centre - scale * 0.5 * (lo + hi)), 1.0f);
    r.set_probe_object_model(model);
    r.set_probe_lighting(lit);
    f.object_frame = time([] {});
    f.upload_and_frame = time([&] { r.set_probe_lighting(lit); });
  }
  return f;
}

// The grid argument: a probe volume file (a transfer of another kind is
// refused, naming its kind), or nullopt for a grid NXxNYxNZ.
std::optional<ProbeTransfer> volume_file_arg(const char* arg) {
  if (!std::filesystem::is_regular_file(arg)) return std::nullopt;
  return read_transfer_as<ProbeTransfer>(arg);
}

// The command line past SCENE MAP GRID.
struct Args {
  double euler[3] = {0, 0, 0}, box[6] = {0, 0, 0, 0, 0, 0};
  bool have_box = false, spacing_table = false, chebyshev = false;
  int points = 400, cube = 0, depth = 0, truth_width = 1024;
  std::string frame_mesh;
};

Args parse_args(int argc, char** argv) {
  Args g;
  for (int i = 4; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--rotate" && i + 1 < argc) std::sscanf(argv[++i], "%lf,%lf,%lf", &g.euler[0], &g.euler[1], &g.euler[2]);
    else if (a == "--box" && i + 1 < argc) {
      g.have_box = std::sscanf(argv[++i], "%lf,%lf,%lf,%lf,%lf,%lf", &g.box[0], &g.box[1], &g.box[2], &g.box[3], &g.box[4],
                               &g.box[5]) == 6;
    } else if (a == "--points" && i + 1 < argc) g.points = std::atoi(argv[++i]);
    else if (a == "--cube" && i + 1 < argc) g.cube = std::atoi(argv[++i]);
    else if (a == "--depth" && i + 1 < argc) g.depth = std::atoi(argv[++i]);
    else if (a == "--truth-width" && i + 1 < argc) g.truth_width = std::atoi(argv[++i]);
    else if (a == "--spacing") g.spacing_table = true;
    else if (a == "--chebyshev") g.chebyshev = true;
    else if (a == "--frame" && i + 1 < argc) g.frame_mesh = argv[++i];  // the depth moments' weights instead of traced visibility
  }
  return g;
}

// What every grid's figures share: the scene, its rays, the map's pixels
// (rotated by R) and the bands.
struct Figures {
  const Args& args;
  const Scene& scene;
  const EnvMap& map;
  glm::dmat3 R;
  std::vector<Pixel> px;
  const detail::RayScene& rays;
  float offset;
  int bands, nc;
};

// One grid's volume, relit, with the ideal probes (the exact SH at every
// probe's position) and the probe weights at a point.
struct GridRun {
  const ProbeGrid& grid;
  const ProbeTransfer& t;
  const std::vector<glm::vec3>& lit;  // nc per probe
  const std::vector<Truth>& ideal;
  std::function<ProbeWeights(const glm::dvec3&, const glm::dvec3&)> weights_at;
};

// The errors at the probes. Dim probes: those whose mean truth over the 6
// normals is between a hundredth and a quarter of the median probe's (they
// see a little of the map: the dim ones inside a room lit through an
// opening; below a hundredth, a probe sees the map only through the cracks
// where walls meet at grazing angles, and every estimate there, the truth's
// too, is a handful of rays).
struct AtProbes {
  Err ours_all, ideal_all, ours_dim, ideal_dim;
  std::size_t dim_probes = 0;
  double dim_below = 0, dim_above = 0;
};

AtProbes at_probes(const Figures& fg, const GridRun& g) {
  const ProbeTransfer& t = g.t;
  const std::vector<Truth>& ideal = g.ideal;
  const std::vector<Pixel>& px = fg.px;
  const int bands = fg.bands, nc = fg.nc;
  const std::vector<std::uint32_t> slots = t.stored_slots();
  const std::size_t P = t.probes();
  AtProbes r;
  std::vector<double> mean_of(P, -1.0);
  for (std::size_t p = 0; p < P; ++p)
    if (t.state[p] == ProbeState::Stored) {
      double m = 0;
      for (const glm::dvec3& n : kAxes) {
        const glm::dvec3 v = truth_lambert(ideal[p], px, n);
        m += (v.x + v.y + v.z) / 6;
      }
      mean_of[p] = m;
    }
  std::vector<double> sorted;
  for (double m : mean_of)
    if (m >= 0) sorted.push_back(m);
  std::sort(sorted.begin(), sorted.end());
  r.dim_below = sorted.empty() ? 0 : 0.25 * sorted[sorted.size() / 2];
  r.dim_above = r.dim_below * 0.04;
  for (std::size_t p = 0; p < P; ++p) {
    if (t.state[p] != ProbeState::Stored) continue;
    std::vector<glm::vec3> mine(g.lit.begin() + std::ptrdiff_t(p * nc), g.lit.begin() + std::ptrdiff_t((p + 1) * nc));
    const bool dim = mean_of[p] > r.dim_above && mean_of[p] < r.dim_below;
    r.dim_probes += dim;
    if (dim && std::getenv("PRT_PROBE_DEBUG")) {
      const std::size_t s2 = slots[p];
      fmt::print("dim probe {} at {:.3f} {:.3f} {:.3f}: nodes {} (complement {}), partial {}; visible map pixels {}\n", p,
                 t.positions[p].x, t.positions[p].y, t.positions[p].z, t.vis_offsets[s2 + 1] - t.vis_offsets[s2],
                 int(t.vis_complement[s2]), t.partial_offsets[s2 + 1] - t.partial_offsets[s2],
                 std::count(ideal[p].visible.begin(), ideal[p].visible.end(), 1));
      for (const glm::dvec3& n : kAxes) {
        const glm::dvec3 tr = truth_lambert(ideal[p], px, n), a = lambert_from_sh(mine, bands, n), b = sh_lambert(ideal[p].sh, bands, n);
        fmt::print("   n {:+.0f} {:+.0f} {:+.0f}: truth {:.3e} probes {:.3e} ideal {:.3e}\n", n.x, n.y, n.z, tr.x, a.x, b.x);
      }
    }
    for (const glm::dvec3& n : kAxes) {
      const glm::dvec3 truth = truth_lambert(ideal[p], px, n);
      const glm::dvec3 a = lambert_from_sh(mine, bands, n), b = sh_lambert(ideal[p].sh, bands, n);
      r.ours_all.add(a, truth);
      r.ideal_all.add(b, truth);
      if (std::getenv("PRT_PROBE_WORST") && glm::length(a - b) > std::atof(std::getenv("PRT_PROBE_WORST")))
        fmt::print("probe {} ({:.3f} {:.3f} {:.3f}) n {:+.0f} {:+.0f} {:+.0f}: truth {:.4g} probes {:.4g} ideal {:.4g}; partial {}\n", p,
                   t.positions[p].x, t.positions[p].y, t.positions[p].z, n.x, n.y, n.z, truth.x, a.x, b.x,
                   t.partial_offsets[slots[p] + 1] - t.partial_offsets[slots[p]]);
      if (dim) {
        r.ours_dim.add(a, truth);
        r.ideal_dim.add(b, truth);
      }
    }
  }
  return r;
}

// Query points between probes: up to `points` in the air (cells whose 8
// probes are all stored; kind 0) and as many near surfaces (within a
// quarter of the smallest spacing; kind 1).
struct Queries {
  std::vector<glm::dvec3> qp;
  std::vector<int> kind;  // 0 air, 1 near
};

Queries query_points(const Figures& fg, const GridRun& g, std::mt19937& gen, std::uniform_real_distribution<double>& U) {
  const ProbeGrid& grid = g.grid;
  const int points = fg.args.points;
  const glm::dvec3 sp = grid.spacing();
  const double smallest = std::min({sp.x > 0 ? sp.x : 1e30, sp.y > 0 ? sp.y : 1e30, sp.z > 0 ? sp.z : 1e30});
  Queries q;
  for (int tries = 0; int(q.qp.size()) < 2 * points && tries < 200 * points; ++tries) {
    const glm::dvec3 p = grid.min + (grid.max - grid.min) * glm::dvec3(U(gen), U(gen), U(gen));
    const ProbeWeights w = trilinear_weights(grid, p);
    bool air = true;
    for (int c = 0; c < 8; ++c) air = air && g.t.state[w.probe[std::size_t(c)]] == ProbeState::Stored;
    glm::dvec3 at;
    const bool near = fg.rays.closest_point(glm::vec3(p), float(0.25 * smallest), at) != ~0u;
    // Inside a solid (the closest surface's back side) is not a query point.
    if (near && glm::length(p - at) < 1e-3 * smallest) continue;
    const int count_air = int(std::count(q.kind.begin(), q.kind.end(), 0));
    if (near && int(q.qp.size()) - count_air < points) {
      q.qp.push_back(p);
      q.kind.push_back(1);
    } else if (air && !near && count_air < points) {
      q.qp.push_back(p);
      q.kind.push_back(0);
    }
  }
  return q;
}

// At the query points, 6 axis normals each: the truth, the probes' relit
// value and the ideal probes trilinearly interpolated.
struct Between {
  std::vector<glm::dvec3> truths, ours, ideals;  // 6 per query point
};

Between between_probes(const Figures& fg, const GridRun& g, const Queries& q) {
  const int bands = fg.bands, nc = fg.nc;
  const std::vector<glm::dvec3>& qp = q.qp;
  Between r;
  r.truths.resize(qp.size() * 6);
  r.ours.resize(qp.size() * 6);
  r.ideals.resize(qp.size() * 6);
  tbb::parallel_for(std::size_t(0), qp.size(), [&](std::size_t i) {
    detail::enable_ftz_daz();
    const Truth tr = trace_truth(fg.rays, fg.px, glm::vec3(qp[i]), bands, fg.offset);
    const ProbeWeights tw = trilinear_weights(g.grid, qp[i]);
    for (int a = 0; a < 6; ++a) {
      const glm::dvec3 n = kAxes[a];
      r.truths[i * 6 + std::size_t(a)] = truth_lambert(tr, fg.px, n);
      const ProbeWeights w = g.weights_at(qp[i], n);
      std::vector<glm::vec3> mix(std::size_t(nc), glm::vec3(0.0f));
      std::vector<glm::dvec3> imix(std::size_t(nc), glm::dvec3(0.0));
      for (int c = 0; c < w.count; ++c)
        for (int k = 0; k < nc; ++k)
          mix[std::size_t(k)] += w.weight[std::size_t(c)] * g.lit[std::size_t(w.probe[std::size_t(c)]) * nc + std::size_t(k)];
      for (int c = 0; c < tw.count; ++c) {
        const Truth& ip = g.ideal[tw.probe[std::size_t(c)]];
        if (ip.sh.empty()) continue;
        for (int k = 0; k < nc; ++k) imix[std::size_t(k)] += double(tw.weight[std::size_t(c)]) * ip.sh[std::size_t(k)];
      }
      r.ours[i * 6 + std::size_t(a)] = lambert_from_sh(mix, bands, n);
      r.ideals[i * 6 + std::size_t(a)] = sh_lambert(imix, bands, n);
    }
  });
  return r;
}

// Inside the box against free space (the air points of `q`): printed.
void box_figures(const Figures& fg, const GridRun& g, const Queries& q, const Between& b, std::mt19937& gen,
                 std::uniform_real_distribution<double>& U) {
  const double* box = fg.args.box;
  const int points = fg.args.points, bands = fg.bands, nc = fg.nc;
  double inside = 0, free = 0;
  std::size_t ni = 0, nf = 0;
  for (int i = 0, tries = 0; i < points && tries < 100 * points; ++tries) {
    const glm::dvec3 p(box[0] + (box[3] - box[0]) * U(gen), box[1] + (box[4] - box[1]) * U(gen),
                       box[2] + (box[5] - box[2]) * U(gen));
    // Inside closed geometry: every axis ray meets a back face first.
    bool inside_box = true;
    for (const glm::dvec3& a : kAxes) {
      const detail::Hit h = fg.rays.intersect1(glm::vec3(p), glm::vec3(a), 0.0f);
      inside_box = inside_box && h.hit() && !h.front;
    }
    if (!inside_box) continue;
    ++i;
    for (const glm::dvec3& n : kAxes) {
      const ProbeWeights w = g.weights_at(p, n);
      std::vector<glm::vec3> mix(std::size_t(nc), glm::vec3(0.0f));
      for (int c = 0; c < w.count; ++c)
        for (int k = 0; k < nc; ++k)
          mix[std::size_t(k)] += w.weight[std::size_t(c)] * g.lit[std::size_t(w.probe[std::size_t(c)]) * nc + std::size_t(k)];
      const glm::dvec3 v = lambert_from_sh(mix, bands, n);
      inside += v.x + v.y + v.z;
      ++ni;
    }
  }
  for (std::size_t i = 0; i < q.qp.size(); ++i)
    if (q.kind[i] == 0)
      for (int a = 0; a < 6; ++a) {
        const glm::dvec3 v = b.ours[i * 6 + std::size_t(a)];
        free += v.x + v.y + v.z;
        ++nf;
      }
  fmt::print("inside the box: mean {:.4g}, free space {:.4g}: {:.2f}%\n", inside / double(ni), free / double(std::max<std::size_t>(nf, 1)),
             100.0 * (inside / double(ni)) / std::max(free / double(std::max<std::size_t>(nf, 1)), 1e-30));
}

// One grid: precomputed, relit, its figures printed (report: in full; else
// one row of the --spacing table).
ProbeTransfer run_grid(const Figures& fg, const std::array<int, 3>& dims, bool report) {
  const Args& args = fg.args;
  ProbeOptions o;
  if (args.cube > 0) o.cube_res = args.cube;
  if (args.depth > 0) o.depth_res = args.depth;
  const ProbeGrid grid = probe_grid(fg.scene.mesh, dims);
  const auto t0 = std::chrono::steady_clock::now();
  const ProbeTransfer t = compute_probe_transfer(fg.scene, grid, o);
  const double t_pre = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  ProbeRelighter relighter(t, fg.map);
  relighter.set_rotation(fg.R);
  std::vector<glm::vec3> lit;
  relighter.relight(lit);
  const std::vector<std::uint32_t> slots = t.stored_slots();
  const std::size_t P = t.probes();
  const ProbeOcclusion occlusion(fg.scene.mesh, grid);
  const ProbeVisibility visible = [&](const glm::dvec3& probe, const glm::dvec3& p) {
    return args.chebyshev ? 1.0 : occlusion(probe, p);
  };
  // Ideal probes: the exact SH at every probe's position.
  std::vector<Truth> ideal(P);
  tbb::parallel_for(std::size_t(0), P, [&](std::size_t p) {
    detail::enable_ftz_daz();
    if (t.state[p] != ProbeState::Invalid) ideal[p] = trace_truth(fg.rays, fg.px, t.positions[p], fg.bands, fg.offset);
  });
  const GridRun g{grid, t, lit, ideal, [&](const glm::dvec3& p, const glm::dvec3& n) {
                    return args.chebyshev ? probe_weights(t, slots, p, n) : probe_weights(t, slots, p, n, visible);
                  }};
  const AtProbes at = at_probes(fg, g);
  // Between probes.
  std::mt19937 gen(7);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  const glm::dvec3 sp = grid.spacing();
  const Queries q = query_points(fg, g, gen, U);
  const Between b = between_probes(fg, g, q);
  Err air_ours, air_ideal, near_ours, near_ideal;
  for (std::size_t i = 0; i < q.qp.size(); ++i)
    for (int a = 0; a < 6; ++a) {
      const std::size_t j = i * 6 + std::size_t(a);
      (q.kind[i] == 0 ? air_ours : near_ours).add(b.ours[j], b.truths[j]);
      (q.kind[i] == 0 ? air_ideal : near_ideal).add(b.ideals[j], b.truths[j]);
    }
  if (report) {
    std::size_t counts[3] = {0, 0, 0};
    for (ProbeState s : t.state) ++counts[int(s)];
    fmt::print("grid {}x{}x{} (spacing {:.3f} {:.3f} {:.3f}): {} stored, {} sky, {} invalid; precompute {:.2f} s, {} bytes\n",
               dims[0], dims[1], dims[2], sp.x, sp.y, sp.z, counts[1], counts[0], counts[2], t_pre, t.bytes());
    fmt::print("at probes ({} values): probes {:.4f}, ideal 3-band {:.4f}, ratio {:.3f}\n", at.ours_all.n, at.ours_all.rel(),
               at.ideal_all.rel(), at.ours_all.rel() / std::max(at.ideal_all.rel(), 1e-12));
    fmt::print("at dim probes ({} probes, mean truth in ({:.4g}, {:.4g})): probes {:.4f}, ideal 3-band {:.4f}, ratio {:.3f}\n",
               at.dim_probes, at.dim_above, at.dim_below, at.ours_dim.rel(), at.ideal_dim.rel(),
               at.ours_dim.rel() / std::max(at.ideal_dim.rel(), 1e-12));
    fmt::print("between probes, in the air ({} values): probes {:.4f}, ideal trilinear {:.4f}, ratio {:.3f}\n", air_ours.n,
               air_ours.rel(), air_ideal.rel(), air_ours.rel() / std::max(air_ideal.rel(), 1e-12));
    fmt::print("between probes, near surfaces ({} values): probes {:.4f}, ideal trilinear {:.4f}, ratio {:.3f}\n",
               near_ours.n, near_ours.rel(), near_ideal.rel(), near_ours.rel() / std::max(near_ideal.rel(), 1e-12));
  } else {
    fmt::print("| {}x{}x{} | {:.3f} | {:.4f} | {:.4f} | {:.4f} | {:.4f} |\n", dims[0], dims[1], dims[2],
               std::max({sp.x, sp.y, sp.z}), air_ours.rel(), air_ideal.rel(), near_ours.rel(), near_ideal.rel());
  }
  if (args.have_box && report) box_figures(fg, g, q, b, gen, U);
  return t;
}

// The relighting cost of a volume (argv[3] a probe file, or a grid
// precomputed here): set_rotation (the map splatted into the rotated cube,
// its pyramid) and relight every probe, 15 rotations, the median; with
// --frame MESH, against a diffuse 3-band RGB PRT frame of MESH at 512 x 512
// (prt::Renderer, whatever OpenGL EGL gives) in this process.
void relight_cost(const Figures& fg, std::optional<ProbeTransfer>& volume, const std::array<int, 3>& dims) {
  const Args& args = fg.args;
  double t_pre = 0;
  ProbeTransfer t;
  if (volume.has_value()) t = std::move(*volume);
  else {
    ProbeOptions o;
    if (args.cube > 0) o.cube_res = args.cube;
    const auto t0 = std::chrono::steady_clock::now();
    t = compute_probe_transfer(fg.scene, probe_grid(fg.scene.mesh, dims), o);
    t_pre = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  ProbeRelighter relighter(t, fg.map);
  std::vector<glm::vec3> lit;
  std::vector<double> light, sum, both;
  for (int i = 0; i < 15; ++i) {
    const auto a = std::chrono::steady_clock::now();
    relighter.set_rotation(sh::rotation_from_euler(10.0 * i, 5.0, 0.0));
    const auto b = std::chrono::steady_clock::now();
    relighter.relight(lit);
    const auto c = std::chrono::steady_clock::now();
    light.push_back(std::chrono::duration<double, std::milli>(b - a).count());
    sum.push_back(std::chrono::duration<double, std::milli>(c - b).count());
    both.push_back(light.back() + sum.back());
  }
  const auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + std::ptrdiff_t(v.size() / 2), v.end());
    return v[v.size() / 2];
  };
  std::size_t nodes = t.vis_nodes.size(), partial = t.partial_nodes.size();
  fmt::print("volume {}x{}x{}: {} probes, {} stored; precompute {:.1f} s; {} bytes ({:.0f} per stored probe; {:.1f} "
             "nodes and {:.1f} partial texels each); {} bright map pixels; relight (median of 15 rotations): lighting {:.2f} ms + "
             "probes {:.2f} ms = {:.2f} ms (best {:.2f} ms)\n",
             t.grid.dims[0], t.grid.dims[1], t.grid.dims[2], t.probes(), t.stored(), t_pre, t.bytes(),
             double(t.bytes()) / double(std::max<std::size_t>(t.stored(), 1)), double(nodes) / double(std::max<std::size_t>(t.stored(), 1)),
             double(partial) / double(std::max<std::size_t>(t.stored(), 1)), relighter.bright_pixels(), median(light), median(sum),
             median(both), *std::min_element(both.begin(), both.end()));
  if (!args.frame_mesh.empty()) {
    const FrameFigures f = frame_figures(args.frame_mesh, fg.map, &t, lit);
    fmt::print("diffuse PRT frame of {} (3 bands RGB, 512 x 512, median of 20): {:.2f} ms; volume relight / frame: {:.2f}x (medians)\n",
               args.frame_mesh, f.frame, median(both) / f.frame);
    if (f.object_frame > 0)
      fmt::print("GPU, the same mesh also drawn as a probe-lit object: frame {:.2f} ms (+{:.2f} ms: its interpolation pass "
                 "and draw); every relit probe uploaded before it: {:.2f} ms (+{:.2f} ms: the upload, {:.1f} MB)\n",
                 f.object_frame, f.object_frame - f.frame, f.upload_and_frame, f.upload_and_frame - f.object_frame,
                 double(lit.size()) * 12.0 / 1e6);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    fmt::print(stderr, "usage: prt_probe_figures SCENE MAP NXxNYxNZ [--rotate y,p,r] [--box x0,y0,z0,x1,y1,z1] "
                       "[--points N] [--spacing] [--cube r]\n");
    return 2;
  }
  const std::string scene_path = argv[1], map_path = argv[2];
  const Args args = parse_args(argc, argv);
  const Scene scene = load_scene_or_mesh(scene_path);
  const EnvMap map = load_envmap(map_path);
  const glm::dmat3 R = sh::rotation_from_euler(args.euler[0], args.euler[1], args.euler[2]);
  const detail::RayScene rays(scene.mesh);
  const int bands = 3;
  const Figures fg{args, scene, map, R, map_pixels(map, R, args.truth_width), rays,
                   float(detail::default_ray_offset(scene.mesh)), bands, bands * bands};
  std::array<int, 3> dims{};
  std::optional<ProbeTransfer> volume = volume_file_arg(argv[3]);
  const bool volume_file = volume.has_value();
  if (!volume_file) std::sscanf(argv[3], "%dx%dx%d", &dims[0], &dims[1], &dims[2]);
  if (volume_file || std::getenv("PRT_PROBE_VOLUME_ONLY")) {
    relight_cost(fg, volume, dims);
    return 0;
  }
  run_grid(fg, dims, true);
  if (args.spacing_table) {
    fmt::print("| grid | spacing | air: probes | air: ideal trilinear | near: probes | near: ideal trilinear |\n|---|--:|--:|--:|--:|--:|\n");
    for (int s : {1, 2, 4})
      run_grid(fg, {std::max(2, dims[0] * s / 2), std::max(2, dims[1] * s / 2), std::max(2, dims[2] * s / 2)}, false);
  }
  return 0;
}
