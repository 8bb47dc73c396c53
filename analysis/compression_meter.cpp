// The relit error of a compression over a distribution of lightings and
// views (prt/compression_error.h, docs/COMPRESSION.md "The error
// distribution").
//
// Diffuse radiance is linear in the lighting, so its squared error under a
// lighting l is l^T G l with G = sum_v d_v d_v^T (d_v a vertex's row
// difference, per channel): one Gram matrix per compression, then every
// lighting costs bands^4 operations, over all vertices. Glossy radiance
// y_v^T M_v l depends on the vertex through its lobe y_v, so each measured
// vertex costs two small matrix products per compression: U = dM_v L (every
// lighting at once) and Y_v U (every eye and exponent at once); the
// specular strength rho enters as err^2 = A + 2 rho B + rho^2 C, so it costs
// nothing.
#include <prt/compression_error.h>

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/paths.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <numeric>

namespace prt {

namespace {

using Mat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
double uniform(std::uint64_t& s) { return (double(splitmix64(s) >> 11) + 0.5) * 0x1.0p-53; }

// A uniformly random rotation (Shoemake's unit quaternion from 3 uniforms).
glm::dmat3 random_rotation(std::uint64_t& s) {
  const double u1 = uniform(s), u2 = 2 * M_PI * uniform(s), u3 = 2 * M_PI * uniform(s);
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const double w = a * std::sin(u2), x = a * std::cos(u2), y = b * std::sin(u3), z = b * std::cos(u3);
  // Column-major glm: m[col][row].
  glm::dmat3 m;
  m[0] = {1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)};
  m[1] = {2 * (x * y - w * z), 1 - 2 * (x * x + z * z), 2 * (y * z + w * x)};
  m[2] = {2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)};
  return m;
}

// Per-sample relative errors -> the statistics.
ErrorStats statistics(std::vector<double> err2, const std::vector<double>& ref2, std::size_t vertices) {
  ErrorStats s;
  s.vertices = vertices;
  double sum_e = 0, sum_r = 0;
  std::vector<double> rel;
  rel.reserve(err2.size());
  for (std::size_t i = 0; i < err2.size(); ++i) {
    sum_e += err2[i];
    sum_r += ref2[i];
    rel.push_back(ref2[i] > 0 ? std::sqrt(std::max(err2[i], 0.0) / ref2[i]) : 0.0);
  }
  s.samples = rel.size();
  if (rel.empty()) return s;
  s.pooled = sum_r > 0 ? std::sqrt(std::max(sum_e, 0.0) / sum_r) : 0.0;
  s.mean = std::accumulate(rel.begin(), rel.end(), 0.0) / double(rel.size());
  std::sort(rel.begin(), rel.end());
  // Nearest rank: the smallest value at or above 95% of the samples.
  const std::size_t rank = std::size_t(std::ceil(0.95 * double(rel.size())));
  s.p95 = rel[std::max<std::size_t>(rank, 1) - 1];
  s.max = rel.back();
  return s;
}

// sqrt of the largest generalised eigenvalue of (G, B), B made definite by a
// ridge of 1e-12 of its mean diagonal (rounding: a direction no vertex
// responds to must not read as an infinite ratio of two roundings).
double largest_ratio(const Mat& G, const Mat& B) {
  const Eigen::Index n = B.rows();
  if (n == 0) return 0.0;
  Mat Br = B;
  const double ridge = 1e-12 * std::max(B.trace() / double(n), 1e-300);
  for (Eigen::Index i = 0; i < n; ++i) Br(i, i) += ridge;
  Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> es(Eigen::MatrixXd(G), Eigen::MatrixXd(Br),
                                                               Eigen::EigenvaluesOnly);
  if (es.info() != Eigen::Success) throw Error("compression error: the bound's eigensolver failed");
  return std::sqrt(std::max(es.eigenvalues().maxCoeff(), 0.0));
}

}  // namespace

namespace {

std::vector<std::string> bundled_maps() {
  const std::filesystem::path dir = data_dir() / "envmaps";
  std::vector<std::string> paths;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.path().extension() == ".exr") paths.push_back(e.path().string());
  std::sort(paths.begin(), paths.end());
  if (paths.empty())
    throw Error(dir.string() + ": no bundled maps to measure the error under (PRT_DATA_DIR); give the maps");
  return paths;
}

