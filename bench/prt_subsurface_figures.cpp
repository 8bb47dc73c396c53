// bench/prt_subsurface_figures.cpp - issue 49's accuracy target for translucent
// materials (docs/SUBSURFACE.md):
//   prt_subsurface_figures MESH ENV [--bands 5] [--samples 1024] [--receivers 200] [--ref-samples 4096]
//                          [--levels 2] [--seed 1] [--quick] [--no-diagnostics] [--no-interreflected]
//                          [--dump MATERIAL] [--only MATERIAL]
// For marble, skin1, ketchup and "custom 0.1 mm" (sigma_a 0.5, sigma_s' 9.5
// /mm in every channel, eta 1.3: 1 / sigma_t' = 0.1 mm), each at two length
// scales S (mm per mesh unit) from the mesh's bounding-box diagonal D and
// the material's longest 1 / sigma_tr (mm), L:
//   "few percent": S = L / (0.03 D) (the object is ~33 diffusion lengths across),
//   "thin":        S = L / (0.5 D)  (2 across: light crosses thin parts),
// one row of:
//   e_prt  our translucent transfer (compute_subsurface_transfer at
//          `--samples` rays, its irradiance samples as the product takes
//          them; the count added is printed) relit at `--bands` bands
//          under the map's projection, against render_subsurface_reference
//          (`--ref-samples` iterations, the same material and scale, shadowed)
//          at the receivers;
//   e_bl   the same for the "exact band-limited answer": the same model on
//          the mesh split `--levels` times at its edges' midpoints (each
//          triangle into 4, twice: 16x the triangles and ~16x the vertices,
//          the original vertices keeping their indices; each new vertex on
//          its original triangle, its normal the normalised barycentric
//          blend of the corners' normals, as the reference interpolates
//          them), at 4^levels x the rays, relit at the same bands, read at
//          the original vertices;
//   the bound 1.1 e_bl + 1% and whether e_prt meets it, the reference's own
//   noise, and the times.
// Errors are relative RMS over the receivers and the three channels,
//   e = sqrt(sum (x - ref)^2 / sum ref^2),
// as they are (the reference's noise included, not taken out); "noise" is
// sqrt(sum se^2 / sum ref^2) of its standard errors se, and the columns
// "e_prt*", "e_bl*" have it taken out, sqrt(max(sum (x - ref)^2 - sum se^2, 0)
// / sum ref^2), as prt compare does. The receivers: `--receivers` vertices
// with a normal, every k-th in index order. One more row, skin1 at the thin
// scale, interreflected (2 bounces) against the reference's interreflected
// mode.
//
// The band-limited answer and the diagnostics share the transmitted
// irradiance's trace (compute_transfer with transmission_eta, rows times pi)
// between the materials of one eta and evaluate the surface integral
// (subsurface_scatter) at the receivers only: the arithmetic of
// compute_subsurface_transfer with the vertices alone as irradiance samples
// (split_levels 0), checked against it at the receivers on the first row
// (printed). Diagnostics (a second table, for every shadowed row): e_prt
// with the vertices alone, that with 4x the rays, with every source pair
// (SubsurfaceScatterOptions::max_solid_angle = 0; the band-limited one too),
// on the mesh split once at `--samples` rays (the surface's sampling alone),
// the mean edge length in mm against the material's smallest and largest
// z_r = 1 / sigma_t'. --dump MATERIAL prints that material's receivers
// (reference, ours, band-limited, and R_d,total E_t / pi) on stderr.
//
// --quick: 128 rays, 48 receivers, 256 reference iterations, one level.
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/reference.h>
#include <prt/subsurface.h>
#include <prt/subsurface_reference.h>
#include <prt/subsurface_scatter.h>
#include <prt/transfer.h>

#include <fmt/core.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <map>
#include <numbers>
#include <string>
#include <tuple>
#include <vector>

using namespace prt;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

struct Args {
  std::string mesh, env;
  int bands = 5, samples = 1024, receivers = 200, ref_samples = 4096, levels = 2;
  std::uint64_t seed = 1;
  bool diagnostics = true, interreflected = true;
  std::string dump;  // --dump MATERIAL: each receiver's values of that material's rows, on stderr
  std::string only;  // --only MATERIAL: that material's rows alone (the interreflected one with skin1)
};

