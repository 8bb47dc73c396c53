// Error of per-vertex results against a reference on a sample of vertices
// (prt/accuracy.h).
#include <prt/accuracy.h>

#include <prt/compare.h>
#include <prt/error.h>
#include <prt/hash.h>
#include <prt/io.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <random>
#include <span>

namespace prt {

namespace {

constexpr char kMagic[4] = {'P', 'R', 'T', 'E'};
constexpr std::uint32_t kVersion = 1;

double sum_sq(std::span<const glm::vec3> v) {
  double s = 0;
  for (const glm::vec3& x : v) s += glm::dot(glm::dvec3(x), glm::dvec3(x));
  return s;
}

// A vector's length, then its elements.
template <class T>
void add_vector(Hasher& h, const std::vector<T>& v) {
  h.add_value(v.size());
  h.add_span(std::span<const T>(v));
}

}  // namespace

double ErrorSet::noise_floor() const {
  const double ref = sum_sq(radiance);
  return ref > 0 ? std::sqrt(sum_sq(std_error) / ref) : 0.0;
}

std::vector<std::uint32_t> choose_error_vertices(const Mesh& mesh, std::size_t count, std::uint64_t seed) {
  std::vector<std::uint32_t> usable;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
    if (glm::dot(mesh.normals[v], mesh.normals[v]) > 0) usable.push_back(std::uint32_t(v));
  if (count < usable.size()) {
    // Partial Fisher-Yates with a fixed generator: the same choice on every
    // platform (std::shuffle's algorithm is implementation-defined).
    std::mt19937_64 rng(seed);
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t j = i + std::size_t(rng() % (usable.size() - i));
      std::swap(usable[i], usable[j]);
    }
    usable.resize(count);
    std::sort(usable.begin(), usable.end());
  }
  return usable;
}

ErrorSet whole_error_set(std::vector<glm::vec3> radiance, std::vector<glm::vec3> std_error) {
  if (radiance.size() != std_error.size())
    throw Error(fmt::format("error set: {} values but {} standard errors", radiance.size(), std_error.size()));
  ErrorSet set;
  set.mesh_vertices = radiance.size();
  set.vertices.resize(radiance.size());
  std::iota(set.vertices.begin(), set.vertices.end(), 0u);
  set.radiance = std::move(radiance);
  set.std_error = std::move(std_error);
  return set;
}

ErrorSet make_error_set(const Mesh& mesh, const EnvMap& map, const ErrorSetOptions& options,
                        const Progress& progress) {
  if (options.vertices == 0) throw Error("error set: at least one vertex is needed");
  const auto t0 = std::chrono::steady_clock::now();
  ErrorSet set;
  set.mesh_vertices = mesh.vertex_count();
  set.vertices = choose_error_vertices(mesh, options.vertices, options.seed);
  if (set.vertices.empty()) throw Error("error set: the mesh has no vertex with a normal");
  ReferenceResult r = render_reference(mesh, map, options.reference, set.vertices, progress);
  set.radiance = std::move(r.radiance);
  set.std_error = std::move(r.std_error);
  set.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return set;
}

Accuracy measure_accuracy(const ErrorSet& set, std::span<const glm::vec3> radiance) {
  if (radiance.size() != set.mesh_vertices)
    throw Error(fmt::format("accuracy: the result has {} vertices, the reference's mesh {}", radiance.size(),
                            set.mesh_vertices));
  std::vector<glm::vec3> a(set.vertices.size());
  for (std::size_t i = 0; i < a.size(); ++i) a[i] = radiance[set.vertices[i]];
  const CompareResult c = compare_vertices(a, set.radiance);
  Accuracy acc;
  const double ref = sum_sq(set.radiance);
  double err = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const glm::dvec3 d = glm::dvec3(a[i]) - glm::dvec3(set.radiance[i]);
    err += glm::dot(d, d);
  }
  const double noise = sum_sq(set.std_error);
  if (ref > 0) {
    acc.rel_rms_raw = std::sqrt(err / ref);
    acc.rel_rms = std::sqrt(std::max(0.0, err - noise) / ref);
    acc.noise_floor = std::sqrt(noise / ref);
  } else {
    acc.rel_rms_raw = acc.rel_rms = err > 0 ? INFINITY : 0.0;
  }
  acc.p99_rel = c.p99_rel;
  return acc;
}