std::vector<NamedLighting> load_lightings(const std::vector<std::string>& paths, int bands) {
  std::vector<NamedLighting> out;
  for (const auto& path : paths) {
    const EnvMap env = load_envmap(path);
    require_finite(env);
    out.push_back({std::filesystem::path(path).stem().string(), project(env, bands)});
  }
  return out;
}

}  // namespace

namespace {

// The counts of a distribution, before any map is read or lighting made.
void check_counts(int rotations, int eyes) {
  if (rotations < 1 || rotations > kMaxErrorRotations)
    throw Error(fmt::format("--rotations must be 1 to {}, got {}", kMaxErrorRotations, rotations));
  if (eyes < 1 || eyes > kMaxErrorEyes) throw Error(fmt::format("--eyes must be 1 to {}, got {}", kMaxErrorEyes, eyes));
}

}  // namespace

ErrorDistribution make_error_distribution(const DistributionSpec& spec, int bands) {
  check_counts(spec.rotations, spec.eyes);
  ErrorDistribution d;
  const std::vector<std::string> maps = spec.maps.empty() ? bundled_maps() : spec.maps;
  d.maps = load_lightings(maps, bands);
  if (!spec.spectra.empty()) {
    d.spectra = load_lightings(spec.spectra, bands);
  } else if (!spec.own_spectra) {
    const std::vector<std::string> bundled = bundled_maps();
    d.spectra = bundled == maps ? d.maps : load_lightings(bundled, bands);
  }
  d.sun = spec.sun;
  d.rotations = spec.rotations;
  d.eyes = spec.eyes;
  return d;
}

std::string ErrorDistribution::describe(bool glossy) const {
  const auto names = [](const std::vector<NamedLighting>& v) {
    std::string n;
    for (const NamedLighting& m : v) n += (n.empty() ? "" : ", ") + m.name;
    return n;
  };
  std::string s = fmt::format("{} map{} ({}) x {} rotation{}", maps.size(), maps.size() == 1 ? "" : "s", names(maps),
                              rotations, rotations == 1 ? "" : "s");
  if (!spectra.empty()) s += fmt::format(" taking their own spectra and those of {} in turn", names(spectra));
  if (sun) s += fmt::format(", and a point light (the sun) x {} rotation{}", rotations, rotations == 1 ? "" : "s");
  if (glossy) {
    std::string g, r;
    for (double e : glosses) g += (g.empty() ? "" : ", ") + fmt::format("{:g}", e);
    for (double e : speculars) r += (r.empty() ? "" : ", ") + fmt::format("{:g}", e);
    s += fmt::format("; {} eyes on a sphere, exponents {}, specular {}", eyes, g, r);
  }
  return s;
}

std::vector<double> band_spectrum(std::span<const glm::dvec3> sh, int bands) {
  if (bands < 1 || sh.size() < std::size_t(bands) * bands)
    throw Error(fmt::format("band_spectrum: {} coefficients, {} bands need {}", sh.size(), bands,
                            std::size_t(std::max(bands, 0)) * std::max(bands, 0)));
  std::vector<double> norm(bands, 0.0);
  for (int l = 0; l < bands; ++l)
    for (int i = l * l; i < (l + 1) * (l + 1); ++i) norm[l] += glm::dot(sh[i], sh[i]);
  const double n0 = std::sqrt(norm[0]);
  for (double& n : norm) n = n0 > 0 ? std::sqrt(n) / n0 : 0.0;
  return norm;
}