// Every triangle split into n^2 (n = 2^levels segments an edge: the grid of
// barycentric points (i, j, n - i - j) / n): the original vertices first, at
// their indices; points on an edge shared by its two triangles (made from the
// edge's ends in index order, so both get the same bits).
Mesh subdivide(const Mesh& m, int levels) {
  const int n = 1 << levels;
  std::vector<glm::vec3> pos = m.positions, nrm = m.normals;
  std::vector<glm::uvec3> tris;
  std::map<std::tuple<std::uint32_t, std::uint32_t, int>, std::uint32_t> edge_points;
  const auto add = [&](const glm::dvec3& p, const glm::dvec3& nn) {
    pos.emplace_back(p);
    const double l = glm::length(nn);
    nrm.emplace_back(l > 1e-12 ? glm::vec3(nn / l) : glm::vec3(0.0f));
    return std::uint32_t(pos.size() - 1);
  };
  const auto blend = [&](const std::vector<glm::vec3>& a, const std::uint32_t* v, const double* w, int k) {
    glm::dvec3 s(0.0);
    for (int q = 0; q < k; ++q) s += w[q] * glm::dvec3(a[v[q]]);
    return s;
  };
  for (const glm::uvec3& t : m.triangles) {
    std::vector<std::uint32_t> grid(std::size_t((n + 1) * (n + 1)));
    const auto at = [&](int i, int j) -> std::uint32_t& { return grid[std::size_t(i * (n + 1) + j)]; };
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        const int k = n - i - j;  // weights: t.x k/n, t.y i/n, t.z j/n
        const std::uint32_t cv[3] = {t.x, t.y, t.z};
        const int cw[3] = {k, i, j};
        int zeros = 0, corner = -1;
        for (int c = 0; c < 3; ++c) zeros += cw[c] == 0, corner = cw[c] == n ? c : corner;
        if (corner >= 0) {
          at(i, j) = cv[corner];
        } else if (zeros == 1) {  // on the edge between the two corners with weight
          std::uint32_t e[2];
          int ew[2], q = 0;
          for (int c = 0; c < 3; ++c)
            if (cw[c] > 0) e[q] = cv[c], ew[q++] = cw[c];
          if (e[0] > e[1]) std::swap(e[0], e[1]), std::swap(ew[0], ew[1]);
          const auto key = std::make_tuple(e[0], e[1], ew[1]);
          const auto found = edge_points.find(key);
          if (found != edge_points.end()) {
            at(i, j) = found->second;
          } else {
            const double w[2] = {double(ew[0]) / n, double(ew[1]) / n};
            at(i, j) = edge_points[key] = add(blend(m.positions, e, w, 2), blend(m.normals, e, w, 2));
          }
        } else {
          const double w[3] = {double(k) / n, double(i) / n, double(j) / n};
          at(i, j) = add(blend(m.positions, cv, w, 3), blend(m.normals, cv, w, 3));
        }
      }
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        tris.emplace_back(at(i, j), at(i + 1, j), at(i, j + 1));
        if (i + j + 2 <= n) tris.emplace_back(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
      }
  }
  return make_mesh(std::move(pos), std::move(tris), std::move(nrm), {}, {}, m.source + " (subdivided)");
}

// The transmitted irradiance's rows, E_t per unit light (S_k times pi), one
// channel, every vertex; what compute_subsurface_transfer gives the surface
// integral.
struct Trace {
  std::vector<float> rows;
  double seconds = 0;
};

Trace trace_transmission(const Mesh& mesh, double eta, int bands, int samples, std::uint64_t seed) {
  TransferOptions o;
  o.mode = TransferMode::Shadowed;
  o.bounces = 0;
  o.bands = bands;
  o.samples = samples;
  o.seed = seed;
  o.transmission_eta = eta;
  const auto t0 = std::chrono::steady_clock::now();
  const Transfer t = compute_transfer(mesh, o);
  Trace r;
  r.rows = dense_transfer(t, mesh);
  if (t.channels != 1) throw Error("expected a one-channel transmission transfer");
  for (float& x : r.rows) x = float(std::numbers::pi * x);
  r.seconds = seconds_since(t0);
  return r;
}