std::string error_set_key(const Mesh& mesh, const EnvMap& map, const ErrorSetOptions& options) {
  Hasher h;
  h.add_value(kVersion);
  add_vector(h, mesh.positions);
  add_vector(h, mesh.triangles);
  add_vector(h, mesh.normals);
  add_vector(h, mesh.colors);
  h.add_value(map.layout);
  h.add_value(map.width);
  h.add_value(map.height);
  add_vector(h, map.rgb);
  const ReferenceOptions& r = options.reference;
  h.add_value(r.mode);
  h.add_value(r.bounces);
  h.add_value(r.albedo);
  h.add_value(r.vertex_colors);
  h.add_value(r.samples);
  h.add_value(r.seed);
  h.add_value(r.offset);
  h.add_value(r.rotation);
  if (r.glossy) {  // (absent for diffuse sets, whose keys stay those of earlier prts)
    h.add_value(r.glossy);
    h.add_value(r.eye);
    h.add_value(r.gloss);
    h.add_value(r.specular);
  }
  h.add_value(options.vertices);
  h.add_value(options.seed);
  return fmt::format("{:016x}", h.digest());
}

void write_error_set(const std::string& path, const std::string& key, const ErrorSet& set) {
  if (key.size() != 16) throw Error("error set: bad key '" + key + "'");
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) throw Error("cannot write " + tmp);
    const std::uint64_t mesh_vertices = set.mesh_vertices, n = set.vertices.size();
    out.write(kMagic, 4);
    out.write(reinterpret_cast<const char*>(&kVersion), 4);
    out.write(key.data(), 16);
    out.write(reinterpret_cast<const char*>(&mesh_vertices), 8);
    out.write(reinterpret_cast<const char*>(&n), 8);
    out.write(reinterpret_cast<const char*>(set.vertices.data()), std::streamsize(n * 4));
    out.write(reinterpret_cast<const char*>(set.radiance.data()), std::streamsize(n * 12));
    out.write(reinterpret_cast<const char*>(set.std_error.data()), std::streamsize(n * 12));
    if (!out.flush()) throw Error("cannot write " + tmp);
  });
}

std::optional<ErrorSet> read_error_set(const std::string& path, const std::string& key) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::nullopt;
  check_input_file(path, "a cached reference");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the cached reference");
  const auto fail = [&](const std::string& what) { return Error(path + ": cached reference " + what); };
  char magic[4];
  std::uint32_t version = 0;
  char file_key[16];
  std::uint64_t mesh_vertices = 0, n = 0;
  in.read(magic, 4);
  in.read(reinterpret_cast<char*>(&version), 4);
  in.read(file_key, 16);
  in.read(reinterpret_cast<char*>(&mesh_vertices), 8);
  in.read(reinterpret_cast<char*>(&n), 8);
  if (!in) throw fail("is truncated (header)");
  if (std::memcmp(magic, kMagic, 4) != 0) throw fail("is not a prt error-set file");
  if (version != kVersion) throw fail(fmt::format("has version {}", version));
  if (std::string(file_key, 16) != key) throw fail("was made for other inputs (key mismatch)");
  const auto size = std::filesystem::file_size(path, ec);
  if (ec || n == 0 || n > mesh_vertices || size != 40 + n * 28) throw fail("has a bad size or count");
  ErrorSet set;
  set.mesh_vertices = mesh_vertices;
  set.vertices.resize(n);
  set.radiance.resize(n);
  set.std_error.resize(n);
  in.read(reinterpret_cast<char*>(set.vertices.data()), std::streamsize(n * 4));
  in.read(reinterpret_cast<char*>(set.radiance.data()), std::streamsize(n * 12));
  in.read(reinterpret_cast<char*>(set.std_error.data()), std::streamsize(n * 12));
  if (!in) throw fail("is truncated");
  for (std::size_t i = 0; i < n; ++i) {
    if (set.vertices[i] >= mesh_vertices || (i > 0 && set.vertices[i] <= set.vertices[i - 1]))
      throw fail("has vertex indices out of order or range");
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(set.radiance[i][c]) || !std::isfinite(set.std_error[i][c]) || set.std_error[i][c] < 0)
        throw fail("has a non-finite or negative value");
  }
  return set;
}

ErrorSet cached_error_set(const Mesh& mesh, const EnvMap& map, const ErrorSetOptions& options,
                          const std::string& cache_dir, const Progress& progress, std::string* note) {
  if (cache_dir.empty()) return make_error_set(mesh, map, options, progress);
  const std::string key = error_set_key(mesh, map, options);
  const std::string path = (std::filesystem::path(cache_dir) / (key + ".prte")).string();
  try {
    if (auto set = read_error_set(path, key)) {
      if (note) *note = "reference read from " + path;
      return std::move(*set);
    }
  } catch (const Error& e) {
    if (note) *note = std::string(e.what()) + "; rendering it again";
  }
  ErrorSet set = make_error_set(mesh, map, options, progress);
  std::error_code ec;
  std::filesystem::create_directories(cache_dir, ec);
  if (ec) throw Error("cannot create the cache directory " + cache_dir + ": " + ec.message());
  write_error_set(path, key, set);
  if (note && note->empty()) *note = "reference cached in " + path;
  return set;
}

}  // namespace prt