std::vector<std::vector<glm::dvec3>> distribution_lightings(const ErrorDistribution& d, int bands) {
  if (d.maps.empty()) throw Error("compression error: no lighting to measure it under");
  check_counts(d.rotations, d.eyes);
  const std::size_t nc = std::size_t(bands) * bands;
  const auto check_bands = [&](const NamedLighting& m) {
    if (m.sh.size() < nc)
      throw Error(fmt::format("compression error: {} has {} bands of lighting, the transfer needs {}", m.name,
                              sh::bands_of(m.sh.size()), bands));
  };
  // A band the map lacks (norm below this fraction of band 0's) is left as
  // it is: scaling it would be scaling rounding noise.
  constexpr double kAbsentBand = 1e-6;
  std::vector<std::vector<glm::dvec3>> out;
  std::uint64_t state = d.seed;
  sh::Rotation rot(bands, glm::dmat3(1.0));
  // `in` as it is, then under rotations - 1 random rotations, rotation r
  // with its bands scaled by scales[(r - 1) mod size].
  const auto add_rotations = [&](std::span<const glm::dvec3> in, const std::vector<std::vector<double>>& scales) {
    out.emplace_back(in.begin(), in.end());
    for (int r = 1; r < d.rotations; ++r) {
      rot.set(random_rotation(state));
      std::vector<glm::dvec3> o(nc);
      rot.apply(in, o);
      const std::vector<double>& k = scales[std::size_t(r - 1) % scales.size()];
      for (int l = 1; l < bands; ++l)
        for (int i = l * l; i < (l + 1) * (l + 1); ++i) o[i] *= k[l];
      out.push_back(std::move(o));
    }
  };
  const std::vector<std::vector<double>> own_only{std::vector<double>(bands, 1.0)};
  for (const NamedLighting& m : d.maps) {
    check_bands(m);
    const std::span<const glm::dvec3> in(m.sh.data(), nc);
    const std::vector<double> own = band_spectrum(in, bands);
    // Per spectrum in turn: the scale of each band (the first: the map's own).
    std::vector<std::vector<double>> scales = own_only;
    for (const NamedLighting& s : d.spectra) {
      check_bands(s);
      if (s.name == m.name) continue;
      const std::vector<double> to = band_spectrum(s.sh, bands);
      std::vector<double> k(bands, 1.0);
      for (int l = 1; l < bands; ++l)
        if (own[l] > kAbsentBand) k[l] = to[l] / own[l];
      scales.push_back(std::move(k));
    }
    add_rotations(in, scales);
  }
  if (d.sun) {
    // A unit delta overhead: its SH coefficients are the basis there.
    std::vector<double> y(nc);
    sh::eval(bands, 0.0, 1.0, 0.0, y.data());
    std::vector<glm::dvec3> up(nc);
    for (std::size_t i = 0; i < nc; ++i) up[i] = glm::dvec3(y[i]);
    add_rotations(up, own_only);
  }
  return out;
}

std::vector<glm::dvec3> eye_sphere(const Mesh& mesh, int count) {
  if (count < 1) throw Error(fmt::format("eye_sphere: at least 1 eye, got {}", count));
  // eye_ring's centre and distance: its first eye is centre + d (0, 0, 1).
  const glm::dvec3 first = eye_ring(mesh, 1)[0];
  glm::dvec3 lo(mesh.positions.at(0)), hi = lo;
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const glm::dvec3 c = 0.5 * (lo + hi);
  const double d = glm::length(first - c);
  std::vector<glm::dvec3> eyes;
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double y = 1.0 - (2.0 * i + 1.0) / count;  // cell centres in y: no eye on a pole
    const double r = std::sqrt(std::max(0.0, 1.0 - y * y)), a = golden * i;
    eyes.push_back(c + d * glm::dvec3(r * std::sin(a), y, r * std::cos(a)));
  }
  return eyes;
}

const char* statistic_name(ErrorStatistic s) { return s == ErrorStatistic::Mean ? "mean" : "p95"; }

struct CompressionErrorMeter::Impl {
  const Transfer& t;
  int nc = 0, ch = 1, gch = 0;
  std::size_t stride = 0, gstride = 0;
  std::vector<float> dense;    // every vertex's diffuse row (analytic ones evaluated)
  std::vector<std::vector<glm::dvec3>> lights;
  Mat L;                       // nc x (3 lights): column 3k + c = light k, channel c
  std::vector<Mat> ref_gram;   // per diffuse channel: sum over all vertices of x x^T
  // Glossy:
  std::vector<glm::dvec3> eyes;
  std::vector<double> glosses, speculars;
  std::vector<std::size_t> verts;  // measured vertices
  std::vector<Mat> Y;              // per measured vertex: (eyes x glosses) x nc lobes (zero rows: below the horizon)
  std::vector<double> ref_abc;     // per (view, light): the reference's A, B, C
  std::size_t views = 0;
  // Bound (glossy): per (gloss, channel) the reference's three matrices.
  std::vector<Mat> ref_bound;

