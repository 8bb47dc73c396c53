// Fuzz target: the probe volume reader (docs/FORMAT.md "Probe volume"):
// read_transfer_as<ProbeTransfer> (read_transfer_file, then the kind: a
// transfer of another kind is refused naming it), then, for a volume it accepts,
// every CPU consumer prt has, cheaply: what prt info --json describes, the
// relighter (prt relight --at, prt export --probes, prt render's probe-lit
// object and Python) under a small map with a sun (so the bright pixels'
// sub-texel sums are used) turned once, the engines' JSON (3 bands), the SH
// matrices and their file (prt export --matrices), and the interpolation
// weights with the depth moments' visibility. A volume the reader accepts
// must be safe for all of them: an index it let through crashes here
// (under ASan: reads past an array).
//
// The checksum: as the transfer target does, an input that ends with the
// end marker "PRTE" gets the checksum of its mutated bytes written into the
// trailer before it is read, so the fuzzer reaches the header and arrays.
//
// Promises beyond "no crash": what read_transfer_as<ProbeTransfer> accepts,
// write_probe_transfer writes back to the same bytes (the format has no
// slack: one version, reserved bytes and padding checked zero), and every
// weight names a probe of the grid and is finite.
#include "fuzz_util.h"

#include <prt/envmap.h>
#include <prt/file_info.h>
#include <prt/hash.h>
#include <prt/probes.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/transfer_file.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <vector>

namespace {

std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// 64 x 32 lat-long: a soft sky and a sun of one pixel (a bright pixel for
// the relighter: over 32 x the mean and 4 x its surroundings).
const prt::EnvMap& small_map() {
  static const prt::EnvMap map = [] {
    const int W = 64, H = 32;
    std::vector<float> rgb(std::size_t(W) * H * 3);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x)
        for (int c = 0; c < 3; ++c)
          rgb[(std::size_t(y) * W + std::size_t(x)) * 3 + std::size_t(c)] = 0.1f + 0.02f * float(c) + 0.01f * float(y);
    for (int c = 0; c < 3; ++c) rgb[(std::size_t(9) * W + 21) * 3 + std::size_t(c)] = 1e4f;
    return prt::make_latlong(W, H, std::move(rgb), "fuzz map");
  }();
  return map;
}

void check_weights(const prt::ProbeTransfer& t, const prt::ProbeWeights& w) {
  if (w.count < 0 || w.count > 8) prt::fuzz::finding("probe weights: count out of range");
  for (int c = 0; c < w.count; ++c) {
    if (w.probe[std::size_t(c)] >= t.probes()) prt::fuzz::finding("probe weights: a probe past the grid");
    if (!std::isfinite(w.weight[std::size_t(c)])) prt::fuzz::finding("probe weights: a weight not finite");
  }
}

// The scratch files, named once before any is written: scratch_path keeps
// its removers in a vector whose growth copies and destroys them, which
// removes the files named before.
struct Scratch {
  std::string input = prt::fuzz::scratch_path("probes.prt");
  std::string written = prt::fuzz::scratch_path("written.prt");
  std::string matrices = prt::fuzz::scratch_path("matrices.bin");
};
const Scratch& scratch() {
  static const Scratch s;
  return s;
}

void exercise(const std::string& path, const std::vector<std::uint8_t>& bytes, const prt::ProbeTransfer& t) {
  // Written back: the same bytes.
  const std::string& written = scratch().written;
  try {
    prt::write_probe_transfer(written, t);
  } catch (const prt::Error& e) {
    prt::fuzz::finding(std::string("a probe volume read fails to write: ") + e.what());
  }
  if (file_bytes(written) != bytes) prt::fuzz::finding("write_probe_transfer(read(f)) differs from f");
  (void)prt::file_info_json(path);
  (void)t.bytes();

  // Relighting, as prt relight --at and prt export --probes do.
  prt::ProbeRelighter relighter(t, small_map());
  relighter.set_rotation(prt::sh::rotation_from_euler(30.0, 10.0, 0.0));
  std::vector<glm::vec3> lit;
  relighter.relight(lit);
  const std::size_t nc = std::size_t(prt::sh::num_coeffs(t.bands));
  if (lit.size() != t.probes() * nc) prt::fuzz::finding("relight: wrong size");
  const std::vector<std::uint32_t> some = {0u, std::uint32_t(t.probes() - 1), std::uint32_t(t.probes() / 2)};
  std::vector<glm::vec3> part;
  relighter.relight(some, part);
  (void)prt::lambert_from_sh(std::span<const glm::vec3>(part.data(), nc), t.bands, {0.0, 1.0, 0.0});
  (void)relighter.sky();
  if (t.bands == 3) (void)prt::probe_engine_json(t, small_map(), {30.0, 10.0, 0.0}, {"scene", "probes.prt", "map", "fuzz"});

  // SH matrices (prt export --matrices), one input band: cheap at any cube size.
  int channels = 0;
  const std::vector<float> m = prt::probe_sh_matrices(t, 1, channels);
  prt::write_probe_matrices(scratch().matrices, t, m, 1, channels);

  // Weights: at the grid's corners and centre, at probes, and outside; the
  // depth moments' visibility (no traced visibility here) and plain trilinear.
  const std::vector<std::uint32_t> slots = t.stored_slots();
  std::vector<glm::dvec3> points = {t.grid.min, t.grid.max, 0.5 * (t.grid.min + t.grid.max),
                                    t.grid.max + (t.grid.max - t.grid.min) + 1.0, t.grid.min - 1e3};
  for (std::size_t p = 0; p < t.probes() && p < 4; ++p) points.push_back(glm::dvec3(t.positions[p]) + 1e-3);
  points.push_back(glm::dvec3(t.positions[t.probes() - 1]));
  for (const glm::dvec3& p : points) {
    check_weights(t, prt::probe_weights(t, slots, p, {0.3, 0.9, -0.3}));
    check_weights(t, prt::probe_weights(t, slots, p, {0.0, 0.0, 0.0}));
    check_weights(t, prt::trilinear_weights(t.grid, p));
  }
  check_weights(t, prt::trilinear_weights(t.grid, glm::dvec3(std::numeric_limits<double>::quiet_NaN())));
  for (std::size_t s = 0; s < t.stored() && s < 4; ++s)
    for (const glm::dvec3& d : {glm::dvec3(0, 0, 1), glm::dvec3(0, 0, -1), glm::dvec3(0.6, -0.8, 0)})
      (void)prt::probe_visibility(t, s, d, double(t.depth_cap) * 0.5);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = scratch().input;
  std::vector<std::uint8_t> bytes(data, data + size);
  constexpr std::size_t kTrailer = 12;  // u64 checksum, "PRTE"
  if (size >= kTrailer && std::memcmp(data + size - 4, "PRTE", 4) == 0) {
    const std::uint64_t sum = prt::hash64(bytes.data(), size - kTrailer);
    std::memcpy(bytes.data() + size - kTrailer, &sum, sizeof sum);  // little-endian, as the format
  }
  prt::fuzz::write_file(path, bytes.data(), bytes.size());

  std::optional<prt::ProbeTransfer> t;
  prt::fuzz::expect_only_prt_errors([&] { t = prt::read_transfer_as<prt::ProbeTransfer>(path); });
  if (!t) return 0;
  // Accepted: no consumer may refuse it (nor crash).
  try {
    exercise(path, bytes, *t);
  } catch (const prt::Error& e) {
    prt::fuzz::finding(std::string("a probe volume the reader accepts is refused by a consumer: ") + e.what());
  }
  return 0;
}