// The surface integral at the receivers, relit: L_o per receiver, RGB.
std::vector<glm::vec3> scatter_relit(const Mesh& mesh, const SubsurfaceMaterial& mat, const std::vector<float>& rows,
                                     int bands, double scale, double max_solid_angle,
                                     const std::vector<std::uint32_t>& receivers,
                                     const std::vector<glm::dvec3>& light, double& seconds) {
  const int nc = bands * bands;
  SubsurfaceScatterOptions so;
  so.length_scale = scale;
  so.max_solid_angle = max_solid_angle;
  so.receivers = receivers;
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<float> out = subsurface_scatter(mesh, mat, rows, nc, so);
  seconds = seconds_since(t0);
  std::vector<glm::vec3> lo(receivers.size());
  for (std::size_t r = 0; r < receivers.size(); ++r)
    for (int c = 0; c < 3; ++c) {
      double s = 0;
      for (int k = 0; k < nc; ++k) s += double(out[(r * 3 + std::size_t(c)) * std::size_t(nc) + std::size_t(k)]) * light[std::size_t(k)][c];
      lo[r][c] = float(s);
    }
  return lo;
}

struct Errors {
  double raw = 0, corrected = 0;
};

Errors rel_rms(const std::vector<glm::vec3>& x, const ReferenceResult& ref) {
  double num = 0, noise = 0, den = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    const glm::dvec3 d = glm::dvec3(x[i]) - glm::dvec3(ref.radiance[i]);
    num += glm::dot(d, d);
    noise += glm::dot(glm::dvec3(ref.std_error[i]), glm::dvec3(ref.std_error[i]));
    den += glm::dot(glm::dvec3(ref.radiance[i]), glm::dvec3(ref.radiance[i]));
  }
  if (!(den > 0)) return {INFINITY, INFINITY};
  return {std::sqrt(num / den), std::sqrt(std::max(num - noise, 0.0) / den)};
}

double noise_of(const ReferenceResult& ref) {
  double noise = 0, den = 0;
  for (std::size_t i = 0; i < ref.radiance.size(); ++i) {
    noise += glm::dot(glm::dvec3(ref.std_error[i]), glm::dvec3(ref.std_error[i]));
    den += glm::dot(glm::dvec3(ref.radiance[i]), glm::dvec3(ref.radiance[i]));
  }
  return den > 0 ? std::sqrt(noise / den) : INFINITY;
}

double longest_diffusion_length(const SubsurfaceMaterial& m) {
  double l = 0;
  for (int c = 0; c < 3; ++c) l = std::max(l, 1.0 / Dipole(m.sigma_a[c], m.sigma_s[c], m.eta).sigma_tr);
  return l;
}

double mean_edge(const Mesh& m) {
  double s = 0;
  for (const glm::uvec3& t : m.triangles)
    for (int c = 0; c < 3; ++c) s += glm::length(m.positions[t[c]] - m.positions[t[(c + 1) % 3]]);
  return s / (3.0 * double(m.triangles.size()));
}

std::vector<std::uint32_t> pick_receivers(const Mesh& m, int count) {
  std::vector<std::uint32_t> usable;
  for (std::uint32_t v = 0; v < m.vertex_count(); ++v)
    if (m.normals[v] != glm::vec3(0.0f)) usable.push_back(v);
  const std::size_t k = std::max<std::size_t>(1, usable.size() / std::size_t(std::max(count, 1)));
  std::vector<std::uint32_t> r;
  for (std::size_t i = 0; i < usable.size() && r.size() < std::size_t(count); i += k) r.push_back(usable[i]);
  return r;
}

struct Material {
  std::string name;
  SubsurfaceMaterial m;
};