  Impl(const Transfer& tr) : t(tr) {}

  // Vertex v's diffuse rows (ch x nc) and glossy matrices (gch x nc x nc):
  // the differences of a compression (reconstructed rows) or the rows.
  void rows(std::size_t v, const ClusteredSignal* cs, const ClusteredSignal* gs, const Mesh& on, Mat& x,
            std::vector<Mat>* m, std::vector<float>& buf) const {
    const std::uint32_t slot = t.slots.empty() ? std::uint32_t(v) : t.slots[v];
    const bool stored = slot != Transfer::kAnalytic;
    x.setZero(ch, nc);
    if (!gs) {  // the reference
      const float* d = dense.data() + v * stride;
      for (int c = 0; c < ch; ++c)
        for (int k = 0; k < nc; ++k) x(c, k) = d[std::size_t(c) * nc + std::size_t(k)];
    } else if (stored && cs) {
      buf.resize(stride);
      cs->reconstruct(slot, buf.data());
      const float* row = t.coeffs.data() + std::size_t(slot) * stride;
      for (int c = 0; c < ch; ++c)
        for (int k = 0; k < nc; ++k) {
          const std::size_t i = std::size_t(c) * nc + std::size_t(k);
          x(c, k) = double(row[i]) - double(buf[i]);
        }
    }
    if (!m) return;
    m->assign(std::size_t(gch), Mat::Zero(nc, nc));
    if (!gs) {
      for (int c = 0; c < gch; ++c) {
        const std::vector<double> M = vertex_glossy_matrix(t, on, v, c);
        (*m)[std::size_t(c)] = Eigen::Map<const Mat>(M.data(), nc, nc);
      }
      return;
    }
    if (!stored) return;
    buf.resize(gstride);
    gs->reconstruct(slot, buf.data());
    const float* row = t.glossy_matrices.data() + std::size_t(slot) * gstride;
    if (t.glossy_symmetric()) {
      Mat& M = (*m)[0];
      std::size_t k = 0;
      for (int p = 0; p < nc; ++p)
        for (int q = p; q < nc; ++q, ++k) M(p, q) = M(q, p) = double(row[k]) - double(buf[k]);
    } else {
      for (int c = 0; c < gch; ++c)
        for (int i = 0; i < nc * nc; ++i) {
          const std::size_t k = std::size_t(c) * nc * nc + std::size_t(i);
          (*m)[std::size_t(c)](i / nc, i % nc) = double(row[k]) - double(buf[k]);
        }
    }
  }

  // Diffuse per-channel Gram of a compression's differences (all stored rows).
  std::vector<Mat> diff_gram(const ClusteredSignal& cs) const {
    const std::size_t rows = t.stored_vertices();
    constexpr std::size_t kBlock = 1024;
    const std::size_t blocks = (rows + kBlock - 1) / kBlock;
    std::vector<std::vector<Mat>> part(blocks);
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
      std::vector<float> buf(stride);
      const std::size_t r0 = b * kBlock, r1 = std::min(rows, r0 + kBlock);
      std::vector<Mat> D(std::size_t(ch), Mat(Eigen::Index(r1 - r0), nc));
      for (std::size_t r = r0; r < r1; ++r) {
        cs.reconstruct(r, buf.data());
        const float* row = t.coeffs.data() + r * stride;
        for (int c = 0; c < ch; ++c)
          for (int k = 0; k < nc; ++k) {
            const std::size_t i = std::size_t(c) * nc + std::size_t(k);
            D[std::size_t(c)](Eigen::Index(r - r0), k) = double(row[i]) - double(buf[i]);
          }
      }
      std::vector<Mat> g(static_cast<std::size_t>(ch), Mat());
      for (int c = 0; c < ch; ++c) g[std::size_t(c)].noalias() = D[std::size_t(c)].transpose() * D[std::size_t(c)];
      part[b] = std::move(g);
    });
    std::vector<Mat> g(std::size_t(ch), Mat::Zero(nc, nc));
    for (const auto& p : part)  // block order: the same sums on any number of threads
      for (int c = 0; c < ch; ++c) g[std::size_t(c)] += p[std::size_t(c)];
    return g;
  }

  // Per light, the squared error (or reference) of the diffuse radiance.
  std::vector<double> light_squares(const std::vector<Mat>& gram) const {
    std::vector<double> out(lights.size(), 0.0);
    for (std::size_t k = 0; k < lights.size(); ++k)
      for (int c = 0; c < 3; ++c) {
        const auto l = L.col(Eigen::Index(3 * k + std::size_t(c)));
        out[k] += l.dot(gram[std::size_t(ch == 3 ? c : 0)] * l);
      }
    return out;
  }

  // Glossy: per (view, light) A, B, C summed over the measured vertices, for
  // the differences of a compression (gs, and cs, or no diffuse difference
  // when cs is null) or the reference (gs null); with
  // bound: per (gloss, channel) the three matrices of the pooled bound.
  void glossy_sums(const Mesh& on, const ClusteredSignal* cs, const ClusteredSignal* gs, std::vector<double>& abc,
                   std::vector<Mat>* bound) const {
    const std::size_t nl = lights.size(), ng = glosses.size();
    const std::size_t blocks = std::min<std::size_t>(64, verts.size());
    std::vector<std::vector<double>> part(blocks);
    std::vector<std::vector<Mat>> bpart(blocks);
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
      std::vector<double> acc(views * nl * 3, 0.0);
      std::vector<Mat> bacc;
      if (bound) bacc.assign(ng * 3 * 3, Mat::Zero(nc, nc));
      Mat x, U, G, D;
      std::vector<Mat> m;
      std::vector<float> buf;
      const std::size_t i0 = verts.size() * b / blocks, i1 = verts.size() * (b + 1) / blocks;
      for (std::size_t i = i0; i < i1; ++i) {
        const std::size_t v = verts[i];
        if (gs) {
          const std::uint32_t slot = t.slots.empty() ? std::uint32_t(v) : t.slots[v];
          if (slot == Transfer::kAnalytic) continue;  // exact: no difference
        }
        rows(v, cs, gs, on, x, &m, buf);
        D.noalias() = x * L;  // ch x 3 nl: diffuse radiance per channel row
        for (int c = 0; c < 3; ++c) {
          const bool bound_channel = bound && (c == 0 || ch == 3 || gch == 3);
          const Mat& M = m[std::size_t(gch == 3 ? c : 0)];
          if (c == 0 || gch == 3) U.noalias() = M * L;  // nc x 3 nl
          G.noalias() = Y[i] * U;                       // views x 3 nl
          const auto d = D.row(ch == 3 ? c : 0);
          for (std::size_t w = 0; w < views; ++w)
            for (std::size_t k = 0; k < nl; ++k) {
              const double dd = d(Eigen::Index(3 * k + std::size_t(c))), g = G(Eigen::Index(w), Eigen::Index(3 * k + std::size_t(c)));
              double* a = acc.data() + (w * nl + k) * 3;
              a[0] += dd * dd;
              a[1] += dd * g;
              a[2] += g * g;
            }
          if (bound_channel) {
            // Pooled over the eyes: w = x_c + rho M^T y per eye and exponent
            // (y = 0 below the horizon: the diffuse part alone).
            const Eigen::RowVectorXd xc = x.row(ch == 3 ? c : 0);
            const Mat xx = double(eyes.size()) * (xc.transpose() * xc);
            for (std::size_t j = 0; j < ng; ++j) {
              Mat* o = bacc.data() + (j * 3 + std::size_t(c)) * 3;
              o[0] += xx;
              for (std::size_t e = 0; e < eyes.size(); ++e) {
                const Eigen::RowVectorXd y = Y[i].row(Eigen::Index(e * ng + j));
                if (y.squaredNorm() == 0) continue;
                const Eigen::RowVectorXd g = y * M;  // (M^T y)^T
                o[1].noalias() += xc.transpose() * g + g.transpose() * xc;
                o[2].noalias() += g.transpose() * g;
              }
            }
          }
        }
      }
      part[b] = std::move(acc);
      if (bound) bpart[b] = std::move(bacc);
    });
    abc.assign(views * nl * 3, 0.0);
    for (const auto& p : part)
      for (std::size_t i = 0; i < abc.size(); ++i) abc[i] += p[i];
    if (bound) {
      bound->assign(ng * 3 * 3, Mat::Zero(nc, nc));
      for (const auto& p : bpart)
        for (std::size_t i = 0; i < bound->size(); ++i) (*bound)[i] += p[i];
    }
  }

  const Mesh* mesh = nullptr;

  // The samples' statistics: the whole radiance at each strength, or (cs
  // null) the glossy part alone.
  ErrorStats glossy_stats(const ClusteredSignal* cs, const ClusteredSignal& gl, bool bound) const {
    if (!t.glossy) throw Error("compression error: the transfer has no glossy matrices");
    std::vector<double> abc;
    std::vector<Mat> b;
    glossy_sums(*mesh, cs, &gl, abc, bound ? &b : nullptr);
    const std::size_t nl = lights.size();
    std::vector<double> e2, r2;
    const std::vector<double> strengths = cs ? speculars : std::vector<double>{};
    for (std::size_t w = 0; w < views; ++w)
      for (std::size_t k = 0; k < nl; ++k) {
        const double* a = abc.data() + (w * nl + k) * 3;
        const double* r = ref_abc.data() + (w * nl + k) * 3;
        if (!cs) {  // the glossy part alone (no sample where the eye sees nothing of it)
          if (r[2] > 0) e2.push_back(a[2]), r2.push_back(r[2]);
          continue;
        }
        for (double rho : strengths) {
          e2.push_back(a[0] + 2 * rho * a[1] + rho * rho * a[2]);
          r2.push_back(r[0] + 2 * rho * r[1] + rho * rho * r[2]);
        }
      }
    ErrorStats s = statistics(std::move(e2), r2, verts.size());
    if (bound)
      for (std::size_t j = 0; j < glosses.size(); ++j)
        for (int c = 0; c < ((ch == 3 || gch == 3) ? 3 : 1); ++c) {
          const Mat* e = b.data() + (j * 3 + std::size_t(c)) * 3;
          const Mat* r = ref_bound.data() + (j * 3 + std::size_t(c)) * 3;
          if (!cs) {
            s.bound = std::max(s.bound, largest_ratio(e[2], r[2]));
            continue;
          }
          for (double rho : speculars)
            s.bound = std::max(s.bound, largest_ratio(e[0] + rho * e[1] + rho * rho * e[2], r[0] + rho * r[1] + rho * rho * r[2]));
        }
    return s;
  }
};