std::vector<Material> materials() {
  std::vector<Material> out;
  for (const char* n : {"marble", "skin1", "ketchup"}) out.push_back({n, *subsurface_preset(n)});
  SubsurfaceMaterial c;
  c.name = "";
  c.sigma_a = glm::dvec3(0.5);
  c.sigma_s = glm::dvec3(9.5);
  c.eta = 1.3;
  out.push_back({"custom 0.1 mm", c});
  return out;
}

// Everything the rows share.
struct Setup {
  Args a;
  Mesh mesh, fine, once;  // once: split one time (diagnostics)
  EnvMap env;
  std::vector<glm::dvec3> light;
  std::vector<std::uint32_t> receivers;
  double diag = 0, edge = 0;
  std::map<double, Trace> coarse, fine_rows, more_rays, once_rows;  // by eta
  const Trace& trace(std::map<double, Trace>& cache, const Mesh& m, double eta, int samples) {
    auto f = cache.find(eta);
    if (f == cache.end()) {
      std::fprintf(stderr, "tracing %zu vertices at %d rays, eta %g...\n", m.vertex_count(), samples, eta);
      f = cache.emplace(eta, trace_transmission(m, eta, a.bands, samples, a.seed)).first;
    }
    return f->second;
  }
};

struct Row {
  std::string material, scale_name;
  double scale = 0, size_mm = 0;
  Errors prt, bl;
  double noise = 0, t_prt = 0, t_bl = 0, t_ref = 0;
  // diagnostics
  Errors more_rays, every_pair, bl_every_pair, split_once, vertices_alone;
  std::size_t added = 0;  // irradiance samples between the vertices
  double zr_min = 0, zr_max = 0;
};

// Per receiver (stderr): the reference and its standard error, ours, the
// band-limited answer and the local limit R_d,total E_t(x_o) / pi (E_t the
// receiver's own transmitted irradiance, relit), per channel.
void dump_receivers(const Setup& s, const SubsurfaceMaterial& m, const Trace& coarse, const std::vector<glm::vec3>& ours,
                    const std::vector<glm::vec3>& bl, const ReferenceResult& ref) {
  const int nc = s.a.bands * s.a.bands;
  const glm::dvec3 total = subsurface_total_reflectance(m);
  for (std::size_t i = 0; i < s.receivers.size(); ++i) {
    const float* row = coarse.rows.data() + std::size_t(s.receivers[i]) * std::size_t(nc);
    std::string line = fmt::format("v {}", s.receivers[i]);
    for (int c = 0; c < 3; ++c) {
      double e = 0;
      for (int k = 0; k < nc; ++k) e += double(row[k]) * s.light[std::size_t(k)][c];
      line += fmt::format(" | ref {:.4g} +- {:.2g} ours {:.4g} bl {:.4g} local {:.4g}", ref.radiance[i][c],
                          ref.std_error[i][c], ours[i][c], bl[i][c], total[c] * e / std::numbers::pi);
    }
    std::fprintf(stderr, "%s\n", line.c_str());
  }
}

ReferenceResult reference(Setup& s, const SubsurfaceMaterial& m, double scale, TransferMode mode, double& seconds) {
  ReferenceOptions ro;
  ro.mode = mode;
  ro.bounces = mode == TransferMode::Interreflected ? 2 : 1;
  ro.samples = s.a.ref_samples;
  ro.seed = s.a.seed;
  const auto t0 = std::chrono::steady_clock::now();
  ReferenceResult r = render_subsurface_reference(s.mesh, s.env, ro, SubsurfaceRecord{m, scale}, s.receivers);
  seconds = seconds_since(t0);
  return r;
}

Row shadowed_row(Setup& s, const Material& mat, const char* scale_name, double fraction, bool check) {
  Row row;
  row.material = mat.name;
  row.scale_name = scale_name;
  row.scale = longest_diffusion_length(mat.m) / (fraction * s.diag);
  row.size_mm = row.scale * s.diag;
  const double eta = mat.m.eta, kDefault = SubsurfaceScatterOptions{}.max_solid_angle;
  const Trace& coarse = s.trace(s.coarse, s.mesh, eta, s.a.samples);
  const Trace& fine = s.trace(s.fine_rows, s.fine, eta, s.a.samples << (2 * s.a.levels));
  double t = 0;
  TransferOptions o;
  o.bands = s.a.bands;
  o.samples = s.a.samples;
  o.seed = s.a.seed;
  SubsurfaceScatterOptions so;
  so.length_scale = row.scale;
  so.added_samples = &row.added;
  const auto t0 = std::chrono::steady_clock::now();
  const Transfer whole = compute_subsurface_transfer(s.mesh, o, mat.m, so);
  const std::vector<glm::vec3> all = relight(whole, s.mesh, s.light);
  row.t_prt = seconds_since(t0);
  std::vector<glm::vec3> ours(s.receivers.size());
  for (std::size_t i = 0; i < ours.size(); ++i) ours[i] = all[s.receivers[i]];
  const auto alone = scatter_relit(s.mesh, mat.m, coarse.rows, s.a.bands, row.scale, kDefault, s.receivers, s.light, t);
  const auto bl = scatter_relit(s.fine, mat.m, fine.rows, s.a.bands, row.scale, kDefault, s.receivers, s.light, t);
  row.t_bl = fine.seconds + t;
  const ReferenceResult ref = reference(s, mat.m, row.scale, TransferMode::Shadowed, row.t_ref);
  row.prt = rel_rms(ours, ref);
  row.vertices_alone = rel_rms(alone, ref);
  row.bl = rel_rms(bl, ref);
  row.noise = noise_of(ref);
  if (s.a.dump == mat.name) dump_receivers(s, mat.m, coarse, ours, bl, ref);
  if (check) {  // the decomposition against compute_subsurface_transfer itself, without irradiance samples
    so.split_levels = 0;
    so.added_samples = nullptr;
    const std::vector<glm::vec3> plain = relight(compute_subsurface_transfer(s.mesh, o, mat.m, so), s.mesh, s.light);
    double dmax = 0, vmax = 0;
    for (std::size_t i = 0; i < s.receivers.size(); ++i) {
      dmax = std::max(dmax, double(glm::length(plain[s.receivers[i]] - alone[i])));
      vmax = std::max(vmax, double(glm::length(plain[s.receivers[i]])));
    }
    fmt::print("check: compute_subsurface_transfer without irradiance samples against the shared trace + "
               "subsurface_scatter at the receivers ({}, {}): largest difference {:.3g} of the largest value {:.3g}\n\n",
               mat.name, scale_name, dmax, vmax);
  }
  if (s.a.diagnostics) {
    const Trace& more = s.trace(s.more_rays, s.mesh, eta, 4 * s.a.samples);
    row.more_rays = rel_rms(scatter_relit(s.mesh, mat.m, more.rows, s.a.bands, row.scale, kDefault, s.receivers, s.light, t), ref);
    row.every_pair = rel_rms(scatter_relit(s.mesh, mat.m, coarse.rows, s.a.bands, row.scale, 0.0, s.receivers, s.light, t), ref);
    if (s.once.vertex_count() == 0) s.once = subdivide(s.mesh, 1);
    const Trace& once = s.trace(s.once_rows, s.once, eta, s.a.samples);
    row.split_once = rel_rms(scatter_relit(s.once, mat.m, once.rows, s.a.bands, row.scale, kDefault, s.receivers, s.light, t), ref);
    row.bl_every_pair = rel_rms(scatter_relit(s.fine, mat.m, fine.rows, s.a.bands, row.scale, 0.0, s.receivers, s.light, t), ref);
    row.zr_min = INFINITY;
    for (int c = 0; c < 3; ++c) {
      const double zr = Dipole(mat.m.sigma_a[c], mat.m.sigma_s[c], mat.m.eta).z_r;
      row.zr_min = std::min(row.zr_min, zr);
      row.zr_max = std::max(row.zr_max, zr);
    }
  }
  return row;
}