CompressionErrorMeter::CompressionErrorMeter(const Transfer& t, const Mesh& mesh, const ErrorDistribution& d,
                                             std::size_t max_vertices)
    : impl_(std::make_unique<Impl>(t)) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error("compression error: " + p);
  if (mesh.vertex_count() != t.vertices)
    throw Error(fmt::format("compression error: the mesh has {} vertices, the transfer {}", mesh.vertex_count(), t.vertices));
  Impl& m = *impl_;
  m.mesh = &mesh;
  m.nc = t.bands * t.bands;
  m.ch = t.channels;
  m.stride = t.stride();
  m.lights = distribution_lightings(d, t.bands);
  const std::size_t nl = m.lights.size();
  m.L.setZero(m.nc, Eigen::Index(3 * nl));
  for (std::size_t k = 0; k < nl; ++k)
    for (int i = 0; i < m.nc; ++i)
      for (int c = 0; c < 3; ++c) m.L(i, Eigen::Index(3 * k + std::size_t(c))) = m.lights[k][std::size_t(i)][c];
  // The reference Gram over every vertex (analytic ones included).
  m.dense = dense_transfer(t, mesh);
  {
    const std::vector<float>& dense = m.dense;
    m.ref_gram.assign(std::size_t(m.ch), Mat::Zero(m.nc, m.nc));
    Mat X(Eigen::Index(t.vertices), m.nc);
    for (int c = 0; c < m.ch; ++c) {
      for (std::size_t v = 0; v < t.vertices; ++v)
        for (int k = 0; k < m.nc; ++k) X(Eigen::Index(v), k) = dense[v * m.stride + std::size_t(c) * m.nc + std::size_t(k)];
      m.ref_gram[std::size_t(c)].noalias() = X.transpose() * X;
    }
  }
  if (!t.glossy) return;
  if (d.eyes < 1 || d.glosses.empty() || d.speculars.empty())
    throw Error("compression error: a glossy transfer needs eyes, exponents and specular strengths");
  for (double e : d.glosses)
    if (!(e >= 0 && e <= glossy::kMaxGloss)) throw Error(fmt::format("compression error: exponent {:g} out of range", e));
  for (double r : d.speculars)
    if (!(r >= 0 && r <= 1)) throw Error(fmt::format("compression error: specular strength {:g} out of [0, 1]", r));
  m.gch = t.glossy_channels();
  m.gstride = t.glossy_stride();
  m.eyes = eye_sphere(mesh, d.eyes);
  m.glosses = d.glosses;
  m.speculars = d.speculars;
  m.views = m.eyes.size() * m.glosses.size();
  // The measured vertices: all, or a fixed random subset (sorted).
  std::vector<std::size_t> all(t.vertices);
  std::iota(all.begin(), all.end(), std::size_t(0));
  if (max_vertices > 0 && max_vertices < all.size()) {
    std::uint64_t s = 0x5eed;
    for (std::size_t i = 0; i < max_vertices; ++i)
      std::swap(all[i], all[i + std::size_t(splitmix64(s) % (all.size() - i))]);
    all.resize(max_vertices);
    std::sort(all.begin(), all.end());
  }
  m.verts = std::move(all);
  std::vector<std::vector<double>> lambda;
  for (double e : m.glosses) lambda.push_back(glossy::phong_lobe_factors(e, t.bands));
  m.Y.assign(m.verts.size(), Mat());
  tbb::parallel_for(std::size_t(0), m.verts.size(), [&](std::size_t i) {
    const std::size_t v = m.verts[i];
    Mat& Yv = m.Y[i];
    Yv.setZero(Eigen::Index(m.views), m.nc);
    const glm::vec3 nf = mesh.normals[v];
    if (nf == glm::vec3(0.0f)) return;
    const glm::dvec3 n = glm::normalize(glm::dvec3(nf));
    std::vector<double> y(std::size_t(m.nc));
    for (std::size_t e = 0; e < m.eyes.size(); ++e) {
      const auto r = glossy::mirror_direction(n, glm::dvec3(mesh.positions[v]), m.eyes[e]);
      if (!r) continue;
      sh::eval<double>(t.bands, r->x, r->y, r->z, y.data());
      for (std::size_t j = 0; j < m.glosses.size(); ++j)
        for (int l = 0; l < t.bands; ++l)
          for (int mm = -l; mm <= l; ++mm) {
            const int k = sh::index(l, mm);
            Yv(Eigen::Index(e * m.glosses.size() + j), k) = y[std::size_t(k)] * lambda[j][std::size_t(l)];
          }
    }
  });
  m.glossy_sums(mesh, nullptr, nullptr, m.ref_abc, &m.ref_bound);
}