Row interreflected_row(Setup& s, const Material& mat, double fraction) {
  Row row;
  row.material = mat.name + ", interreflected (2 bounces)";
  row.scale_name = "thin";
  row.scale = longest_diffusion_length(mat.m) / (fraction * s.diag);
  row.size_mm = row.scale * s.diag;
  TransferOptions o;
  o.mode = TransferMode::Interreflected;
  o.bounces = 2;
  o.bands = s.a.bands;
  o.seed = s.a.seed;
  SubsurfaceScatterOptions so;
  so.length_scale = row.scale;
  const auto at_receivers = [&](const Mesh& m, int samples, double& seconds) {
    o.samples = samples;
    std::fprintf(stderr, "interreflected transfer of %zu vertices at %d rays...\n", m.vertex_count(), samples);
    const auto t0 = std::chrono::steady_clock::now();
    const Transfer t = compute_subsurface_transfer(m, o, mat.m, so);
    const std::vector<glm::vec3> all = relight(t, m, s.light);
    seconds = seconds_since(t0);
    std::vector<glm::vec3> r(s.receivers.size());
    for (std::size_t i = 0; i < r.size(); ++i) r[i] = all[s.receivers[i]];
    return r;
  };
  so.added_samples = &row.added;
  const auto ours = at_receivers(s.mesh, s.a.samples, row.t_prt);
  so.added_samples = nullptr;
  so.split_levels = 0;  // the band-limited answer's samples: the mesh split --levels times, everywhere
  const auto bl = at_receivers(s.fine, s.a.samples << (2 * s.a.levels), row.t_bl);
  const ReferenceResult ref = reference(s, mat.m, row.scale, TransferMode::Interreflected, row.t_ref);
  row.prt = rel_rms(ours, ref);
  row.bl = rel_rms(bl, ref);
  row.noise = noise_of(ref);
  return row;
}

void print_row(const Row& r) {
  const double bound = 1.1 * r.bl.raw + 0.01;
  fmt::print("| {} | {} | {:.4g} | {:.4g} | {:.2f}% | {:.2f}% | {:.2f}% | {} | {:.2f}% | {:.2f}% | {:.2f}% | {} | {:.1f} | {:.1f} | {:.1f} |\n",
             r.material, r.scale_name, r.scale, r.size_mm, 100 * r.prt.raw, 100 * r.bl.raw, 100 * bound,
             r.prt.raw <= bound ? "yes" : fmt::format("**no** (+{:.2f} pts)", 100 * (r.prt.raw - bound)),
             100 * r.noise, 100 * r.prt.corrected, 100 * r.bl.corrected, r.added, r.t_prt, r.t_bl, r.t_ref);
  std::fflush(stdout);
}

Args parse(int argc, char** argv) {
  Args a;
  a.mesh = argv[1];
  a.env = argv[2];
  bool quick = false;
  for (int i = 3; i < argc; ++i) {
    const std::string o = argv[i];
    const auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw Error(o + " needs a value");
      return argv[++i];
    };
    if (o == "--bands") a.bands = std::stoi(next());
    else if (o == "--samples") a.samples = std::stoi(next());
    else if (o == "--receivers") a.receivers = std::stoi(next());
    else if (o == "--ref-samples") a.ref_samples = std::stoi(next());
    else if (o == "--levels") a.levels = std::stoi(next());
    else if (o == "--seed") a.seed = std::stoull(next());
    else if (o == "--quick") quick = true;
    else if (o == "--no-diagnostics") a.diagnostics = false;
    else if (o == "--no-interreflected") a.interreflected = false;
    else if (o == "--dump") a.dump = next();
    else if (o == "--only") a.only = next();
    else throw Error("unknown option " + o);
  }
  if (quick) a.samples = 128, a.receivers = 48, a.ref_samples = 256, a.levels = 1;
  return a;
}

void print_diagnostics(const Setup& s, const std::vector<Row>& rows) {
  fmt::print("\nDiagnostics (shadowed rows): e_prt with the vertices alone as irradiance samples (split_levels 0), "
             "and that at {} rays, with every source pair (max_solid_angle 0; e_bl too) and on the mesh split once at "
             "{} rays; mean edge {:.4g} mesh units, in mm against z_r = 1/sigma_t' (smallest, largest)\n\n",
             4 * s.a.samples, s.a.samples, s.edge);
  fmt::print("| material | scale | e_prt | e_prt vertices alone | e_prt {} rays | e_prt every pair | e_prt split once | e_bl | e_bl every pair | edge mm | "
             "z_r mm |\n|---|---|---|---|---|---|---|---|---|---|---|\n",
             4 * s.a.samples);
  for (const Row& r : rows)
    fmt::print("| {} | {} | {:.2f}% | {:.2f}% | {:.2f}% | {:.2f}% | {:.2f}% | {:.2f}% | {:.2f}% | {:.3g} | {:.3g}-{:.3g} |\n", r.material,
               r.scale_name, 100 * r.prt.raw, 100 * r.vertices_alone.raw, 100 * r.more_rays.raw, 100 * r.every_pair.raw, 100 * r.split_once.raw, 100 * r.bl.raw,
               100 * r.bl_every_pair.raw, s.edge * r.scale, r.zr_min, r.zr_max);
}

int run(Setup& s) {
  const auto t0 = std::chrono::steady_clock::now();
  s.mesh = load_mesh(s.a.mesh);
  s.fine = subdivide(s.mesh, s.a.levels);
  s.env = load_envmap(s.a.env);
  s.light = project(s.env, s.a.bands);
  s.receivers = pick_receivers(s.mesh, s.a.receivers);
  s.diag = s.mesh.diagonal();
  s.edge = mean_edge(s.mesh);
  fmt::print("{} ({} vertices, {} triangles, diagonal D {:.4g}, mean edge {:.4g}); split {} times: {} vertices, "
             "{} triangles; under {} at {} bands; {} receivers; ours {} rays, band-limited {} rays; reference {} "
             "iterations\n\n",
             s.a.mesh, s.mesh.vertex_count(), s.mesh.triangles.size(), s.diag, s.edge, s.a.levels,
             s.fine.vertex_count(), s.fine.triangles.size(), s.a.env, s.a.bands, s.receivers.size(), s.a.samples,
             s.a.samples << (2 * s.a.levels), s.a.ref_samples);
  std::fflush(stdout);
  std::vector<Row> rows;
  const std::vector<Material> mats = materials();
  std::string table =
      "| material | scale | S (mm/unit) | object mm | e_prt | e_bl | 1.1 e_bl + 1% | met | ref noise | e_prt* | e_bl* "
      "| samples added | ours s | band-limited s | reference s |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  bool header = false;
  for (const Material& m : mats) {
    if (!s.a.only.empty() && s.a.only != m.name) continue;
    for (const auto& [name, fraction] : {std::pair{"few percent", 0.03}, std::pair{"thin", 0.5}}) {
      std::fprintf(stderr, "%s, %s...\n", m.name.c_str(), name);
      rows.push_back(shadowed_row(s, m, name, fraction, rows.empty()));
      if (!header) fmt::print("{}", table), header = true;
      print_row(rows.back());
    }
  }
  if (s.a.interreflected && (s.a.only.empty() || s.a.only == mats[1].name)) print_row(interreflected_row(s, mats[1], 0.5));
  fmt::print("\nTraces (shared by the rows of one eta): ");
  for (const auto& [eta, t] : s.coarse) fmt::print("ours eta {} {:.1f} s; ", eta, t.seconds);
  for (const auto& [eta, t] : s.fine_rows) fmt::print("band-limited eta {} {:.1f} s; ", eta, t.seconds);
  fmt::print("\n");
  if (s.a.diagnostics) print_diagnostics(s, rows);
  fmt::print("\ntotal {:.1f} s\n", seconds_since(t0));
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: prt_subsurface_figures MESH ENV [--bands 5] [--samples 1024] [--receivers 200] "
                 "[--ref-samples 4096] [--levels 2] [--seed 1] [--quick] [--no-diagnostics] [--no-interreflected] [--dump MATERIAL] "
                 "[--only MATERIAL]\n");
    return 2;
  }
  try {
    Setup s;
    s.a = parse(argc, argv);
    return run(s);
  } catch (const std::exception& x) {
    std::fprintf(stderr, "prt_subsurface_figures: %s\n", x.what());
    return 1;
  }
}