CompressionErrorMeter::~CompressionErrorMeter() = default;
CompressionErrorMeter::CompressionErrorMeter(CompressionErrorMeter&&) noexcept = default;

std::size_t CompressionErrorMeter::vertices() const {
  return impl_->t.glossy ? impl_->verts.size() : impl_->t.vertices;
}

ErrorStats CompressionErrorMeter::diffuse(const ClusteredSignal& coeffs, bool bound) const {
  const Impl& m = *impl_;
  const std::vector<Mat> g = m.diff_gram(coeffs);
  ErrorStats s = statistics(m.light_squares(g), m.light_squares(m.ref_gram), m.t.vertices);
  if (bound)
    for (int c = 0; c < m.ch; ++c) s.bound = std::max(s.bound, largest_ratio(g[std::size_t(c)], m.ref_gram[std::size_t(c)]));
  return s;
}

ErrorStats CompressionErrorMeter::glossy(const ClusteredSignal& coeffs, const ClusteredSignal& gl, bool bound) const {
  return impl_->glossy_stats(&coeffs, gl, bound);
}

ErrorStats CompressionErrorMeter::glossy_part(const ClusteredSignal& gl, bool bound) const {
  return impl_->glossy_stats(nullptr, gl, bound);
}

ErrorStats CompressionErrorMeter::operator()(const CompressedTransfer& c, bool bound) const {
  return impl_->t.glossy ? glossy(c.coeffs, c.glossy, bound) : diffuse(c.coeffs, bound);
}

}  // namespace prt
