// Tests of transfer files (docs/FORMAT.md): bit-identical round trips, the
// byte layout the document specifies, every way a file can be bad, atomic
// writing, the mesh check and `prt info`.
#include "test_files.h"

#include <prt/precompute.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/hash.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

#include <glm/gtc/packing.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
// xxHash itself, compiled in (nothing links libxxhash): the checksum is checked
// against it, not against prt::Hasher.
#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <cctype>
#include <csignal>
#include <cstdio>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <limits>
#include <random>
#include <regex>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using prt::Transfer;
using prt::TransferMode;

// ---- helpers --------------------------------------------------------------------

using namespace prt::test;

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

// Sections to fill in a test transfer.
struct Sections {
  bool direct = false, ao = false, bent = false, energy = false;
};

// A transfer with random values in every array, consistent with its header.
Transfer make_transfer(TransferMode mode, int channels, int bands, std::size_t vertices, Sections s,
                       unsigned seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> g;
  Transfer t;
  t.bands = bands;
  t.channels = channels;
  t.mode = mode;
  t.bounces = mode == TransferMode::Interreflected ? 3 : 0;
  t.samples = 1024;
  t.albedo = {0.8f, 0.5f, 0.25f};
  t.vertex_colors = channels == 3;
  t.seed = 0x0123456789abcdefull + seed;
  t.vertices = vertices;
  t.mesh_hash = 0xfedcba9876543210ull ^ seed;
  t.coeffs.resize(vertices * t.stride());
  for (float& c : t.coeffs) c = g(rng);
  if (s.direct) {
    t.direct.resize(t.coeffs.size());
    for (float& c : t.direct) c = g(rng);
  }
  if (s.ao) {
    t.ao.resize(vertices);
    for (float& a : t.ao) a = std::abs(g(rng)) / 4;
  }
  if (s.bent) {
    t.bent_normals.resize(vertices);
    for (auto& n : t.bent_normals) n = {g(rng), g(rng), g(rng)};
  }
  if (s.energy)
    for (int b = 0; b < t.bounces; ++b) t.bounce_energy.push_back(1.0 / (b + 3));
  return t;
}

Transfer full_transfer(std::size_t vertices = 40) {
  return make_transfer(TransferMode::Interreflected, 3, 4, vertices, {true, true, true, true});
}

// `t` with the vertices `analytic(v)` selects marked analytic (their rows dropped).
template <typename Pick>
Transfer with_analytic(Transfer t, Pick analytic) {
  std::vector<std::uint8_t> mask(t.vertices);
  for (std::size_t v = 0; v < t.vertices; ++v) mask[v] = analytic(v) ? 1 : 0;
  prt::compact_transfer(t, mask);
  t.shading_hash = 0x5eed5eed5eed5eedull;
  return t;
}

// full_transfer(40) with every third vertex analytic (0, 3, ..., 39): 14 analytic, 26 stored.
Transfer mixed_transfer() {
  return with_analytic(full_transfer(40), [](std::size_t v) { return v % 3 == 0; });
}

template <typename T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0);
}

void expect_identical(const Transfer& a, const Transfer& b) {
  EXPECT_EQ(a.bands, b.bands);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.mode, b.mode);
  EXPECT_EQ(a.bounces, b.bounces);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(std::memcmp(&a.albedo, &b.albedo, sizeof a.albedo), 0);
  EXPECT_EQ(a.vertex_colors, b.vertex_colors);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.mesh_hash, b.mesh_hash);
  EXPECT_EQ(a.shading_hash, b.shading_hash);
  EXPECT_EQ(a.slots, b.slots);
  EXPECT_TRUE(same_bits(a.coeffs, b.coeffs));
  EXPECT_TRUE(same_bits(a.direct, b.direct));
  EXPECT_TRUE(same_bits(a.ao, b.ao));
  EXPECT_TRUE(same_bits(a.bent_normals, b.bent_normals));
  EXPECT_TRUE(same_bits(a.bounce_energy, b.bounce_energy));
  EXPECT_EQ(a.glossy, b.glossy);
  EXPECT_TRUE(same_bits(a.glossy_matrices, b.glossy_matrices));
  EXPECT_EQ(a.interpolated, b.interpolated);
  EXPECT_EQ(a.light_bounce.bounces, b.light_bounce.bounces);
  EXPECT_EQ(a.light_bounce.patches, b.light_bounce.patches);
  EXPECT_EQ(a.light_bounce.patch, b.light_bounce.patch);
  EXPECT_EQ(a.light_bounce.offsets, b.light_bounce.offsets);
  EXPECT_EQ(a.light_bounce.source, b.light_bounce.source);
  EXPECT_TRUE(same_bits(a.light_bounce.weight, b.light_bounce.weight));
  EXPECT_EQ(a.light_bounce.cluster_offsets, b.light_bounce.cluster_offsets);
  EXPECT_EQ(a.light_bounce.cluster_source, b.light_bounce.cluster_source);
  EXPECT_TRUE(same_bits(a.light_bounce.cluster_weight, b.light_bounce.cluster_weight));
  const prt::LightBounce::ProbeRows &pa = a.light_bounce.probes, &pb = b.light_bounce.probes;
  EXPECT_EQ(pa.dims, pb.dims);
  EXPECT_EQ(std::memcmp(&pa.min, &pb.min, sizeof pa.min), 0);
  EXPECT_EQ(std::memcmp(&pa.max, &pb.max, sizeof pa.max), 0);
  EXPECT_EQ(pa.bands, pb.bands);
  EXPECT_EQ(pa.offsets, pb.offsets);
  EXPECT_EQ(pa.source, pb.source);
  EXPECT_TRUE(same_bits(pa.weight, pb.weight));
  EXPECT_EQ(a.subsurface.has_value(), b.subsurface.has_value());
  if (a.subsurface && b.subsurface) {
    EXPECT_TRUE(*a.subsurface == *b.subsurface);
  }
}

// `t` with random glossy matrices for its stored rows (the layout of its mode).
Transfer with_glossy(Transfer t, unsigned seed = 7) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> g;
  t.glossy = true;
  t.glossy_matrices.resize(t.stored_vertices() * t.glossy_stride());
  for (float& x : t.glossy_matrices) x = g(rng);
  return t;
}

// Field offsets of docs/FORMAT.md, restated here on purpose: the test pins
// the document, not the implementation's constants.
constexpr std::size_t kHeader = 128, kSectionHeader = 24, kTrailer = 12;
constexpr std::size_t kVersionAt = 8, kHeaderSizeAt = 12, kBasisAt = 16, kBandsAt = 20, kChannelsAt = 24,
                      kModeAt = 28, kBouncesAt = 32, kSamplesAt = 36, kAlbedoAt = 40, kFlagsAt = 52, kSeedAt = 56,
                      kVerticesAt = 64, kMeshHashAt = 72, kSectionCountAt = 80, kStoredAt = 88, kShadingHashAt = 96;

template <typename T>
T get(const std::string& bytes, std::size_t at) {
  T v;
  std::memcpy(&v, bytes.data() + at, sizeof v);
  return v;
}

template <typename T>
void put(std::string& bytes, std::size_t at, T v) {
  std::memcpy(bytes.data() + at, &v, sizeof v);
}

// Recomputes the trailer's checksum after an edit, as a buggy or foreign
// writer would produce: the reader must then catch the edit itself.
void reseal(std::string& bytes) {
  put<std::uint64_t>(bytes, bytes.size() - kTrailer, XXH3_64bits(bytes.data(), bytes.size() - kTrailer));
}

// Expects read_transfer(path) to throw prt::Error whose message names the
// file and contains every one of `words`.
void expect_read_error(const std::string& path, const std::vector<std::string>& words, const std::string& what) {
  try {
    prt::read_transfer(path);
    ADD_FAILURE() << what << ": read_transfer accepted the file";
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_TRUE(contains(msg, path)) << what << ": message does not name the file: " << msg;
    for (const auto& w : words) EXPECT_TRUE(contains(msg, w)) << what << ": expected '" << w << "' in: " << msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": threw something other than prt::Error: " << e.what();
  }
}

// The format version of the file at `path` (prt::read_transfer_file's).
std::uint32_t file_version(const std::string& path) {
  std::uint32_t version = 0;
  (void)prt::read_transfer_file(path, &version);
  return version;
}

// Writes `bytes` to a file and expects reading it to fail with `words`.
void expect_bytes_error(const TempDir& dir, const std::string& bytes, const std::vector<std::string>& words,
                        const std::string& what) {
  const std::string path = dir.file("bad.prtt");
  write_file(path, bytes);
  expect_read_error(path, words, what);
}

// A valid file's bytes, with the offsets of its sections' headers.
struct Sample {
  std::string bytes;
  std::vector<std::size_t> section_at;
};

// The file at `path`, its sections found by walking the table.
Sample sample_of(const std::string& path) {
  Sample s{read_file(path), {}};
  std::size_t at = kHeader;
  for (std::uint32_t i = 0; i < get<std::uint32_t>(s.bytes, kSectionCountAt); ++i) {
    s.section_at.push_back(at);
    const auto bytes = get<std::uint64_t>(s.bytes, at + 16);
    at += kSectionHeader + bytes + (8 - bytes % 8) % 8;
  }
  return s;
}

Sample sample_file(const TempDir& dir, const Transfer& t) {
  const std::string path = dir.file("sample.prtt");
  prt::write_transfer(path, t);
  return sample_of(path);
}

// ---- round trips -------------------------------------------------------------------

TEST(TransferFile, RoundTripIsBitIdenticalForEveryModeChannelAndSection) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  unsigned seed = 0;
  for (TransferMode mode : {TransferMode::Unshadowed, TransferMode::Shadowed, TransferMode::Interreflected})
    for (int channels : {1, 3})
      for (int bands : {1, 2, 5})
        for (int mask = 0; mask < 16; ++mask) {
          const Sections s{(mask & 1) != 0 && mode == TransferMode::Interreflected, (mask & 2) != 0,
                           (mask & 4) != 0, (mask & 8) != 0 && mode == TransferMode::Interreflected};
          // 7 vertices: odd sizes, so sections need padding to 8 bytes.
          const Transfer t = make_transfer(mode, channels, bands, 7, s, ++seed);
          SCOPED_TRACE(std::string(prt::transfer_mode_name(mode)) + " channels " + std::to_string(channels) +
                       " bands " + std::to_string(bands) + " sections " + std::to_string(mask));
          prt::write_transfer(path, t);
          EXPECT_EQ(fs::file_size(path), prt::transfer_file_size(t));
          EXPECT_EQ(fs::file_size(path) % 4, 0u);
          const Transfer back = prt::read_transfer(path);
          expect_identical(t, back);
          // Writing what was read gives the same bytes.
          const std::string first = read_file(path);
          prt::write_transfer(path, back);
          EXPECT_EQ(read_file(path), first);
        }
}

TEST(TransferFile, RoundTripKeepsAnalyticVertices) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  // Vertex counts around the mask's 32-bit words; none, some, all analytic.
  for (std::size_t vertices : {1u, 7u, 31u, 32u, 33u, 100u})
    for (int pattern = 0; pattern < 4; ++pattern) {
      const auto pick = [&](std::size_t v) {
        return pattern == 0 ? false : pattern == 1 ? v % 3 == 1 : pattern == 2 ? v + 1 == vertices : true;
      };
      for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
        const bool ir = mode == TransferMode::Interreflected;
        const Transfer t = with_analytic(make_transfer(mode, ir ? 3 : 1, 3, vertices, {ir, true, true, ir}), pick);
        SCOPED_TRACE(std::to_string(vertices) + " vertices, pattern " + std::to_string(pattern) + ", " +
                     std::string(prt::transfer_mode_name(mode)));
        prt::write_transfer(path, t);
        EXPECT_EQ(fs::file_size(path), prt::transfer_file_size(t));
        const Transfer back = prt::read_transfer(path);
        expect_identical(t, back);
        EXPECT_EQ(back.analytic_vertices(), t.analytic_vertices());
        for (std::size_t v = 0; v < vertices; ++v) EXPECT_EQ(back.is_analytic(v), pick(v)) << "vertex " << v;
      }
    }
}

// Version 1 files (every vertex stored; bytes 84-127 zero) are still read.
TEST(TransferFile, ReadsVersionOneFiles) {
  TempDir dir;
  const Transfer t = full_transfer();
  Sample s = sample_file(dir, t);
  ASSERT_EQ(get<std::uint64_t>(s.bytes, kStoredAt), 40u);
  put<std::uint32_t>(s.bytes, kVersionAt, 1);
  put<std::uint64_t>(s.bytes, kStoredAt, 0);  // reserved in version 1
  put<std::uint64_t>(s.bytes, kShadingHashAt, 0);
  reseal(s.bytes);
  const std::string path = dir.file("v1.prtt");
  write_file(path, s.bytes);
  expect_identical(prt::read_transfer(path), t);
  EXPECT_EQ(file_version(path), 1u);
  const Result r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_EQ(nlohmann::json::parse(r.out).at("format_version"), 1);
  // Version 1 has no stored count, shading hash or analytic-vertex mask.
  std::string b = s.bytes;
  put<std::uint64_t>(b, kStoredAt, 40);
  reseal(b);
  expect_bytes_error(dir, b, {"reserved byte 88 is not zero"}, "stored count in version 1");
  const Sample m = sample_file(dir, mixed_transfer());
  b = m.bytes;
  put<std::uint32_t>(b, kVersionAt, 1);
  put<std::uint64_t>(b, kStoredAt, 0);
  put<std::uint64_t>(b, kShadingHashAt, 0);
  reseal(b);
  expect_bytes_error(dir, b, {"6 sections; at most 5 kinds exist in version 1"}, "mask in version 1");
  b = s.bytes;  // the version 1 file of every vertex
  put<std::uint32_t>(b, s.section_at[4], 6);  // its bounce energy section relabelled as a mask
  reseal(b);
  expect_bytes_error(dir, b, {"unknown kind 6 in a version 1 file"}, "kind 6 in version 1");
}

TEST(TransferFile, RoundTripKeepsSpecialFloatsBitForBit) {
  TempDir dir;
  Transfer t = make_transfer(TransferMode::Shadowed, 1, 2, 3, {false, true, true, false});
  t.coeffs[0] = -0.0f;
  t.coeffs[1] = std::numeric_limits<float>::denorm_min();
  t.coeffs[2] = -std::numeric_limits<float>::max();
  t.coeffs[3] = std::numeric_limits<float>::min();
  t.ao[0] = 0.0f;
  t.bent_normals[1] = {0.0f, -0.0f, 1.0f};
  t.albedo = {0.1f, 1e-30f, 1.0f};  // albedo is limited to [0, 1]
  t.seed = ~0ull;
  t.mesh_hash = 0;
  t.samples = std::numeric_limits<int>::max();
  const std::string path = dir.file("t.prtt");
  prt::write_transfer(path, t);
  expect_identical(t, prt::read_transfer(path));
}

TEST(TransferFile, LargerTransferRoundTrips) {
  TempDir dir;
  const Transfer t = make_transfer(TransferMode::Interreflected, 3, 8, 5000, {true, true, true, true});
  const std::string path = dir.file("big.prtt");
  prt::write_transfer(path, t);
  expect_identical(t, prt::read_transfer(path));
}

// ---- the layout docs/FORMAT.md specifies ----------------------------------------------

TEST(TransferFormat, BytesAreWhereTheDocumentSays) {
  TempDir dir;
  const Transfer t = full_transfer(5);
  const Sample s = sample_file(dir, t);
  const std::string& b = s.bytes;
  EXPECT_EQ(b.substr(0, 8), std::string("PRTT\r\n\x1a\n", 8));
  EXPECT_EQ(get<std::uint32_t>(b, kVersionAt), 2u);
  EXPECT_EQ(get<std::uint32_t>(b, kHeaderSizeAt), 128u);
  EXPECT_EQ(get<std::uint32_t>(b, kBasisAt), 0u);
  EXPECT_EQ(get<std::uint32_t>(b, kBandsAt), 4u);
  EXPECT_EQ(get<std::uint32_t>(b, kChannelsAt), 3u);
  EXPECT_EQ(get<std::uint32_t>(b, kModeAt), 2u);
  EXPECT_EQ(get<std::uint32_t>(b, kBouncesAt), 3u);
  EXPECT_EQ(get<std::uint32_t>(b, kSamplesAt), 1024u);
  EXPECT_EQ(get<float>(b, kAlbedoAt + 0), 0.8f);
  EXPECT_EQ(get<float>(b, kAlbedoAt + 4), 0.5f);
  EXPECT_EQ(get<float>(b, kAlbedoAt + 8), 0.25f);
  EXPECT_EQ(get<std::uint32_t>(b, kFlagsAt), 1u);  // vertex colours
  EXPECT_EQ(get<std::uint64_t>(b, kSeedAt), t.seed);
  EXPECT_EQ(get<std::uint64_t>(b, kVerticesAt), 5u);
  EXPECT_EQ(get<std::uint64_t>(b, kMeshHashAt), t.mesh_hash);
  EXPECT_EQ(get<std::uint32_t>(b, kSectionCountAt), 5u);
  EXPECT_EQ(get<std::uint64_t>(b, kStoredAt), 5u);  // every vertex stored
  EXPECT_EQ(get<std::uint64_t>(b, kShadingHashAt), t.shading_hash);
  for (std::size_t i = 84; i < kStoredAt; ++i) EXPECT_EQ(b[i], 0) << "reserved byte " << i;
  for (std::size_t i = 104; i < kHeader; ++i) EXPECT_EQ(b[i], 0) << "reserved byte " << i;

  // Sections in kind order: kind, element type, count, bytes, data.
  const std::uint32_t kinds[5] = {1, 2, 3, 4, 5}, types[5] = {1, 1, 1, 1, 2};
  const std::uint64_t counts[5] = {5 * 3 * 16, 5 * 3 * 16, 5, 15, 3};
  ASSERT_EQ(s.section_at.size(), 5u);
  EXPECT_EQ(s.section_at[0], kHeader);
  for (int i = 0; i < 5; ++i) {
    const std::size_t at = s.section_at[i];
    EXPECT_EQ(at % 8, 0u);
    EXPECT_EQ(get<std::uint32_t>(b, at), kinds[i]);
    EXPECT_EQ(get<std::uint32_t>(b, at + 4), types[i]);
    EXPECT_EQ(get<std::uint64_t>(b, at + 8), counts[i]);
    EXPECT_EQ(get<std::uint64_t>(b, at + 16), counts[i] * (types[i] == 2 ? 8 : 4));
  }
  // Vertex-major [vertex][channel][k]: vertex 2, channel 1, k = 7.
  EXPECT_EQ(get<float>(b, kHeader + kSectionHeader + 4 * ((2 * 3 + 1) * 16 + 7)), t.coeffs[(2 * 3 + 1) * 16 + 7]);
  // AO: 5 floats = 20 bytes, padded to 24 with zeros.
  EXPECT_EQ(s.section_at[3] - s.section_at[2], kSectionHeader + 24);
  EXPECT_EQ(get<std::uint32_t>(b, s.section_at[2] + kSectionHeader + 20), 0u);
  EXPECT_EQ(get<double>(b, s.section_at[4] + kSectionHeader + 8), t.bounce_energy[1]);

  // Trailer: XXH3-64 of everything before it, then "PRTE".
  EXPECT_EQ(b.substr(b.size() - 4), "PRTE");
  EXPECT_EQ(get<std::uint64_t>(b, b.size() - kTrailer), XXH3_64bits(b.data(), b.size() - kTrailer));
}

TEST(TransferFormat, AnalyticVertexMaskIsWhereTheDocumentSays) {
  TempDir dir;
  const Transfer t = mixed_transfer();
  const Sample s = sample_file(dir, t);
  const std::string& b = s.bytes;
  EXPECT_EQ(get<std::uint64_t>(b, kVerticesAt), 40u);
  EXPECT_EQ(get<std::uint64_t>(b, kStoredAt), 26u);
  EXPECT_EQ(get<std::uint64_t>(b, kShadingHashAt), 0x5eed5eed5eed5eedull);
  ASSERT_EQ(get<std::uint32_t>(b, kSectionCountAt), 6u);
  // Coefficients and direct: the 26 stored vertices' rows, in vertex order.
  EXPECT_EQ(get<std::uint64_t>(b, s.section_at[0] + 8), 26u * 3 * 16);
  EXPECT_EQ(get<std::uint64_t>(b, s.section_at[1] + 8), 26u * 3 * 16);
  EXPECT_EQ(get<float>(b, kHeader + kSectionHeader), t.coeffs[0]);  // row 0 is vertex 1
  // AO and bent normals stay per vertex.
  EXPECT_EQ(get<std::uint64_t>(b, s.section_at[2] + 8), 40u);
  // Kind 6, u32, (40 + 31) / 32 = 2 words, 8 bytes: bit v % 32 of word v / 32.
  const std::size_t at = s.section_at[5];
  EXPECT_EQ(get<std::uint32_t>(b, at), 6u);
  EXPECT_EQ(get<std::uint32_t>(b, at + 4), 4u);
  EXPECT_EQ(get<std::uint64_t>(b, at + 8), 2u);
  EXPECT_EQ(get<std::uint64_t>(b, at + 16), 8u);
  std::uint32_t w0 = 0, w1 = 0;
  for (std::size_t v = 0; v < 40; v += 3) (v < 32 ? w0 : w1) |= 1u << (v % 32);
  EXPECT_EQ(get<std::uint32_t>(b, at + kSectionHeader), w0);
  EXPECT_EQ(get<std::uint32_t>(b, at + kSectionHeader + 4), w1);
  EXPECT_EQ(b.size(), at + kSectionHeader + 8 + kTrailer);
  EXPECT_EQ(prt::transfer_file_size(t), b.size());
  // Saved: 14 rows of coefficients and of direct (14 x 192 bytes each), less the mask section.
  EXPECT_EQ(prt::analytic_bytes_saved(t), 2u * 14 * 192 - (kSectionHeader + 8));
}

TEST(TransferFormat, WorkedExampleOfTheDocument) {
  // docs/FORMAT.md: bunny00 (37706 vertices), 5 bands, 1 channel, shadowed,
  // with ambient occlusion and bent normals.
  Transfer t = make_transfer(TransferMode::Shadowed, 1, 5, 37706, {false, true, true, false});
  EXPECT_EQ(prt::transfer_bytes_per_vertex(t), 116u);
  EXPECT_EQ(prt::transfer_file_size(t), 4374108u);
  const auto sections = prt::transfer_sections(t);
  ASSERT_EQ(sections.size(), 3u);
  EXPECT_EQ(sections[0].bytes, 3770600u);
  EXPECT_EQ(sections[1].bytes, 150824u);
  EXPECT_EQ(sections[2].bytes, 452472u);
  // With 1000 analytic vertices: 100 bytes less each, plus a mask of 1179
  // words (4716 bytes, padded to 4720) behind a section header.
  const Transfer a = with_analytic(t, [](std::size_t v) { return v < 1000; });
  EXPECT_EQ(prt::transfer_file_size(a), 4278852u);
  EXPECT_EQ(prt::analytic_bytes_saved(a), 4374108u - 4278852u);
  // Interreflected, 3 channels, everything: 300 + 300 + 4 + 12 per vertex.
  t = make_transfer(TransferMode::Interreflected, 3, 5, 37706, {true, true, true, true});
  EXPECT_EQ(prt::transfer_bytes_per_vertex(t), 616u);
}

// ---- bad files -------------------------------------------------------------------------

TEST(TransferRead, MissingEmptyAndDirectory) {
  TempDir dir;
  expect_read_error(dir.file("nope.prtt"), {"no such file"}, "missing");
  write_file(dir.file("empty.prtt"), "");
  expect_read_error(dir.file("empty.prtt"), {"empty"}, "empty");
  fs::create_directories(dir.file("d.prtt"));
  expect_read_error(dir.file("d.prtt"), {"directory"}, "directory");
}

TEST(TransferRead, NotATransferFile) {
  TempDir dir;
  expect_bytes_error(dir, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", {"not a prt transfer file"}, "text file");
  expect_bytes_error(dir, "hi", {"not a prt transfer file"}, "short text");
  expect_bytes_error(dir, std::string(4096, '\0'), {"not a prt transfer file"}, "zeros");
  Sample s = sample_file(dir, full_transfer());
  s.bytes[0] = 'Q';
  expect_bytes_error(dir, s.bytes, {"not a prt transfer file"}, "wrong magic");
}

TEST(TransferRead, TextModeMangledSignatureIsNamed) {
  TempDir dir;
  const Sample s = sample_file(dir, full_transfer());
  std::string mangled = s.bytes;
  mangled.erase(4, 1);  // CR LF -> LF, as a text-mode copy does
  expect_bytes_error(dir, mangled, {"signature", "text mode"}, "CRLF -> LF");
}

TEST(TransferRead, NewerAndUnknownVersions) {
  TempDir dir;
  Sample s = sample_file(dir, full_transfer());
  put<std::uint32_t>(s.bytes, kVersionAt, 99);
  expect_bytes_error(dir, s.bytes, {"written by a newer prt (version 99); this prt reads versions 1 to 12"},
                     "version 99");
  // A newer version may change everything after the version: it is named
  // even when the rest is short or different.
  expect_bytes_error(dir, s.bytes.substr(0, 16), {"newer prt (version 99)"}, "version 99, short");
  put<std::uint32_t>(s.bytes, kVersionAt, 0);
  expect_bytes_error(dir, s.bytes, {"unknown format version 0"}, "version 0");
}

TEST(TransferRead, TruncatedAnywhere) {
  TempDir dir;
  const Transfer t = full_transfer();
  const Sample s = sample_file(dir, t);
  const std::size_t size = s.bytes.size();
  const std::vector<std::size_t> cuts = {3,
                                         8,
                                         12,
                                         20,
                                         100,
                                         127,
                                         128,
                                         139,
                                         140,
                                         150,                          // inside the first section header
                                         s.section_at[0] + 1000,       // inside the coefficients
                                         s.section_at[1] + 30,         // inside the direct part
                                         s.section_at[4] + 4,          // inside the last section header
                                         s.section_at[4] + 30,         // inside the last section's data
                                         size - kTrailer,              // no trailer
                                         size - 4,                     // no end marker
                                         size - 1};
  for (std::size_t cut : cuts) {
    SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(size));
    expect_bytes_error(dir, s.bytes.substr(0, cut), {"truncated: expected ", "bytes, file has " + std::to_string(cut)},
                       "cut");
  }
  // Where the size is known exactly, it is stated exactly.
  for (std::size_t cut : {s.section_at[4] + 30, size - kTrailer, size - 4, size - 1})
    expect_bytes_error(dir, s.bytes.substr(0, cut),
                       {"truncated: expected " + std::to_string(size) + " bytes, file has " + std::to_string(cut)},
                       "exact");
  expect_bytes_error(dir, s.bytes.substr(0, 100), {"truncated: expected at least 140 bytes, file has 100"},
                     "inside the header");
}

TEST(TransferRead, FlippedBytesFailTheChecksum) {
  TempDir dir;
  const Sample s = sample_file(dir, full_transfer());
  const std::size_t size = s.bytes.size();
  for (std::size_t at : {std::size_t(kBandsAt), std::size_t(kVerticesAt), std::size_t(100), s.section_at[0] + 16,
                         s.section_at[0] + kSectionHeader + 17, size / 2, s.section_at[4] + kSectionHeader + 3,
                         size - kTrailer, size - 5}) {
    std::string b = s.bytes;
    b[at] = static_cast<char>(b[at] ^ 0x10);
    expect_bytes_error(dir, b, {"corrupt: checksum mismatch"}, "flip at " + std::to_string(at));
  }
  std::string b = s.bytes;
  b[size - 1] = 'X';
  expect_bytes_error(dir, b, {"corrupt", "end marker"}, "end marker");
  b = s.bytes + "extra";
  expect_bytes_error(dir, b, {"corrupt: expected " + std::to_string(size) + " bytes"}, "appended bytes");
}

TEST(TransferRead, BadHeaderValues) {
  TempDir dir;
  const Sample s = sample_file(dir, full_transfer());
  struct Case {
    std::size_t at;
    std::uint64_t value;
    int bytes;
    std::vector<std::string> words;
  };
  const std::vector<Case> cases = {
      {kBandsAt, 0, 4, {"bad header", "bands is 0", "1 to 64"}},
      {kBandsAt, 65, 4, {"bands is 65"}},
      {kChannelsAt, 2, 4, {"channels is 2", "1 or 3"}},
      {kChannelsAt, 0, 4, {"channels is 0"}},
      {kModeAt, 3, 4, {"unknown transfer mode 3"}},
      {kBasisAt, 1, 4, {"wavelet"}},
      {kBasisAt, 7, 4, {"unknown basis 7"}},
      {kBouncesAt, 0x80000000u, 4, {"bounces is 2147483648"}},
      {kSamplesAt, 0xffffffffu, 4, {"samples is 4294967295"}},
      {kAlbedoAt + 4, 0x7fc00000u, 4, {"albedo is not finite"}},
      // What compute_transfer refuses (--albedo outside [0, 1]): 2, -1, 1e30.
      {kAlbedoAt, 0x40000000u, 4, {"bad header: albedo is 2 0.5 0.25; must be in [0, 1] per channel"}},
      {kAlbedoAt + 4, 0xbf800000u, 4, {"albedo is 0.8 -1 0.25; must be in [0, 1]"}},
      {kAlbedoAt + 8, 0x7149f2cau, 4, {"albedo is 0.8 0.5 1e+30; must be in [0, 1]"}},
      {kFlagsAt, 0x81, 4, {"unknown flags 0x80"}},
      {84, 1, 1, {"reserved byte 84"}},
      {110, 1, 1, {"reserved byte 110"}},
      {kHeaderSizeAt, 64, 4, {"header size 64"}},
      {kVerticesAt, 0, 8, {"no vertices"}},
      {kVerticesAt, 1ull << 40, 8, {"1099511627776 vertices cannot fit"}},
      {kVerticesAt, ~0ull, 8, {"vertices cannot fit"}},
      {kVerticesAt, 41, 8, {"section 'ambient occlusion' has 40 values; expected 41"}},
      {kStoredAt, 41, 8, {"41 stored vertices, more than its 40 vertices"}},
      {kStoredAt, 39, 8, {"section 'coefficients' has 1920 values", "39 x 3 x 16 = 1872"}},
      {kStoredAt, 1ull << 40, 8, {"stored vertices, more than"}},
      {kSectionCountAt, 0, 4, {"no sections"}},
      {kSectionCountAt, 7, 4, {"7 sections; at most 6 kinds exist in version 2"}},
  };
  for (const auto& c : cases) {
    std::string b = s.bytes;
    if (c.bytes == 1)
      b[c.at] = static_cast<char>(c.value);
    else if (c.bytes == 4)
      put<std::uint32_t>(b, c.at, std::uint32_t(c.value));
    else
      put<std::uint64_t>(b, c.at, c.value);
    reseal(b);
    expect_bytes_error(dir, b, c.words, "header byte " + std::to_string(c.at) + " = " + std::to_string(c.value));
  }
}

TEST(TransferRead, SectionsInconsistentWithTheHeader) {
  TempDir dir;
  const Sample s = sample_file(dir, full_transfer());
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& words, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, words, what);
  };
  const std::size_t c = s.section_at[0], ao = s.section_at[2];
  edit(c, std::uint32_t(9), {"unknown kind 9"}, "kind 9");
  edit(c, std::uint32_t(3), {"no 'coefficients' section"}, "coefficients missing");
  edit(ao, std::uint32_t(2), {"out of order or repeated"}, "repeated kind");
  edit(c + 4, std::uint32_t(2), {"element type 2", "expected 1 (f32)"}, "f64 coefficients");
  edit(c + 8, std::uint64_t(1919), {"1919 values", "expected stored vertices x channels x bands^2"}, "count");
  edit(c + 16, std::uint64_t(7676), {"1920 f32 values but 7676 bytes"}, "bytes");
  edit(ao + 8, std::uint64_t(39), {"'ambient occlusion' has 39 values; expected 40"}, "AO count");
  edit(s.section_at[4] + 8, std::uint64_t(4), {"'bounce energy' has 4 values; expected 1 to bounces = 3"},
       "bounce energy count");
  edit(kModeAt, std::uint32_t(1), {"'direct' section", "only an interreflected transfer"}, "direct when shadowed");
  edit(kSectionCountAt, std::uint32_t(4), {"between the last section and the trailer"}, "section count too small");
  edit(kSectionCountAt, std::uint32_t(6), {"section 6 of 6 is missing"}, "section count too large");

  // Non-zero padding: the AO section (40 floats) needs none; make one that does.
  Transfer odd = full_transfer(5);
  const Sample o = sample_file(dir, odd);
  std::string b = o.bytes;
  b[o.section_at[2] + kSectionHeader + 20] = 1;
  reseal(b);
  expect_bytes_error(dir, b, {"padding after section 'ambient occlusion'"}, "padding");
}

TEST(TransferRead, BadAnalyticVertexMask) {
  TempDir dir;
  const Sample s = sample_file(dir, mixed_transfer());
  const std::size_t mask = s.section_at[5], words = mask + kSectionHeader;
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& words_expected,
                        const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, words_expected, what);
  };
  // Bit 1 (vertex 1) set as well: 15 marked, the header says 14.
  edit(words, get<std::uint32_t>(s.bytes, words) | 2u,
       {"bad analytic-vertex mask: 15 vertices marked analytic; the header says 14 (40 vertices, 26 stored)"},
       "one bit too many");
  // Bits past vertex 39 (bit 8 of word 1) are not vertices.
  edit(words + 4, (get<std::uint32_t>(s.bytes, words + 4) & ~1u) | (1u << 8),
       {"bits set past the last vertex (40)"}, "tail bit");
  edit(mask + 4, std::uint32_t(1), {"'analytic vertices' has element type 1; expected 4 (u32)"}, "f32 mask");
  edit(mask + 8, std::uint64_t(3), {"'analytic vertices' has 3 words; expected (vertices + 31) / 32 = 2"},
       "word count");
  edit(mask + 16, std::uint64_t(12), {"2 u32 values but 12 bytes"}, "byte size");
  edit(kStoredAt, std::uint64_t(40), {"section 'coefficients' has 1248 values", "40 x 3 x 16 = 1920"},
       "stored count says all");

  // The mask section left out (the file shortened by it): the header's
  // stored count still says 14 vertices are analytic.
  std::string b = s.bytes.substr(0, mask) + s.bytes.substr(s.bytes.size() - kTrailer);
  put<std::uint32_t>(b, kSectionCountAt, 5);
  reseal(b);
  expect_bytes_error(dir, b, {"no 'analytic vertices' section", "14 of 40 vertices are analytic"}, "no mask");

  // A mask in a file that stores every vertex.
  const Sample d = sample_file(dir, full_transfer());
  b = d.bytes.substr(0, d.bytes.size() - kTrailer);
  const std::string extra = s.bytes.substr(mask, kSectionHeader + 8);
  b += extra + d.bytes.substr(d.bytes.size() - kTrailer);
  put<std::uint32_t>(b, kSectionCountAt, 6);
  reseal(b);
  expect_bytes_error(dir, b, {"has an 'analytic vertices' section, but the header says every vertex is stored"},
                     "mask when all stored");

  // Too many vertices for the mask to fit in the file.
  edit(kVerticesAt, std::uint64_t(1) << 40, {"1099511627776 vertices cannot fit", "analytic-vertex mask"},
       "huge vertex count");
}

TEST(TransferRead, NonFiniteValuesNameTheVertex) {
  TempDir dir;
  const Transfer t = full_transfer();
  const Sample s = sample_file(dir, t);
  const std::size_t stride = t.stride();  // 3 x 16
  const auto edit = [&](std::size_t at, float value, const std::vector<std::string>& words, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, words, what);
  };
  const std::size_t data = kHeader + kSectionHeader;
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  edit(data + 4 * (12 * stride + 16 + 5), nan, {"vertex 12 has a non-finite coefficient", "channel 1, k = 5"}, "NaN");
  edit(data + 4 * (39 * stride), -inf, {"vertex 39 has a non-finite coefficient"}, "-Inf");
  edit(s.section_at[1] + kSectionHeader + 4 * (3 * stride), inf, {"vertex 3 has a non-finite direct coefficient"},
       "direct");
  edit(s.section_at[2] + kSectionHeader + 4 * 7, nan, {"vertex 7 has a non-finite ambient occlusion"}, "AO");
  edit(s.section_at[3] + kSectionHeader + 4 * (3 * 8 + 2), inf, {"vertex 8 has a non-finite bent normal"}, "bent");
  std::string b = s.bytes;
  put(b, s.section_at[4] + kSectionHeader + 8, std::numeric_limits<double>::quiet_NaN());
  reseal(b);
  expect_bytes_error(dir, b, {"bounce 2 has a non-finite energy"}, "bounce energy");

  // With analytic vertices (every third), rows are named by their vertex:
  // row 1 is vertex 2, row 25 vertex 38.
  const Sample m = sample_file(dir, mixed_transfer());
  b = m.bytes;
  put(b, data + 4 * (1 * stride + 3), nan);
  reseal(b);
  expect_bytes_error(dir, b, {"vertex 2 has a non-finite coefficient"}, "NaN in row 1");
  b = m.bytes;
  put(b, m.section_at[1] + kSectionHeader + 4 * (25 * stride), inf);
  reseal(b);
  expect_bytes_error(dir, b, {"vertex 38 has a non-finite direct coefficient"}, "Inf in direct row 25");
}

// ---- glossy matrices (version 3) -----------------------------------------------------

TEST(TransferFile, GlossyMatricesRoundTripAsVersionThree) {
  TempDir dir;
  const std::size_t nc = 16;  // 4 bands
  struct Case {
    Transfer t;
    std::size_t per_row;  // floats per stored row, as docs/FORMAT.md says
  };
  const std::vector<Case> cases = {
      {with_glossy(make_transfer(TransferMode::Shadowed, 1, 4, 40, {false, true, true, false})), nc * (nc + 1) / 2},
      {with_glossy(mixed_transfer()), 3 * nc * nc},  // interreflected RGB, 26 of 40 stored
  };
  for (const Case& c : cases) {
    const Sample s = sample_file(dir, c.t);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 3u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, kFlagsAt) & 2u, 2u);
    // The last section is kind 7, f32, stored vertices x the row above.
    const std::size_t last = s.section_at.back();
    EXPECT_EQ(get<std::uint32_t>(s.bytes, last), 7u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, last + 4), 1u);
    EXPECT_EQ(get<std::uint64_t>(s.bytes, last + 8), c.t.stored_vertices() * c.per_row);
    float first;
    std::memcpy(&first, s.bytes.data() + last + kSectionHeader, 4);
    EXPECT_EQ(first, c.t.glossy_matrices[0]);
    expect_identical(prt::read_transfer(dir.file("sample.prtt")), c.t);
  }
  // Without glossy matrices prt still writes version 2.
  const Sample plain = sample_file(dir, full_transfer());
  EXPECT_EQ(get<std::uint32_t>(plain.bytes, kVersionAt), 2u);
}

TEST(TransferRead, GlossyMatricesInconsistentWithTheHeader) {
  TempDir dir;
  const Transfer t = with_glossy(make_transfer(TransferMode::Shadowed, 1, 4, 40, {false, true, false, false}));
  const Sample s = sample_file(dir, t);
  const std::size_t g = s.section_at.back();
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& words, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, words, what);
  };
  edit(kFlagsAt, std::uint32_t(0), {"'glossy matrices' section", "flags say it has none"}, "section without flag");
  edit(kVersionAt, std::uint32_t(2), {"unknown flags 0x2 in a version 2 file"}, "glossy in version 2");
  edit(g + 8, std::uint64_t(40 * 136 - 1), {"'glossy matrices' has 5439 values", "bands^2 (bands^2 + 1) / 2"},
       "count");
  edit(kModeAt, std::uint32_t(0), {"unshadowed transfer does not have"}, "unshadowed with glossy");
  edit(g + kSectionHeader + 4 * (136 * 17 + 3), std::numeric_limits<float>::quiet_NaN(),
       {"vertex 17 has a non-finite glossy matrix entry"}, "NaN");
  // The flag without the section.
  const Sample plain = sample_file(dir, make_transfer(TransferMode::Shadowed, 1, 4, 40, {false, true, false, false}));
  std::string b = plain.bytes;
  put(b, kVersionAt, std::uint32_t(3));
  put(b, kFlagsAt, std::uint32_t(2));
  reseal(b);
  expect_bytes_error(dir, b, {"no 'glossy matrices' section", "flags say the file has one"}, "flag without section");
}

// ---- compressed transfers (version 4, docs/FORMAT.md "Compressed transfer") ---------------

void expect_same_signal(const prt::ClusteredSignal& a, const prt::ClusteredSignal& b) {
  EXPECT_EQ(a.clusters, b.clusters);
  EXPECT_EQ(a.vectors, b.vectors);
  EXPECT_EQ(a.dim, b.dim);
  EXPECT_EQ(a.weight_bits, b.weight_bits);
  EXPECT_EQ(a.cluster, b.cluster);
  EXPECT_TRUE(same_bits(a.means, b.means));
  EXPECT_TRUE(same_bits(a.bases, b.bases));
  EXPECT_TRUE(same_bits(a.weights, b.weights));
  EXPECT_TRUE(same_bits(a.weight_scales, b.weight_scales));
}

prt::CompressedTransfer compressed(const Transfer& t, int clusters, int vectors, int bits) {
  prt::CompressOptions o;
  o.clusters = clusters;
  o.vectors = vectors;
  o.weight_bits = bits;
  o.iterations = 4;
  return prt::compress_transfer(t, o);
}

// A compressed file's bytes with its section offsets (as sample_file).
Sample compressed_sample(const TempDir& dir, const prt::CompressedTransfer& c) {
  const std::string path = dir.file("sample.prtt");
  prt::write_compressed_transfer(path, c);
  return sample_of(path);
}

// Expects `read` to throw prt::Error naming `path` with every one of `words`.
template <typename Read>
void expect_error_of(Read read, const std::string& path, const std::vector<std::string>& words,
                     const std::string& what) {
  try {
    read(path);
    ADD_FAILURE() << what << ": the file was accepted";
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_TRUE(contains(msg, path)) << what << ": message does not name the file: " << msg;
    for (const auto& w : words) EXPECT_TRUE(contains(msg, w)) << what << ": expected '" << w << "' in: " << msg;
  }
}

TEST(CompressedFile, RoundTripIsBitExactAsVersionFour) {
  TempDir dir;
  struct Case {
    Transfer t;
    int clusters, vectors, bits;
    std::uint32_t index_type;  // docs/FORMAT.md: 6 u8, 7 u16
  };
  const std::vector<Case> cases = {
      {mixed_transfer(), 3, 4, 32, 6},  // interreflected RGB, 14 of 40 analytic, direct part dropped
      {mixed_transfer(), 3, 4, 16, 6},
      {with_glossy(make_transfer(TransferMode::Shadowed, 1, 4, 40, {false, true, false, false})), 4, 3, 16, 6},
      {with_glossy(mixed_transfer()), 2, 5, 32, 6},
      {make_transfer(TransferMode::Shadowed, 1, 3, 700, {}), 300, 2, 16, 7},  // 300 clusters: 16-bit indices
  };
  for (const Case& k : cases) {
    const prt::CompressedTransfer c = compressed(k.t, k.clusters, k.vectors, k.bits);
    const Sample s = compressed_sample(dir, c);
    const std::string path = dir.file("sample.prtt");
    EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 4u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, kFlagsAt) & 4u, 4u);
    EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(c));
    EXPECT_EQ(prt::kind_of(prt::read_transfer_file(path)), prt::TransferKind::Compressed);
    // The coefficients' record: its header as the document lays it out.
    const std::size_t rec = s.section_at[s.section_at.size() - (k.t.glossy ? 2 : 1)];
    EXPECT_EQ(get<std::uint32_t>(s.bytes, rec), 8u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, rec + 4), 6u);  // u8
    const std::size_t r = rec + kSectionHeader;
    EXPECT_EQ(get<std::uint32_t>(s.bytes, r + 0), std::uint32_t(c.coeffs.clusters));
    EXPECT_EQ(get<std::uint32_t>(s.bytes, r + 4), std::uint32_t(c.coeffs.vectors));
    EXPECT_EQ(get<std::uint32_t>(s.bytes, r + 8), k.t.stride());
    EXPECT_EQ(get<std::uint32_t>(s.bytes, r + 12), k.bits == 16 ? 5u : 1u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, r + 16), k.index_type);
    EXPECT_EQ(get<std::uint64_t>(s.bytes, r + 24), k.t.stored_vertices());
    EXPECT_EQ(get<float>(s.bytes, r + 32), c.coeffs.means[0]);
    const prt::CompressedTransfer back = prt::read_compressed_transfer(path);
    expect_identical(back.transfer, c.transfer);
    expect_same_signal(back.coeffs, c.coeffs);
    expect_same_signal(back.glossy, c.glossy);
    // And written again, the same bytes.
    prt::write_compressed_transfer(dir.file("again.prtt"), back);
    EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
    const std::string d = prt::describe_transfer(back);
    EXPECT_TRUE(contains(d, "format version 4")) << d;
    EXPECT_TRUE(contains(d, std::to_string(c.coeffs.clusters) + " clusters x " + std::to_string(c.coeffs.vectors) +
                                " principal vectors"))
        << d;
  }
}

TEST(CompressedFile, EachReaderRefusesTheOtherKind) {
  TempDir dir;
  const Transfer t = mixed_transfer();
  const std::string plain = dir.file("plain.prtt"), packed = dir.file("packed.prtt");
  prt::write_transfer(plain, t);
  prt::write_compressed_transfer(packed, compressed(t, 2, 3, 32));
  EXPECT_EQ(prt::kind_of(prt::read_transfer_file(plain)), prt::TransferKind::SH);
  expect_error_of(prt::read_transfer, packed, {"compressed by clustered PCA", "read_compressed_transfer"},
                  "read_transfer of a compressed file");
  expect_error_of(prt::read_compressed_transfer, plain, {"uncompressed transfer", "prt compress"},
                  "read_compressed_transfer of a plain file");
}

TEST(CompressedRead, EveryInconsistencyIsRefusedByName) {
  TempDir dir;
  // Shadowed mono, 4 bands (16 values a row), 40 rows in 3 clusters of 3
  // vectors, 16-bit weights. The record: 32 (header) + 192 (means) + 576
  // (bases) + 36 (scales) + 4 (padding) + 40 (u8 indices) + 240 (weights).
  const Transfer t = make_transfer(TransferMode::Shadowed, 1, 4, 40, {false, true, false, false});
  const prt::CompressedTransfer c = compressed(t, 3, 3, 16);
  ASSERT_EQ(c.coeffs.clusters, 3);
  const Sample s = compressed_sample(dir, c);
  const std::size_t sec = s.section_at.back(), r = sec + kSectionHeader;
  ASSERT_EQ(get<std::uint64_t>(s.bytes, sec + 16), 1120u);
  const std::size_t pad_at = r + 32 + 192 + 576 + 36, index_at = pad_at + 4, weights_at = index_at + 40;
  const auto read = prt::read_compressed_transfer;
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& words, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    const std::string path = dir.file("bad.prtt");
    write_file(path, b);
    expect_error_of(read, path, words, what);
  };
  edit(kVersionAt, std::uint32_t(3), {"unknown flags 0x4 in a version 3 file"}, "compressed in version 3");
  edit(kFlagsAt, std::uint32_t(0), {"uncompressed transfer"}, "flag cleared");
  edit(kFlagsAt, std::uint32_t(6), {"no 'compressed glossy matrices' section"}, "glossy flag without its record");
  edit(r + 8, std::uint32_t(15), {"'compressed coefficients'", "rows of 15 values", "give 16"}, "dim");
  edit(r + 24, std::uint64_t(39), {"39 rows", "40 stored vertices"}, "rows");
  edit(r + 0, std::uint32_t(0), {"0 clusters for 40 rows"}, "no cluster");
  edit(r + 0, std::uint32_t(300), {"cluster index type 6", "300 clusters take 7 (u16)"}, "index too narrow");
  edit(r + 4, std::uint32_t(17), {"17 principal vectors", "at most 16"}, "vectors");
  edit(r + 12, std::uint32_t(2), {"weight type 2"}, "weight type");
  edit(r + 20, std::uint32_t(1), {"reserved bytes 20-23"}, "reserved");
  edit(r + 4, std::uint32_t(1), {"1120 bytes", "a record of 3 clusters x 1 vectors"}, "size against the layout");
  edit(pad_at + 1, std::uint8_t(1), {"padding inside its record"}, "padding");
  edit(index_at + 7, std::uint8_t(3), {"row 7 of the compressed coefficients is in cluster 3; there are 3"}, "index");
  edit(r + 32 + 4 * 5, std::numeric_limits<float>::infinity(), {"non-finite mean"}, "mean");
  edit(weights_at + 2 * 4, std::int16_t(-32768), {"row 1 of the compressed coefficients has weight 1",
                                                   "within 32767 steps"}, "weight code out of range");
  // A compressed section in an uncompressed file.
  const Sample plain = sample_file(dir, t);
  std::string b = plain.bytes;
  put(b, kVersionAt, std::uint32_t(4));
  put(b, plain.section_at[0], std::uint32_t(8));
  put(b, plain.section_at[0] + 4, std::uint32_t(6));
  reseal(b);
  write_file(dir.file("bad.prtt"), b);
  expect_error_of(prt::read_transfer, dir.file("bad.prtt"), {"'compressed coefficients' section", "not compressed"},
                  "record in a plain file");
}

TEST(CompressedWrite, RefusesWhatCouldNotBeReadBack) {
  TempDir dir;
  prt::CompressedTransfer c = compressed(mixed_transfer(), 2, 3, 32);
  const std::string path = dir.file("out.prtt");
  const auto refused = [&](const prt::CompressedTransfer& bad, const std::string& words) {
    try {
      prt::write_compressed_transfer(path, bad);
      ADD_FAILURE() << "written: " << words;
    } catch (const prt::Error& e) {
      EXPECT_TRUE(contains(e.what(), path + ": cannot write this compressed transfer")) << e.what();
      EXPECT_TRUE(contains(e.what(), words)) << e.what();
    }
    EXPECT_FALSE(fs::exists(path));
  };
  prt::CompressedTransfer bad = c;
  bad.coeffs.cluster[5] = 2;
  refused(bad, "in cluster 2; there are 2");
  bad = c;
  bad.transfer.coeffs.assign(bad.transfer.stored_vertices() * bad.transfer.stride(), 0.0f);
  refused(bad, "in its clusters only");
  bad = c;
  bad.coeffs.weights.pop_back();
  refused(bad, "weights");
  bad = c;
  bad.coeffs.weight_bits = 16;
  refused(bad, "weight scales");
}

// ---- the compression choice record (version 6, kind 12) ----------------------------------

prt::CompressionChoiceRecord sample_choice() {
  prt::CompressionChoiceRecord r;
  r.target = 0.01;
  r.maps = {"sunset"};
  r.spectra = {"city", "studio"};
  r.sun = true;
  r.rotations = 24;
  r.seed = 7;
  r.eyes = 32;
  r.exponents = {4, 8};
  r.speculars = {0.5};
  r.mean = 0.004;
  r.p95 = 0.0087;
  r.max = 0.017;
  r.bound = 0.037;
  r.samples = 9216;
  r.vertices = 40;
  return r;
}

TEST(CompressedFile, ChoiceRecordRoundTripsAsVersionSix) {
  TempDir dir;
  prt::CompressedTransfer c = compressed(with_glossy(mixed_transfer()), 2, 3, 16);
  const std::uint64_t without = prt::transfer_file_size(c);
  c.choice = sample_choice();
  const Sample s = compressed_sample(dir, c);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 6u);
  EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(c));
  // The last section: kind 12, u8, its JSON's bytes.
  const std::size_t sec = s.section_at.back();
  const std::string json = prt::compression_choice_json(*c.choice);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, sec), 12u);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, sec + 4), 6u);
  EXPECT_EQ(get<std::uint64_t>(s.bytes, sec + 16), json.size());
  EXPECT_EQ(s.bytes.substr(sec + kSectionHeader, json.size()), json);
  EXPECT_EQ(prt::transfer_file_size(c), without + kSectionHeader + json.size() + (8 - json.size() % 8) % 8);
  const prt::CompressedTransfer back = prt::read_compressed_transfer(dir.file("sample.prtt"));
  ASSERT_TRUE(back.choice.has_value());
  EXPECT_EQ(prt::compression_choice_json(*back.choice), json);
  EXPECT_EQ(back.choice->spectra, c.choice->spectra);
  EXPECT_TRUE(back.choice->sun);
  EXPECT_EQ(back.choice->exponents, c.choice->exponents);
  EXPECT_EQ(back.choice->samples, 9216u);
  prt::write_compressed_transfer(dir.file("again.prtt"), back);
  EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
  const std::string d = prt::describe_transfer(back);
  for (const char* w : {"format version 6", "chosen for a p95 relit error of at most 1%", "sunset",
                        "those of city, studio in turn", "and a point light (the sun) x 24 rotations", "32 eyes",
                        "p95 0.870%", "bound 3.700%"})
    EXPECT_TRUE(contains(d, w)) << w << " in " << d;
  // Without a record: version 4, as before.
  c.choice.reset();
  EXPECT_EQ(get<std::uint32_t>(compressed_sample(dir, c).bytes, kVersionAt), 4u);
}

TEST(CompressedRead, BadChoiceRecordsAreRefusedByName) {
  TempDir dir;
  prt::CompressedTransfer c = compressed(mixed_transfer(), 2, 3, 16);
  c.choice = sample_choice();
  c.choice->eyes = 0;  // diffuse
  c.choice->exponents.clear();
  c.choice->speculars.clear();
  const Sample s = compressed_sample(dir, c);
  const std::size_t sec = s.section_at.back(), data = sec + kSectionHeader;
  const std::string json = prt::compression_choice_json(*c.choice);
  const auto with_json = [&](std::string text, const std::vector<std::string>& words, const std::string& what) {
    text.resize(json.size(), ' ');  // same length: the layout stays valid
    std::string b = s.bytes;
    b.replace(data, json.size(), text);
    reseal(b);
    write_file(dir.file("bad.prtt"), b);
    expect_error_of(prt::read_compressed_transfer, dir.file("bad.prtt"), words, what);
  };
  with_json("{\"target\": 0.01", {"bad section 'compression choice'", "not a JSON object"}, "truncated JSON");
  with_json("[1, 2]", {"not a JSON object"}, "an array");
  std::string missing = json;
  missing.replace(missing.find("\"rotations\""), 11, "\"rotationz\"");
  with_json(missing, {"'compression choice'", "rotations"}, "a key missing");
  std::string wrong = json;
  wrong.replace(wrong.find("\"p95\""), 5, "\"p96\"");
  with_json(wrong, {"statistic 'p96'"}, "an unknown statistic");
  std::string big = json;
  big.replace(big.find("0.01,"), 5, "1.50,");
  with_json(big, {"target 1.5 is not in (0, 1)"}, "a target out of range");
  // In an uncompressed file's version, and in a file that is not compressed.
  std::string b = s.bytes;
  put(b, kVersionAt, std::uint32_t(5));
  reseal(b);
  write_file(dir.file("bad.prtt"), b);
  expect_error_of(prt::read_compressed_transfer, dir.file("bad.prtt"), {"unknown kind 12 in a version 5 file"},
                  "kind 12 in version 5");
  // The writer refuses what the reader would.
  c.choice->rotations = 0;
  EXPECT_THROW(prt::write_compressed_transfer(dir.file("out.prtt"), c), prt::Error);
  EXPECT_FALSE(fs::exists(dir.file("out.prtt")));
}

// ---- interpolated vertices (version 7, kind 13; adaptive sample points) --------------------

// `t` with the vertices `interpolated(v)` selects marked interpolated.
template <typename Pick>
Transfer with_interpolated(Transfer t, Pick interpolated) {
  t.interpolated.assign(t.vertices, 0);
  for (std::size_t v = 0; v < t.vertices; ++v) t.interpolated[v] = interpolated(v) ? 1 : 0;
  return t;
}

// mixed_transfer() (every third vertex analytic) with every vertex but each
// fourth interpolated: 10 of 40 traced (0, 4, ..., 36), 30 interpolated,
// analytic ones among both (vertex 0 analytic and traced, 3 analytic and
// interpolated).
Transfer adaptive_transfer() {
  return with_interpolated(mixed_transfer(), [](std::size_t v) { return v % 4 != 0; });
}

// The mask words docs/FORMAT.md specifies for `t.interpolated`.
std::vector<std::uint32_t> interpolated_words(const Transfer& t) {
  std::vector<std::uint32_t> w((t.vertices + 31) / 32, 0u);
  for (std::size_t v = 0; v < t.vertices; ++v)
    if (t.interpolated[v]) w[v / 32] |= 1u << (v % 32);
  return w;
}

// Checks that the last section of `s` is the interpolated-vertex mask of `t`.
void expect_interpolated_section(const Sample& s, const Transfer& t) {
  const std::size_t at = s.section_at.back();
  const std::vector<std::uint32_t> words = interpolated_words(t);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, at), 13u);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, at + 4), 4u);  // u32
  EXPECT_EQ(get<std::uint64_t>(s.bytes, at + 8), words.size());
  EXPECT_EQ(get<std::uint64_t>(s.bytes, at + 16), 4 * words.size());
  for (std::size_t i = 0; i < words.size(); ++i)
    EXPECT_EQ(get<std::uint32_t>(s.bytes, at + kSectionHeader + 4 * i), words[i]) << "word " << i;
  const std::size_t padded = 4 * words.size() + (8 - 4 * words.size() % 8) % 8;
  EXPECT_EQ(s.bytes.size(), at + kSectionHeader + padded + kTrailer);  // the last section
}

TEST(TransferFile, InterpolatedVerticesRoundTripAsVersionSeven) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  // Vertex counts around the mask's 32-bit words; some, one (the last), all
  // interpolated; with and without analytic vertices.
  for (std::size_t vertices : {1u, 7u, 31u, 32u, 33u, 100u})
    for (int pattern = 0; pattern < 3; ++pattern)
      for (bool analytic : {false, true}) {
        const auto pick = [&](std::size_t v) {
          return pattern == 0 ? v % 3 != 1 || vertices == 1 : pattern == 1 ? v + 1 == vertices : true;
        };
        Transfer t = make_transfer(TransferMode::Interreflected, 3, 3, vertices, {true, true, true, true});
        if (analytic) t = with_analytic(t, [](std::size_t v) { return v % 2 == 0; });
        t = with_interpolated(t, pick);
        SCOPED_TRACE(std::to_string(vertices) + " vertices, pattern " + std::to_string(pattern) +
                     (analytic ? ", analytic ones" : ""));
        const Sample s = sample_file(dir, t);
        EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 7u);
        EXPECT_EQ(prt::transfer_format_version(t), 7u);
        EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(t));
        expect_interpolated_section(s, t);
        prt::write_transfer(path, t);
        const Transfer back = prt::read_transfer(path);
        expect_identical(t, back);
        EXPECT_EQ(back.interpolated_vertices(), t.interpolated_vertices());
        EXPECT_EQ(file_version(path), 7u);
        prt::write_transfer(dir.file("again.prtt"), back);
        EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
      }
  // Glossy too: version 7 (it holds version 3's kind 7 as well).
  const Transfer g = with_interpolated(with_glossy(mixed_transfer()), [](std::size_t v) { return v > 20; });
  const Sample s = sample_file(dir, g);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 7u);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[s.section_at.size() - 2]), 7u);
  expect_interpolated_section(s, g);
  expect_identical(prt::read_transfer(dir.file("sample.prtt")), g);
}

TEST(TransferFormat, InterpolatedVertexMaskIsWhereTheDocumentSays) {
  TempDir dir;
  const Transfer t = adaptive_transfer();
  const Sample s = sample_file(dir, t);
  ASSERT_EQ(get<std::uint32_t>(s.bytes, kSectionCountAt), 7u);
  // Kind 13 after kind 6, u32, (40 + 31) / 32 = 2 words: bit v % 32 of word v / 32.
  EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[5]), 6u);
  const std::size_t at = s.section_at[6];
  EXPECT_EQ(get<std::uint32_t>(s.bytes, at), 13u);
  EXPECT_EQ(get<std::uint64_t>(s.bytes, at + 8), 2u);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, at + kSectionHeader), 0xeeeeeeeeu);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, at + kSectionHeader + 4), 0xeeu);  // vertices 32-39; none past 39
  // The mask adds its section and changes nothing else but the version and count.
  const Sample before = sample_file(dir, mixed_transfer());
  EXPECT_EQ(s.bytes.size(), before.bytes.size() + kSectionHeader + 8);
  EXPECT_EQ(s.bytes.substr(kHeader, at - kHeader), before.bytes.substr(kHeader, at - kHeader));
  const auto sections = prt::transfer_sections(t);
  ASSERT_EQ(sections.size(), 7u);
  EXPECT_STREQ(sections.back().name, "interpolated vertices");
  EXPECT_STREQ(sections.back().type, "u32");
  EXPECT_FALSE(sections.back().per_vertex);
  // Not per vertex (as the analytic mask), and it saves nothing: the bytes
  // per vertex and the analytic vertices' saving are those without it.
  EXPECT_EQ(prt::transfer_bytes_per_vertex(t), prt::transfer_bytes_per_vertex(mixed_transfer()));
  EXPECT_EQ(prt::analytic_bytes_saved(t), prt::analytic_bytes_saved(mixed_transfer()));
}

// Nothing interpolated (no mask, or every flag 0): no section, and the file
// byte for byte what prt wrote before there were interpolated vertices.
TEST(TransferFile, NoInterpolatedVertexWritesTheFileOfBefore) {
  TempDir dir;
  for (const Transfer& base : {full_transfer(), mixed_transfer(), with_glossy(mixed_transfer())}) {
    const Sample plain = sample_file(dir, base);
    const std::uint32_t version = base.glossy ? 3u : 2u;
    EXPECT_EQ(get<std::uint32_t>(plain.bytes, kVersionAt), version);
    Transfer zeros = base;
    zeros.interpolated.assign(zeros.vertices, 0);
    EXPECT_EQ(prt::transfer_format_version(zeros), version);
    EXPECT_EQ(prt::transfer_file_size(zeros), plain.bytes.size());
    EXPECT_EQ(prt::transfer_sections(zeros).size(), prt::transfer_sections(base).size());
    EXPECT_EQ(sample_file(dir, zeros).bytes, plain.bytes);
    const Transfer back = prt::read_transfer(dir.file("sample.prtt"));
    EXPECT_TRUE(back.interpolated.empty());
    EXPECT_EQ(back.interpolated_vertices(), 0u);
    const std::string d = prt::describe_transfer(zeros);
    EXPECT_FALSE(contains(d, "interpolated")) << d;
    EXPECT_TRUE(contains(d, "format version " + std::to_string(version))) << d;
  }
}

TEST(TransferRead, BadInterpolatedVertexMask) {
  TempDir dir;
  const Sample s = sample_file(dir, adaptive_transfer());
  const std::size_t mask = s.section_at[6], words = mask + kSectionHeader;
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& expected, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, expected, what);
  };
  // The section in a file older than version 7.
  edit(kVersionAt, std::uint32_t(6),
       {"bad section table: section 7 of 7 has unknown kind 13 in a version 6 file",
        "'interpolated vertices' sections are version 7 and later"},
       "kind 13 in version 6");
  edit(kVersionAt, std::uint32_t(2), {"7 sections; at most 6 kinds exist in version 2"}, "kind 13 in version 2");
  edit(mask + 4, std::uint32_t(1), {"'interpolated vertices' has element type 1; expected 4 (u32)"}, "f32 mask");
  edit(mask + 8, std::uint64_t(3), {"section 'interpolated vertices' has 3 words; expected (vertices + 31) / 32 = 2"},
       "word count");
  edit(mask + 8, std::uint64_t(1), {"'interpolated vertices' has 1 words; expected (vertices + 31) / 32 = 2"},
       "word count too small");
  edit(mask + 16, std::uint64_t(12), {"2 u32 values but 12 bytes"}, "byte size");
  // Bits past vertex 39 (bit 8 of word 1) are not vertices.
  edit(words + 4, get<std::uint32_t>(s.bytes, words + 4) | (1u << 8),
       {"bad interpolated-vertex mask: bits set past the last vertex (40)"}, "tail bit");
  edit(words + 4, get<std::uint32_t>(s.bytes, words + 4) | 0x80000000u, {"bits set past the last vertex (40)"},
       "last bit of the last word");
  // An all-zero mask: a file must not carry an empty one.
  edit(words, std::uint64_t(0),
       {"bad interpolated-vertex mask: no vertex is marked interpolated", "an empty mask is not written"},
       "all-zero mask");
  // The compressed reader is the same reader.
  const Sample c = compressed_sample(dir, compressed(adaptive_transfer(), 2, 3, 16));
  std::string b = c.bytes;
  put(b, c.section_at.back() + kSectionHeader, std::uint64_t(0));
  reseal(b);
  write_file(dir.file("bad.prtt"), b);
  expect_error_of(prt::read_compressed_transfer, dir.file("bad.prtt"), {"no vertex is marked interpolated"},
                  "all-zero mask, compressed");
  b = c.bytes;
  put(b, kVersionAt, std::uint32_t(4));
  reseal(b);
  write_file(dir.file("bad.prtt"), b);
  expect_error_of(prt::read_compressed_transfer, dir.file("bad.prtt"),
                  {"unknown kind 13 in a version 4 file", "version 7 and later"}, "kind 13 in version 4");
}

TEST(TransferWrite, RefusesBadInterpolatedFlags) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  Transfer t = adaptive_transfer();
  t.interpolated.pop_back();
  EXPECT_EQ(prt::transfer_problem(t), "39 interpolated-vertex flags for 40 vertices (one per vertex, or none)");
  EXPECT_THROW(prt::write_transfer(path, t), prt::Error);
  t = adaptive_transfer();
  t.interpolated[5] = 2;
  EXPECT_EQ(prt::transfer_problem(t), "vertex 5 has interpolated-vertex flag 2; must be 0 (traced) or 1 (interpolated)");
  try {
    prt::write_transfer(path, t);
    ADD_FAILURE() << "wrote a flag of 2";
  } catch (const prt::Error& e) {
    EXPECT_EQ(std::string(e.what()), path + ": cannot write this transfer: " + prt::transfer_problem(t));
  }
  EXPECT_FALSE(fs::exists(path));
  EXPECT_EQ(prt::transfer_problem(adaptive_transfer()), "");
}

TEST(CompressedFile, KeepsInterpolatedVerticesAsVersionSeven) {
  TempDir dir;
  const Transfer t = adaptive_transfer();
  for (bool glossy : {false, true})
    for (bool choice : {false, true}) {
      SCOPED_TRACE(std::string(glossy ? "glossy" : "diffuse") + (choice ? ", with a choice record" : ""));
      prt::CompressedTransfer c = compressed(glossy ? with_glossy(t) : t, 2, 3, 16);
      EXPECT_EQ(c.transfer.interpolated, t.interpolated);  // compress_transfer keeps the mask
      if (choice) c.choice = sample_choice();
      EXPECT_EQ(prt::transfer_format_version(c), 7u);
      const Sample s = compressed_sample(dir, c);
      EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 7u);
      EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(c));
      // Kind 13 last, after the records (8, 9) and the choice (12).
      const std::size_t n = s.section_at.size();
      EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[n - 2]), choice ? 12u : glossy ? 9u : 8u);
      expect_interpolated_section(s, t);
      const prt::CompressedTransfer back = prt::read_compressed_transfer(dir.file("sample.prtt"));
      expect_identical(back.transfer, c.transfer);
      expect_same_signal(back.coeffs, c.coeffs);
      EXPECT_EQ(prt::decompress(back).interpolated, t.interpolated);
      prt::write_compressed_transfer(dir.file("again.prtt"), back);
      EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
      const std::string d = prt::describe_transfer(back);
      EXPECT_TRUE(contains(d, "format version 7")) << d;
      EXPECT_TRUE(contains(d, "traced 10 of 40 vertices (25.0%), 30 interpolated")) << d;
      // Without the mask: the version of before.
      c.transfer.interpolated.clear();
      EXPECT_EQ(get<std::uint32_t>(compressed_sample(dir, c).bytes, kVersionAt), choice ? 6u : 4u);
    }
}

// A 40-texel lightmap of an 8x8 atlas (texels 3 to 42): shadowed, grey, with
// ambient occlusion; every third texel analytic when `analytic`.
prt::LightmapTransfer sample_lightmap(bool analytic = false) {
  prt::LightmapTransfer l;
  l.transfer = make_transfer(TransferMode::Shadowed, 1, 2, 40, {false, true, false, false});
  l.transfer.vertex_colors = false;
  if (analytic) l.transfer = with_analytic(l.transfer, [](std::size_t v) { return v % 3 == 0; });
  l.layout.width = l.layout.height = 8;
  for (std::uint32_t i = 0; i < 40; ++i) l.layout.texels.push_back(i + 3);
  l.layout.scene_hash = 0x1234;
  return l;
}

Sample lightmap_sample(const TempDir& dir, const prt::LightmapTransfer& l) {
  const std::string path = dir.file("lightmap.prtt");
  prt::write_lightmap_transfer(path, l);
  return sample_of(path);
}

// Adaptive sample points among a lightmap's texels (prt precompute --lightmap
// --adaptive): the mask over the texels after the layout and texels, version 7.
TEST(LightmapFile, InterpolatedTexelsRoundTripAsVersionSeven) {
  TempDir dir;
  for (bool analytic : {false, true}) {
    SCOPED_TRACE(analytic ? "analytic texels" : "every texel stored");
    prt::LightmapTransfer l = sample_lightmap(analytic);
    l.transfer = with_interpolated(l.transfer, [](std::size_t v) { return v % 4 != 0; });  // 10 of 40 traced
    EXPECT_EQ(prt::transfer_format_version(l), 7u);
    const Sample s = lightmap_sample(dir, l);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 7u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, kFlagsAt) & 8u, 8u);  // flag bit 3: a lightmap
    EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(l));
    const std::size_t n = s.section_at.size();
    ASSERT_GE(n, 3u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[n - 3]), 10u);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[n - 2]), 11u);
    expect_interpolated_section(s, l.transfer);
    const auto sections = prt::transfer_sections(l);
    ASSERT_EQ(sections.size(), n);
    EXPECT_EQ(sections.back().kind, 13u);
    const std::string path = dir.file("lightmap.prtt");
    const prt::LightmapTransfer back = prt::read_lightmap_transfer(path);
    expect_identical(l.transfer, back.transfer);
    EXPECT_EQ(back.transfer.interpolated_vertices(), 30u);
    EXPECT_EQ(back.layout.texels, l.layout.texels);
    EXPECT_EQ(back.layout.scene_hash, l.layout.scene_hash);
    std::uint32_t version = 0;
    EXPECT_EQ(prt::kind_of(prt::read_transfer_file(path, &version)), prt::TransferKind::Lightmap);
    EXPECT_EQ(version, 7u);
    expect_error_of(prt::read_transfer, path, {"holds a lightmap"}, "read_transfer of a version 7 lightmap");
    prt::write_lightmap_transfer(dir.file("again.prtt"), back);
    EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
    const std::string d = prt::describe_transfer(back);
    EXPECT_TRUE(contains(d, "format version 7")) << d;
    EXPECT_TRUE(contains(d, "traced 10 of 40 texels (25.0%), 30 interpolated")) << d;
    EXPECT_TRUE(contains(d, "lightmap texels")) << d;  // the file's own sections
    EXPECT_TRUE(contains(d, " " + std::to_string(s.bytes.size()) + " bytes\n")) << d;  // the file size
  }
}

// Nothing interpolated (no flags, or every flag 0): the version 5 file of
// before, byte for byte; the mask adds only its section (and the version and
// count).
TEST(LightmapFile, NoInterpolatedTexelWritesTheFileOfBefore) {
  TempDir dir;
  const prt::LightmapTransfer l = sample_lightmap(true);
  const Sample plain = lightmap_sample(dir, l);
  EXPECT_EQ(get<std::uint32_t>(plain.bytes, kVersionAt), 5u);
  EXPECT_EQ(prt::transfer_format_version(l), 5u);
  for (std::size_t at : plain.section_at) EXPECT_NE(get<std::uint32_t>(plain.bytes, at), 13u);
  EXPECT_EQ(get<std::uint32_t>(plain.bytes, plain.section_at.back()), 11u);
  prt::LightmapTransfer zeros = l;
  zeros.transfer.interpolated.assign(40, 0);
  EXPECT_EQ(prt::transfer_format_version(zeros), 5u);
  EXPECT_EQ(prt::transfer_sections(zeros).size(), prt::transfer_sections(l).size());
  EXPECT_EQ(lightmap_sample(dir, zeros).bytes, plain.bytes);
  const prt::LightmapTransfer back = prt::read_lightmap_transfer(dir.file("lightmap.prtt"));
  EXPECT_TRUE(back.transfer.interpolated.empty());
  const std::string d = prt::describe_transfer(back);
  EXPECT_TRUE(contains(d, "format version 5")) << d;
  EXPECT_FALSE(contains(d, "interpolated")) << d;

  // With the mask: the same bytes up to it.
  prt::LightmapTransfer adaptive = l;
  adaptive.transfer = with_interpolated(l.transfer, [](std::size_t v) { return v == 39; });
  const Sample m = lightmap_sample(dir, adaptive);
  const std::size_t at = m.section_at.back();
  EXPECT_EQ(m.bytes.size(), plain.bytes.size() + kSectionHeader + 8);
  EXPECT_EQ(m.bytes.substr(kHeader, at - kHeader), plain.bytes.substr(kHeader, plain.bytes.size() - kTrailer - kHeader));
  std::string without = m.bytes.substr(0, at) + m.bytes.substr(m.bytes.size() - kTrailer);
  put<std::uint32_t>(without, kVersionAt, 5);
  put<std::uint32_t>(without, kSectionCountAt, get<std::uint32_t>(m.bytes, kSectionCountAt) - 1);
  reseal(without);
  EXPECT_EQ(without, plain.bytes);
}

// A lightmap's mask is checked as a per-vertex file's; the texels' are its rows.
TEST(LightmapRead, BadInterpolatedTexelMask) {
  TempDir dir;
  prt::LightmapTransfer l = sample_lightmap();
  l.transfer = with_interpolated(l.transfer, [](std::size_t v) { return v % 4 != 0; });
  const Sample s = lightmap_sample(dir, l);
  const std::size_t mask = s.section_at.back(), words = mask + kSectionHeader;
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& expected, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    write_file(dir.file("bad.prtt"), b);
    expect_error_of(prt::read_lightmap_transfer, dir.file("bad.prtt"), expected, what);
  };
  edit(kVersionAt, std::uint32_t(5), {"unknown kind 13 in a version 5 file", "version 7 and later"},
       "kind 13 in a version 5 lightmap");
  edit(kVersionAt, std::uint32_t(6), {"unknown kind 13 in a version 6 file"}, "kind 13 in a version 6 lightmap");
  edit(mask + 8, std::uint64_t(1), {"'interpolated vertices' has 1 words; expected (vertices + 31) / 32 = 2"},
       "word count");
  edit(words + 4, get<std::uint32_t>(s.bytes, words + 4) | (1u << 8), {"bits set past the last vertex (40)"},
       "tail bit");
  edit(words, std::uint64_t(0), {"no vertex is marked interpolated"}, "all-zero mask");
  // The mask before the layout: out of order.
  std::string b = s.bytes.substr(0, s.section_at[s.section_at.size() - 3]) +
                  s.bytes.substr(mask, s.bytes.size() - kTrailer - mask) +
                  s.bytes.substr(s.section_at[s.section_at.size() - 3], mask - s.section_at[s.section_at.size() - 3]) +
                  s.bytes.substr(s.bytes.size() - kTrailer);
  reseal(b);
  write_file(dir.file("bad.prtt"), b);
  expect_error_of(prt::read_lightmap_transfer, dir.file("bad.prtt"), {"out of order"}, "mask before the layout");
  // The writer refuses flags the reader would.
  prt::LightmapTransfer bad = l;
  bad.transfer.interpolated.pop_back();
  EXPECT_THROW(prt::write_lightmap_transfer(dir.file("w.prtt"), bad), prt::Error);
  EXPECT_FALSE(fs::exists(dir.file("w.prtt")));
}

// ---- the light-bounce operator (version 8, kinds 14-19; 9 with cluster rows, 20-22; prt/light_bounce.h) ----

// A valid operator over `points` points (a transfer's vertices, a lightmap's
// covered texels): point i in patch i % 3 of the finest level, patches 0 and
// 1 in the coarser patch 3 (4 patches of two levels). The rows of patch 0
// reach patches 1 and 2, those of 1 reach 0 and 2, those of 2 the coarse 3;
// every fifth row reaches none. Random weights, half-precision values (what
// an operator holds: files store 16 bits), none round: the round trip is
// bit for bit. 40 points: 21 rows of 2 entries, 11 of 1: 53.
prt::LightBounce sample_light_bounce(std::size_t points, int bounces = 2) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<float> weight(0.0f, 2.0f);
  const std::vector<std::uint32_t> reach[3] = {{1, 2}, {0, 2}, {3}};
  prt::LightBounce b;
  b.bounces = bounces;
  b.patches = 4;
  b.parent = {3, 3, prt::LightBounce::kNoParent, prt::LightBounce::kNoParent};
  b.offsets.push_back(0);
  for (std::size_t i = 0; i < points; ++i) {
    b.patch.push_back(std::uint32_t(i % 3));
    if (i % 5 != 4)
      for (std::uint32_t p : reach[i % 3]) {
        b.source.push_back(p);
        b.weight.push_back(glm::unpackHalf1x16(glm::packHalf1x16(weight(rng))));
      }
    b.offsets.push_back(std::uint32_t(b.source.size()));
  }
  return b;
}

// `t` (interreflected) with sample_light_bounce over its vertices.
Transfer with_light_bounce(Transfer t, int bounces = 2) {
  t.light_bounce = sample_light_bounce(t.vertices, bounces);
  return t;
}

// `b` (sample_light_bounce's 4 patches) with cluster rows, as
// prt::link_clusters makes them: patch 0's row reaches patches 2 and 3,
// patch 1's none, patch 2's patch 0, the coarse patch 3's patch 2 (4 cluster
// entries, 3 clusters with rows). Random half-precision weights, none round.
prt::LightBounce with_cluster_rows(prt::LightBounce b) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<float> weight(0.0f, 2.0f);
  const std::vector<std::uint32_t> reach[4] = {{2, 3}, {}, {0}, {2}};
  b.cluster_offsets.assign(1, 0);
  for (const auto& row : reach) {
    for (std::uint32_t p : row) {
      b.cluster_source.push_back(p);
      b.cluster_weight.push_back(glm::unpackHalf1x16(glm::packHalf1x16(weight(rng))));
    }
    b.cluster_offsets.push_back(std::uint32_t(b.cluster_source.size()));
  }
  return b;
}

// `t` (interreflected) with sample_light_bounce and its cluster rows.
Transfer with_clustered_light_bounce(Transfer t, int bounces = 2) {
  t.light_bounce = with_cluster_rows(sample_light_bounce(t.vertices, bounces));
  return t;
}

// `b` (sample_light_bounce's 4 patches) with probe rows on a 2 x 2 x 2 grid
// of 3 bands (9 weights an entry), as prt precompute --light-bounce --probes
// makes them: probe q's row reaches patch p < 3 when bit p of q is set, and
// probe 7's the coarse patch 3 too (probe 0's none): 13 entries, 117
// weights (odd: padding). Random half-precision weights of either sign (SH
// coefficients), none round; a box with no round bound.
prt::LightBounce with_probe_rows(prt::LightBounce b) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<float> weight(-2.0f, 2.0f);
  prt::LightBounce::ProbeRows& r = b.probes;
  r.dims = {2, 2, 2};
  r.min = {-1.25, -0.5, -2.0 / 3.0};
  r.max = {1.0 / 3.0, 0.75, 2.5};
  r.bands = 3;
  r.offsets.assign(1, 0);
  for (std::uint32_t q = 0; q < 8; ++q) {
    for (std::uint32_t p = 0; p < 4; ++p) {
      if (p < 3 ? ((q >> p) & 1u) == 0 : q != 7) continue;
      r.source.push_back(p);
      for (int k = 0; k < 9; ++k) r.weight.push_back(glm::unpackHalf1x16(glm::packHalf1x16(weight(rng))));
    }
    r.offsets.push_back(std::uint32_t(r.source.size()));
  }
  return b;
}

// `t` (interreflected) with sample_light_bounce and its probe rows.
Transfer with_probed_light_bounce(Transfer t, int bounces = 2) {
  t.light_bounce = with_probe_rows(sample_light_bounce(t.vertices, bounces));
  return t;
}

// sample_lightmap made interreflected (2 bounces): a lightmap that may keep an operator.
prt::LightmapTransfer interreflected_lightmap(bool analytic = false) {
  prt::LightmapTransfer l = sample_lightmap(analytic);
  l.transfer.mode = TransferMode::Interreflected;
  l.transfer.bounces = 2;
  return l;
}

// The offset of the section of `kind` in `s`.
std::size_t section_of(const Sample& s, std::uint32_t kind) {
  for (std::size_t at : s.section_at)
    if (get<std::uint32_t>(s.bytes, at) == kind) return at;
  ADD_FAILURE() << "no section of kind " << kind;
  return 0;
}

// Section `i` of `s` as stored: head, data and padding.
std::string section_bytes(const Sample& s, std::size_t i) {
  const std::size_t end = i + 1 < s.section_at.size() ? s.section_at[i + 1] : s.bytes.size() - kTrailer;
  return s.bytes.substr(s.section_at[i], end - s.section_at[i]);
}

// The file `s` without the sections whose kind `drop` picks, as version
// `version`, its section count lowered, resealed.
template <typename Pick>
std::string without_sections(const Sample& s, Pick drop, std::uint32_t version) {
  std::string out = s.bytes.substr(0, kHeader);
  std::uint32_t kept = 0;
  for (std::size_t i = 0; i < s.section_at.size(); ++i)
    if (!drop(get<std::uint32_t>(s.bytes, s.section_at[i]))) {
      out += section_bytes(s, i);
      ++kept;
    }
  out += s.bytes.substr(s.bytes.size() - kTrailer);
  put<std::uint32_t>(out, kVersionAt, version);
  put<std::uint32_t>(out, kSectionCountAt, kept);
  reseal(out);
  return out;
}

// Checks that the last sections of `s` are those docs/FORMAT.md specifies
// for `b`: kinds 14 to 19, u32 bounces and patches, u32 per point, u32 per
// point and one more, u32 and f16 (IEEE 754 binary16) per entry, u32 per
// patch; then, when `b` has cluster rows, kinds 20 to 22, u32 per patch and
// one more, u32 and f16 per cluster entry; then, when it has probe rows,
// kinds 23 to 27, u32 NX, NY, NZ and bands, f64 min and max, u32 per probe
// and one more, u32 per probe entry and bands^2 f16 per probe entry; the
// arrays in order.
void expect_light_bounce_sections(const Sample& s, const prt::LightBounce& b) {
  const bool clusters = !b.cluster_offsets.empty(), probes = !b.probes.empty();
  const std::size_t n = s.section_at.size(), points = b.patch.size(), entries = b.source.size(),
                    cluster_entries = b.cluster_source.size(), probe_entries = b.probes.source.size();
  // Kind, element type (4 u32, 8 f16, 2 f64), element bytes, count.
  struct Head {
    std::uint32_t kind, type, size;
    std::size_t count;
  };
  std::vector<Head> heads = {{14, 4, 4, 2},        {15, 4, 4, points},  {16, 4, 4, points + 1},
                             {17, 4, 4, entries},  {18, 8, 2, entries}, {19, 4, 4, b.patches}};
  if (clusters)
    heads.insert(heads.end(), {{20, 4, 4, b.patches + std::size_t(1)},
                               {21, 4, 4, cluster_entries},
                               {22, 8, 2, cluster_entries}});
  const std::size_t probe_count = probes ? b.probes.offsets.size() - 1 : 0,
                    per_entry = std::size_t(b.probes.bands * b.probes.bands);
  if (probes)
    heads.insert(heads.end(), {{23, 4, 4, 4},
                               {24, 2, 8, 6},
                               {25, 4, 4, probe_count + 1},
                               {26, 4, 4, probe_entries},
                               {27, 8, 2, probe_entries * per_entry}});
  ASSERT_GE(n, heads.size());
  const std::size_t first = n - heads.size();
  for (std::size_t i = 0; i < heads.size(); ++i) {
    const std::size_t at = s.section_at[first + i];
    SCOPED_TRACE("section of kind " + std::to_string(heads[i].kind));
    EXPECT_EQ(get<std::uint32_t>(s.bytes, at), heads[i].kind);
    EXPECT_EQ(get<std::uint32_t>(s.bytes, at + 4), heads[i].type);
    EXPECT_EQ(get<std::uint64_t>(s.bytes, at + 8), heads[i].count);
    EXPECT_EQ(get<std::uint64_t>(s.bytes, at + 16), heads[i].size * heads[i].count);
  }
  const auto data = [&](std::size_t i, std::size_t k) {
    return s.section_at[first + i] + kSectionHeader + heads[i].size * k;
  };
  EXPECT_EQ(get<std::uint32_t>(s.bytes, data(0, 0)), std::uint32_t(b.bounces));
  EXPECT_EQ(get<std::uint32_t>(s.bytes, data(0, 1)), b.patches);
  for (std::size_t k = 0; k < points; ++k) EXPECT_EQ(get<std::uint32_t>(s.bytes, data(1, k)), b.patch[k]) << k;
  for (std::size_t k = 0; k <= points; ++k) EXPECT_EQ(get<std::uint32_t>(s.bytes, data(2, k)), b.offsets[k]) << k;
  for (std::size_t k = 0; k < entries; ++k) {
    EXPECT_EQ(get<std::uint32_t>(s.bytes, data(3, k)), b.source[k]) << k;
    EXPECT_EQ(get<std::uint16_t>(s.bytes, data(4, k)), glm::packHalf1x16(b.weight[k])) << k;
  }
  for (std::size_t k = 0; k < b.patches; ++k) EXPECT_EQ(get<std::uint32_t>(s.bytes, data(5, k)), b.parent[k]) << k;
  if (clusters) {
    for (std::size_t k = 0; k <= b.patches; ++k)
      EXPECT_EQ(get<std::uint32_t>(s.bytes, data(6, k)), b.cluster_offsets[k]) << k;
    for (std::size_t k = 0; k < cluster_entries; ++k) {
      EXPECT_EQ(get<std::uint32_t>(s.bytes, data(7, k)), b.cluster_source[k]) << k;
      EXPECT_EQ(get<std::uint16_t>(s.bytes, data(8, k)), glm::packHalf1x16(b.cluster_weight[k])) << k;
    }
  }
  if (probes) {
    const std::size_t p = clusters ? 9 : 6;  // the grid's section
    const prt::LightBounce::ProbeRows& r = b.probes;
    for (std::size_t a = 0; a < 3; ++a) EXPECT_EQ(get<std::uint32_t>(s.bytes, data(p, a)), std::uint32_t(r.dims[a]));
    EXPECT_EQ(get<std::uint32_t>(s.bytes, data(p, 3)), std::uint32_t(r.bands));
    for (int a = 0; a < 3; ++a) {
      EXPECT_EQ(get<double>(s.bytes, data(p + 1, std::size_t(a))), r.min[a]) << a;
      EXPECT_EQ(get<double>(s.bytes, data(p + 1, std::size_t(a) + 3)), r.max[a]) << a;
    }
    for (std::size_t k = 0; k <= probe_count; ++k)
      EXPECT_EQ(get<std::uint32_t>(s.bytes, data(p + 2, k)), r.offsets[k]) << k;
    for (std::size_t k = 0; k < probe_entries; ++k)
      EXPECT_EQ(get<std::uint32_t>(s.bytes, data(p + 3, k)), r.source[k]) << k;
    for (std::size_t k = 0; k < r.weight.size(); ++k)
      EXPECT_EQ(get<std::uint16_t>(s.bytes, data(p + 4, k)), glm::packHalf1x16(r.weight[k])) << k;
  }
  // The last section ends the data: its padding, then the trailer.
  const Head& last = heads.back();
  EXPECT_EQ(s.bytes.size(), data(heads.size() - 1, last.count) + (8 - last.size * last.count % 8) % 8 + kTrailer);
}

// Writes `t` (an operator's transfer), expects the file of `version` of the
// size it says, holding the operator's sections, read back identical and
// written again (to `path`) byte for byte; returns its bytes.
Sample expect_round_trip(const TempDir& dir, const std::string& path, const Transfer& t, std::uint32_t version) {
  EXPECT_EQ(prt::transfer_format_version(t), version);
  const Sample s = sample_file(dir, t);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), version);
  EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(t));
  expect_light_bounce_sections(s, t.light_bounce);
  const Transfer back = prt::read_transfer(dir.file("sample.prtt"));
  expect_identical(t, back);
  EXPECT_EQ(file_version(dir.file("sample.prtt")), version);
  prt::write_transfer(path, back);
  EXPECT_EQ(read_file(path), s.bytes);
  return s;
}

TEST(LightBounceFile, RoundTripIsBitIdenticalAsVersionEight) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  // Rows of every vertex, analytic (stored nothing else) and interpolated
  // ones (kind 13 before 14) included; 7 vertices (odd sizes: padding); one
  // bounce and the most; an operator without entries (every row empty).
  prt::LightBounce no_entries = sample_light_bounce(40);
  no_entries.offsets.assign(41, 0);
  no_entries.source.clear();
  no_entries.weight.clear();
  Transfer empty_rows = full_transfer();
  empty_rows.light_bounce = no_entries;
  const std::vector<std::pair<std::string, Transfer>> cases = {
      {"every vertex stored", with_light_bounce(full_transfer())},
      {"analytic vertices", with_light_bounce(mixed_transfer())},
      {"interpolated vertices", with_light_bounce(adaptive_transfer())},
      {"7 vertices, 1 bounce", with_light_bounce(full_transfer(7), 1)},
      {"the most bounces", with_light_bounce(full_transfer(), prt::kMaxLightBounces)},
      {"no entries", empty_rows},
  };
  for (const auto& [what, t] : cases) {
    SCOPED_TRACE(what);
    ASSERT_EQ(prt::transfer_problem(t), "");
    const Sample s = expect_round_trip(dir, path, t, 8u);
    // Without the operator: the file of before, byte for byte (its own
    // version, no kinds 14-19); the operator adds only its six sections.
    Transfer plain = t;
    plain.light_bounce = {};
    const std::uint32_t before = prt::transfer_format_version(plain);
    EXPECT_LT(before, 8u);
    EXPECT_EQ(prt::transfer_sections(t).size(), prt::transfer_sections(plain).size() + 6);
    EXPECT_EQ(without_sections(s, [](std::uint32_t kind) { return kind >= 14; }, before),
              sample_file(dir, plain).bytes);
    // Not per vertex: the bytes per vertex are the transfer's.
    EXPECT_EQ(prt::transfer_bytes_per_vertex(t), prt::transfer_bytes_per_vertex(plain));
  }
}

// An operator's cluster rows (prt::link_clusters): kinds 20 to 22 after the
// six, version 9; the same operator without them stays the version 8 file.
TEST(LightBounceFile, ClusterRowsRoundTripBitIdenticalAsVersionNine) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  // Hand-made rows over every vertex stored, analytic and interpolated
  // vertices, 7 vertices (odd sizes: padding); link_clusters' own rows; and
  // cluster rows of which none has an entry (the offsets say there are rows:
  // still version 9, sources and weights empty).
  Transfer no_cluster_entries = with_light_bounce(full_transfer());
  no_cluster_entries.light_bounce.cluster_offsets.assign(5, 0);
  Transfer linked = with_light_bounce(full_transfer());
  linked.light_bounce = prt::link_clusters(linked.light_bounce, 0);
  ASSERT_FALSE(linked.light_bounce.cluster_source.empty());  // patch 2's rows reach the coarse patch 3
  const std::vector<std::pair<std::string, Transfer>> cases = {
      {"every vertex stored", with_clustered_light_bounce(full_transfer())},
      {"analytic vertices", with_clustered_light_bounce(mixed_transfer())},
      {"interpolated vertices", with_clustered_light_bounce(adaptive_transfer())},
      {"7 vertices, 1 bounce", with_clustered_light_bounce(full_transfer(7), 1)},
      {"link_clusters", linked},
      {"no cluster entries", no_cluster_entries},
  };
  for (const auto& [what, t] : cases) {
    SCOPED_TRACE(what);
    ASSERT_EQ(prt::transfer_problem(t), "");
    const Sample s = expect_round_trip(dir, path, t, 9u);
    // Without the cluster rows: the version 8 file, byte for byte; the rows
    // add only their three sections.
    Transfer flat = t;
    flat.light_bounce.cluster_offsets.clear();
    flat.light_bounce.cluster_source.clear();
    flat.light_bounce.cluster_weight.clear();
    EXPECT_EQ(prt::transfer_format_version(flat), 8u);
    EXPECT_EQ(prt::transfer_sections(t).size(), prt::transfer_sections(flat).size() + 3);
    EXPECT_EQ(without_sections(s, [](std::uint32_t kind) { return kind >= 20; }, 8), sample_file(dir, flat).bytes);
    EXPECT_EQ(prt::transfer_bytes_per_vertex(t), prt::transfer_bytes_per_vertex(flat));
  }
  // A lightmap's: after the layout, texels and the six.
  prt::LightmapTransfer l = interreflected_lightmap(true);
  l.transfer.light_bounce = with_cluster_rows(sample_light_bounce(40));
  EXPECT_EQ(prt::transfer_format_version(l), 9u);
  const Sample ls = lightmap_sample(dir, l);
  EXPECT_EQ(get<std::uint32_t>(ls.bytes, kVersionAt), 9u);
  EXPECT_EQ(ls.bytes.size(), prt::transfer_file_size(l));
  expect_light_bounce_sections(ls, l.transfer.light_bounce);
  const prt::LightmapTransfer lback = prt::read_lightmap_transfer(dir.file("lightmap.prtt"));
  expect_identical(l.transfer, lback.transfer);
  prt::write_lightmap_transfer(dir.file("again.prtt"), lback);
  EXPECT_EQ(read_file(dir.file("again.prtt")), ls.bytes);
  EXPECT_TRUE(contains(prt::describe_transfer(lback), "format version 9"));
  l.transfer.light_bounce = sample_light_bounce(40);
  EXPECT_EQ(prt::transfer_format_version(l), 8u);
}

// An operator's probe rows (prt precompute --light-bounce --probes): kinds
// 23 to 27 after the six (and the cluster rows' three), version 10; the
// same operator without them stays the version 9 (or 8) file, byte for
// byte.
TEST(LightBounceFile, ProbeRowsRoundTripBitIdenticalAsVersionTen) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  // Over every vertex stored, analytic and interpolated vertices, 7
  // vertices and one bounce; with cluster rows too; and probe rows of which
  // none has an entry (the offsets say there are rows: still version 10).
  Transfer no_probe_entries = with_probed_light_bounce(full_transfer());
  prt::LightBounce::ProbeRows& empty = no_probe_entries.light_bounce.probes;
  empty.offsets.assign(9, 0);
  empty.source.clear();
  empty.weight.clear();
  Transfer clustered = with_clustered_light_bounce(full_transfer());
  clustered.light_bounce = with_probe_rows(clustered.light_bounce);
  const std::vector<std::pair<std::string, Transfer>> cases = {
      {"every vertex stored", with_probed_light_bounce(full_transfer())},
      {"analytic vertices", with_probed_light_bounce(mixed_transfer())},
      {"interpolated vertices", with_probed_light_bounce(adaptive_transfer())},
      {"7 vertices, 1 bounce", with_probed_light_bounce(full_transfer(7), 1)},
      {"cluster rows too", clustered},
      {"no probe entries", no_probe_entries},
  };
  for (const auto& [what, t] : cases) {
    SCOPED_TRACE(what);
    ASSERT_EQ(prt::transfer_problem(t), "");
    const Sample s = expect_round_trip(dir, path, t, 10u);
    // Without the probe rows: the file of before, byte for byte (version 9
    // with cluster rows, else 8); the rows add only their five sections.
    Transfer flat = t;
    flat.light_bounce.probes = {};
    const std::uint32_t before = t.light_bounce.cluster_offsets.empty() ? 8u : 9u;
    EXPECT_EQ(prt::transfer_format_version(flat), before);
    EXPECT_EQ(prt::transfer_sections(t).size(), prt::transfer_sections(flat).size() + 5);
    EXPECT_EQ(without_sections(s, [](std::uint32_t kind) { return kind >= 23; }, before),
              sample_file(dir, flat).bytes);
    EXPECT_EQ(prt::transfer_bytes_per_vertex(t), prt::transfer_bytes_per_vertex(flat));
  }
  // A lightmap's: after the layout, texels and the six.
  prt::LightmapTransfer l = interreflected_lightmap(true);
  l.transfer.light_bounce = with_probe_rows(sample_light_bounce(40));
  EXPECT_EQ(prt::transfer_format_version(l), 10u);
  const Sample ls = lightmap_sample(dir, l);
  EXPECT_EQ(get<std::uint32_t>(ls.bytes, kVersionAt), 10u);
  EXPECT_EQ(ls.bytes.size(), prt::transfer_file_size(l));
  expect_light_bounce_sections(ls, l.transfer.light_bounce);
  const prt::LightmapTransfer lback = prt::read_lightmap_transfer(dir.file("lightmap.prtt"));
  expect_identical(l.transfer, lback.transfer);
  prt::write_lightmap_transfer(dir.file("again.prtt"), lback);
  EXPECT_EQ(read_file(dir.file("again.prtt")), ls.bytes);
  EXPECT_TRUE(contains(prt::describe_transfer(lback), "format version 10"));
  l.transfer.light_bounce.probes = {};
  EXPECT_EQ(prt::transfer_format_version(l), 8u);
  EXPECT_EQ(without_sections(ls, [](std::uint32_t kind) { return kind >= 23; }, 8), lightmap_sample(dir, l).bytes);
}

// Files an earlier prt wrote (the fuzz corpus's seeds, made by prt
// precompute and prt compress: every version from 2 to 7), read and written
// again: the same version and bytes. A transfer without an operator is
// written as it was before version 8.
TEST(TransferFile, FilesOfEarlierVersionsAreWrittenAgainByteForByte) {
  TempDir dir;
  const fs::path corpus = fs::path(PRT_SOURCE_DIR) / "tests" / "fuzz" / "corpus" / "transfer";
  std::vector<std::uint32_t> versions;
  for (const char* name : {"seed-unshadowed-b2.prt", "seed-shadowed-b3.prt", "seed-interreflected-colour.prt",
                           "seed-compressed-b3-w16.prt", "seed-compressed-chosen.prt", "seed-compressed-glossy.prt",
                           "seed-adaptive-b1.prt", "seed-lightmap-b1.prt", "seed-lightmap-adaptive-b1.prt"}) {
    SCOPED_TRACE(name);
    const std::string in = (corpus / name).string();
    ASSERT_TRUE(fs::exists(in)) << in;
    std::uint32_t version = 0;
    const prt::AnyTransfer any = prt::read_transfer_file(in, &version);
    versions.push_back(version);
    const std::string out = dir.file("again.prtt");
    prt::write_transfer_file(out, any);
    EXPECT_EQ(read_file(out), read_file(in));
    EXPECT_EQ(file_version(out), version);
  }
  std::sort(versions.begin(), versions.end());
  EXPECT_EQ(versions.front(), 2u);
  EXPECT_EQ(versions.back(), 7u);
}

// A lightmap's operator: a row per covered texel, its sections after the
// layout and texels (and the interpolated-texel mask).
TEST(LightmapFile, LightBounceRoundTripsAsVersionEight) {
  TempDir dir;
  for (bool analytic : {false, true})
    for (bool interpolated : {false, true}) {
      SCOPED_TRACE(std::string(analytic ? "analytic texels" : "every texel stored") +
                   (interpolated ? ", interpolated texels" : ""));
      prt::LightmapTransfer plain = interreflected_lightmap(analytic);
      if (interpolated) plain.transfer = with_interpolated(plain.transfer, [](std::size_t v) { return v % 4 != 0; });
      prt::LightmapTransfer l = plain;
      l.transfer.light_bounce = sample_light_bounce(40);
      EXPECT_EQ(prt::transfer_format_version(l), 8u);
      const Sample s = lightmap_sample(dir, l);
      EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 8u);
      EXPECT_EQ(get<std::uint32_t>(s.bytes, kFlagsAt) & 8u, 8u);  // flag bit 3: a lightmap
      EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(l));
      const std::size_t n = s.section_at.size(), mask = interpolated ? 1 : 0;
      ASSERT_GE(n, 8 + mask);
      EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[n - 8 - mask]), 10u);
      EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[n - 7 - mask]), 11u);
      if (interpolated) {
        EXPECT_EQ(get<std::uint32_t>(s.bytes, s.section_at[n - 7]), 13u);
      }
      expect_light_bounce_sections(s, l.transfer.light_bounce);
      const std::string path = dir.file("lightmap.prtt");
      const prt::LightmapTransfer back = prt::read_lightmap_transfer(path);
      expect_identical(l.transfer, back.transfer);
      EXPECT_EQ(back.layout.texels, l.layout.texels);
      std::uint32_t version = 0;
      EXPECT_EQ(prt::kind_of(prt::read_transfer_file(path, &version)), prt::TransferKind::Lightmap);
      EXPECT_EQ(version, 8u);
      prt::write_lightmap_transfer(dir.file("again.prtt"), back);
      EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
      const std::string d = prt::describe_transfer(back);
      EXPECT_TRUE(contains(d, "format version 8")) << d;
      EXPECT_TRUE(contains(d, "per receiver (texel)")) << d;
      // Without it: the version 5 (7 with the mask) file of before, byte for byte.
      const std::uint32_t before = interpolated ? 7u : 5u;
      EXPECT_EQ(prt::transfer_format_version(plain), before);
      EXPECT_EQ(without_sections(s, [](std::uint32_t kind) { return kind >= 14; }, before),
                lightmap_sample(dir, plain).bytes);
    }
}

// A compressed file (file version `version`) followed by the last
// `sections` sections of `s` is refused by read_compressed_transfer, naming
// the first of them (`first`): an operator's rows are never a compressed
// file's.
void expect_compressed_refuses(const TempDir& dir, const Sample& s, std::size_t sections, std::uint32_t version,
                               const std::string& first) {
  const Sample c = compressed_sample(dir, compressed(full_transfer(), 2, 3, 16));
  std::string b = c.bytes.substr(0, c.bytes.size() - kTrailer);
  for (std::size_t i = s.section_at.size() - sections; i < s.section_at.size(); ++i) b += section_bytes(s, i);
  b += c.bytes.substr(c.bytes.size() - kTrailer);
  put<std::uint32_t>(b, kVersionAt, version);
  put<std::uint32_t>(b, kSectionCountAt, std::uint32_t(c.section_at.size() + sections));
  reseal(b);
  write_file(dir.file("bad.prtt"), b);
  expect_error_of(prt::read_compressed_transfer, dir.file("bad.prtt"),
                  {"has a '" + first + "' section, but the header's flags say the file is compressed"}, "compressed");
}

TEST(LightBounceRead, DamagedOperatorsAreRefusedByName) {
  TempDir dir;
  const Transfer t = with_light_bounce(full_transfer());  // 11 sections: 1-5, 14-19
  ASSERT_EQ(t.light_bounce.entries(), 53u);
  const Sample s = sample_file(dir, t);
  const auto data = [&](std::uint32_t kind, std::size_t k) { return section_of(s, kind) + kSectionHeader + 4 * k; };
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& expected, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, expected, what);
  };
  // The sections in a file older than version 8.
  edit(kVersionAt, std::uint32_t(7),
       {"bad section table: section 6 of 11 has unknown kind 14 in a version 7 file",
        "'light bounce header' sections are version 8 and later"},
       "kind 14 in version 7");
  edit(kVersionAt, std::uint32_t(2), {"11 sections; at most 6 kinds exist in version 2"}, "kind 14 in version 2");
  // Section heads: element types and counts.
  edit(section_of(s, 18) + 4, std::uint32_t(1), {"section 'light bounce weights' has element type 1; expected 8 (f16)"},
       "f32 weights");
  edit(section_of(s, 17) + 4, std::uint32_t(1), {"section 'light bounce sources' has element type 1; expected 4 (u32)"},
       "f32 sources");
  edit(section_of(s, 14) + 8, std::uint64_t(3),
       {"section 'light bounce header' has 3 values; expected 2 (bounces, patches)"}, "header count");
  edit(section_of(s, 15) + 8, std::uint64_t(39),
       {"section 'light bounce patches' has 39 values; expected one per vertex (40)"}, "patch count");
  edit(section_of(s, 16) + 8, std::uint64_t(40),
       {"section 'light bounce offsets' has 40 values; expected vertices + 1 = 41"}, "offset count");
  edit(section_of(s, 18) + 8, std::uint64_t(63),
       {"section 'light bounce weights' has 63 values; 'light bounce sources' has 53 (one weight per entry)"},
       "weight count");
  // The header's values.
  edit(data(14, 0), std::uint32_t(0), {"bad section 'light bounce header': 0 bounces; an operator applies 1 to 64"},
       "0 bounces");
  edit(data(14, 0), std::uint32_t(65), {"65 bounces; an operator applies 1 to 64"}, "65 bounces");
  edit(data(14, 0), std::uint32_t(0x80000000u), {"2147483648 bounces"}, "bounces past int");
  edit(data(14, 1), std::uint32_t(0xffffffffu), {"light bounce: 4294967295 source patches for 40 points"},
       "2^32 - 1 patches");
  edit(data(14, 1), std::uint32_t(5), {"light bounce: 4 parents for 5 patches"}, "a patch without a parent");
  // The arrays: what light_bounce_problem refuses.
  edit(data(15, 0), std::uint32_t(7), {"light bounce: point 0 is in patch 7 of 4"}, "a point's patch out of range");
  edit(data(19, 0), std::uint64_t(0xffffffffffffffffull), {"light bounce: patch 3 holds no point"},
       "a coarse patch without children");
  edit(data(19, 0), std::uint32_t(0), {"light bounce: patch 0's parent is 0 (a later patch of 4, or none)"},
       "a patch its own parent");
  edit(data(19, 2), std::uint32_t(4), {"light bounce: patch 2's parent is 4"}, "a parent out of range");
  edit(data(17, 0), std::uint32_t(4), {"light bounce: row 0 names patch 4 of 4"}, "a source out of range");
  edit(data(17, 1), std::uint32_t(1), {"light bounce: row 0's patches do not increase"}, "a source repeated");
  edit(data(16, 40), std::uint32_t(52), {"light bounce: row offsets run from 0 to 52 over 53 entries"},
       "offsets not ending at the entries");
  edit(data(16, 0), std::uint32_t(1), {"light bounce: row offsets run from 1 to 53 over 53 entries"},
       "offsets not starting at 0");
  // A row running past the entries, the next one back: refused before any
  // row is read (past the sources' end otherwise).
  edit(data(16, 1), std::uint32_t(1000), {"light bounce: row 1's offsets decrease"}, "an offset past the entries");
  // The weights are binary16: 0x7e00 a NaN, 0x7c00 infinity, 0xb800 -0.5.
  const auto weight_at = [&](std::size_t e) { return section_of(s, 18) + kSectionHeader + 2 * e; };
  edit(weight_at(5), std::uint16_t(0x7e00), {"light bounce: row 3 has the weight nan"}, "a NaN weight");
  edit(weight_at(5), std::uint16_t(0x7c00), {"light bounce: row 3 has the weight inf"}, "an infinite weight");
  edit(weight_at(0), std::uint16_t(0xb800), {"light bounce: row 0 has the weight -0.5"}, "a negative weight");
  // Some of the six sections without the others.
  const auto missing = [&](auto drop, const std::vector<std::string>& expected, const std::string& what) {
    expect_bytes_error(dir, without_sections(s, drop, 8), expected, what);
  };
  missing([](std::uint32_t k) { return k == 18; },
          {"bad section table: the light-bounce operator's sections (kinds 14 to 19) come together, but the file has "
           "'light bounce header', 'light bounce patches', 'light bounce offsets', 'light bounce sources', 'light "
           "bounce parents' without 'light bounce weights'"},
          "no weights");
  missing([](std::uint32_t k) { return k == 14; }, {"without 'light bounce header'"}, "no header");
  missing([](std::uint32_t k) { return k == 15 || k == 17; },
          {"has 'light bounce header', 'light bounce offsets', 'light bounce weights', 'light bounce parents' without "
           "'light bounce patches', 'light bounce sources'"},
          "no patches or sources");
  // A version 8 file need not hold one.
  write_file(dir.file("none.prtt"), without_sections(s, [](std::uint32_t k) { return k >= 14; }, 8));
  EXPECT_TRUE(prt::read_transfer(dir.file("none.prtt")).light_bounce.empty());

  // Only an interreflected transfer keeps one.
  const Sample g = sample_file(dir, with_light_bounce(make_transfer(TransferMode::Interreflected, 1, 2, 40, {})));
  std::string b = g.bytes;
  put(b, kModeAt, std::uint32_t(1));
  reseal(b);
  expect_bytes_error(dir, b,
                     {"has a 'light bounce header' section, but the header says the transfer is shadowed (a "
                      "light-bounce operator is kept by interreflected transfers only)"},
                     "shadowed");
  // Never a compressed file: its own sections followed by the operator's.
  expect_compressed_refuses(dir, s, 6, 8, "light bounce header");
  // A lightmap's operator is read by the same reader.
  prt::LightmapTransfer l = interreflected_lightmap();
  l.transfer.light_bounce = sample_light_bounce(40);
  const Sample ls = lightmap_sample(dir, l);
  b = ls.bytes;
  put(b, section_of(ls, 17) + kSectionHeader, std::uint32_t(5));
  reseal(b);
  write_file(dir.file("bad.prtt"), b);
  expect_error_of(prt::read_lightmap_transfer, dir.file("bad.prtt"), {"light bounce: row 0 names patch 5 of 4"},
                  "a lightmap's source out of range");
}

TEST(LightBounceRead, DamagedClusterRowsAreRefusedByName) {
  TempDir dir;
  const Transfer t = with_clustered_light_bounce(full_transfer());  // 14 sections: 1-5, 14-19, 20-22
  ASSERT_EQ(t.light_bounce.cluster_source.size(), 4u);
  const Sample s = sample_file(dir, t);
  ASSERT_EQ(s.section_at.size(), 14u);
  const auto data = [&](std::uint32_t kind, std::size_t k) { return section_of(s, kind) + kSectionHeader + 4 * k; };
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& expected, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, expected, what);
  };
  // The sections in a version 8 file: kind 20 is version 9's.
  edit(kVersionAt, std::uint32_t(8),
       {"bad section table: section 12 of 14 has unknown kind 20 in a version 8 file",
        "'light bounce cluster offsets' sections are version 9 and later"},
       "kind 20 in version 8");
  // Section heads: element types and counts (the offsets one per patch and
  // one more: the header's 4 patches; the weights as many as the sources).
  edit(section_of(s, 22) + 4, std::uint32_t(1),
       {"section 'light bounce cluster weights' has element type 1; expected 8 (f16)"}, "f32 cluster weights");
  edit(section_of(s, 20) + 8, std::uint64_t(4),
       {"bad section table: section 'light bounce cluster offsets' has 4 values; expected patches + 1 = 5 (one row "
        "per source patch)"},
       "cluster offset count");
  edit(section_of(s, 22) + 8, std::uint64_t(5),
       {"bad section table: section 'light bounce cluster weights' has 5 values; 'light bounce cluster sources' has 4 "
        "(one weight per cluster entry)"},
       "cluster weight count");
  // The count follows the header's patches: 5 patches want 6 offsets (the
  // operator is refused for its parents then, not for its cluster offsets).
  edit(data(14, 1), std::uint32_t(5),
       {"bad section table: section 'light bounce cluster offsets' has 5 values; expected patches + 1 = 6"},
       "patches changed under the cluster offsets");
  // The values: what light_bounce_problem refuses in the cluster rows.
  edit(data(21, 0), std::uint32_t(4), {"light bounce: cluster row 0 names patch 4 of 4"},
       "a cluster source out of range");
  edit(data(21, 1), std::uint32_t(2), {"light bounce: cluster row 0's patches do not increase"},
       "a cluster source repeated");
  edit(data(20, 4), std::uint32_t(3), {"light bounce: cluster row offsets run from 0 to 3 over 4 entries"},
       "cluster offsets not ending at the entries");
  edit(section_of(s, 22) + kSectionHeader, std::uint16_t(0xb800), {"light bounce: cluster row 0 has the weight -0.5"},
       "a negative cluster weight");
  // Some of the three without the others, or without the operator's six.
  const auto missing = [&](auto drop, const std::vector<std::string>& expected, const std::string& what) {
    expect_bytes_error(dir, without_sections(s, drop, 9), expected, what);
  };
  missing([](std::uint32_t k) { return k == 21; },
          {"bad section table: the light-bounce operator's cluster sections (kinds 20 to 22) come together, but the "
           "file has 'light bounce cluster offsets', 'light bounce cluster weights' without 'light bounce cluster "
           "sources'"},
          "no cluster sources");
  missing([](std::uint32_t k) { return k == 20; }, {"without 'light bounce cluster offsets'"}, "no cluster offsets");
  missing([](std::uint32_t k) { return k == 22; }, {"without 'light bounce cluster weights'"}, "no cluster weights");
  missing([](std::uint32_t k) { return k >= 14 && k <= 19; },
          {"bad section table: the file has 'light bounce cluster offsets', 'light bounce cluster sources', 'light "
           "bounce cluster weights' (kinds 20 to 22, an operator's cluster rows) but no light-bounce operator (kinds "
           "14 to 19)"},
          "cluster rows without the operator");
  // (Without the six and the three: a version 9 file need hold neither.)
  write_file(dir.file("none.prtt"), without_sections(s, [](std::uint32_t k) { return k >= 14; }, 9));
  EXPECT_TRUE(prt::read_transfer(dir.file("none.prtt")).light_bounce.empty());
  write_file(dir.file("flat.prtt"), without_sections(s, [](std::uint32_t k) { return k >= 20; }, 9));
  EXPECT_TRUE(prt::read_transfer(dir.file("flat.prtt")).light_bounce.cluster_offsets.empty());

  // Never a compressed file: its own sections followed by the three.
  expect_compressed_refuses(dir, s, 3, 9, "light bounce cluster offsets");
}

TEST(LightBounceRead, DamagedProbeRowsAreRefusedByName) {
  TempDir dir;
  const Transfer t = with_probed_light_bounce(full_transfer());  // 16 sections: 1-5, 14-19, 23-27
  ASSERT_EQ(t.light_bounce.probes.source.size(), 13u);
  const Sample s = sample_file(dir, t);
  ASSERT_EQ(s.section_at.size(), 16u);
  const auto data = [&](std::uint32_t kind, std::size_t k) { return section_of(s, kind) + kSectionHeader + 4 * k; };
  const auto edit = [&](std::size_t at, auto value, const std::vector<std::string>& expected, const std::string& what) {
    std::string b = s.bytes;
    put(b, at, value);
    reseal(b);
    expect_bytes_error(dir, b, expected, what);
  };
  // The sections in a version 9 (or older) file: kind 23 is version 10's.
  edit(kVersionAt, std::uint32_t(9),
       {"bad section table: section 12 of 16 has unknown kind 23 in a version 9 file",
        "'light bounce probe grid' sections are version 10 and later"},
       "kind 23 in version 9");
  edit(kVersionAt, std::uint32_t(8), {"section 12 of 16 has unknown kind 23 in a version 8 file"},
       "kind 23 in version 8");
  // Section heads: element types and counts (the offsets one per probe of
  // the grid and one more, the weights bands^2 per source).
  edit(section_of(s, 24) + 4, std::uint32_t(1),
       {"section 'light bounce probe box' has element type 1; expected 2 (f64)"}, "f32 box");
  edit(section_of(s, 27) + 4, std::uint32_t(1),
       {"section 'light bounce probe weights' has element type 1; expected 8 (f16)"}, "f32 probe weights");
  edit(section_of(s, 23) + 8, std::uint64_t(3),
       {"bad section table: section 'light bounce probe grid' has 3 values; expected 4 (NX, NY, NZ, bands)"},
       "grid count");
  edit(section_of(s, 24) + 8, std::uint64_t(5),
       {"section 'light bounce probe box' has 5 values; expected 6 (min x, y, z, max x, y, z)"}, "box count");
  edit(section_of(s, 25) + 8, std::uint64_t(8),
       {"bad section table: section 'light bounce probe offsets' has 8 values; expected probes + 1 = 9 (one row per "
        "probe)"},
       "probe offset count");
  edit(section_of(s, 27) + 8, std::uint64_t(118),
       {"bad section table: section 'light bounce probe weights' has 118 values; 'light bounce probe sources' has 13 "
        "(bands^2 = 9 weights per probe entry)"},
       "probe weight count");
  // The grid's values: the dims before the offsets' count is taken from them.
  edit(data(23, 0), std::uint32_t(0x80000000u),
       {"bad section 'light bounce probe grid': NX 2147483648 is out of range"}, "NX past int");
  edit(data(23, 1), std::uint32_t(1),
       {"bad section 'light bounce probe grid': NY is 1; each of NX, NY, NZ must be 2 to 1024"}, "NY of 1");
  edit(data(23, 2), std::uint32_t(3), {"section 'light bounce probe offsets' has 9 values; expected probes + 1 = 13"},
       "NZ changed under the probe offsets");
  // The values: what light_bounce_problem refuses in the probe rows.
  edit(data(23, 3), std::uint32_t(0), {"light bounce: probe rows of 0 bands (1 to 8)"}, "0 bands");
  edit(section_of(s, 24) + kSectionHeader, std::numeric_limits<double>::quiet_NaN(),
       {"light bounce: the probe rows' box runs from nan to 0.333"}, "a NaN box");
  edit(section_of(s, 24) + kSectionHeader + 8 * 4, -1.0,
       {"light bounce: the probe rows' box runs from -0.5 to -1 along axis 1"}, "max below min");
  // Probe 1's row is entry 0 (patch 0), probe 3's entries 2 and 3 (patches 0, 1).
  edit(data(26, 0), std::uint32_t(4), {"light bounce: probe row 1 names patch 4 of 4"}, "a probe source out of range");
  edit(data(26, 3), std::uint32_t(0), {"light bounce: probe row 3's patches do not increase"},
       "a probe source repeated");
  edit(data(25, 8), std::uint32_t(12), {"light bounce: probe row offsets run from 0 to 12 over 13 entries"},
       "probe offsets not ending at the entries");
  edit(section_of(s, 27) + kSectionHeader, std::uint16_t(0x7e00), {"light bounce: probe row 1 has the weight nan"},
       "a NaN probe weight");
  // A negative weight (0xb800, -0.5) is an SH coefficient's: read as it is.
  std::string negative = s.bytes;
  put(negative, section_of(s, 27) + kSectionHeader, std::uint16_t(0xb800));
  reseal(negative);
  write_file(dir.file("negative.prtt"), negative);
  EXPECT_EQ(prt::read_transfer(dir.file("negative.prtt")).light_bounce.probes.weight[0], -0.5f);
  // Some of the five without the others, or without the operator's six.
  const auto missing = [&](auto drop, const std::vector<std::string>& expected, const std::string& what) {
    expect_bytes_error(dir, without_sections(s, drop, 10), expected, what);
  };
  missing([](std::uint32_t k) { return k == 25; },
          {"bad section table: the light-bounce operator's probe sections (kinds 23 to 27) come together, but the "
           "file has 'light bounce probe grid', 'light bounce probe box', 'light bounce probe sources', 'light bounce "
           "probe weights' without 'light bounce probe offsets'"},
          "no probe offsets");
  missing([](std::uint32_t k) { return k == 24; }, {"without 'light bounce probe box'"}, "no box");
  missing([](std::uint32_t k) { return k >= 14 && k <= 19; },
          {"bad section table: the file has 'light bounce probe grid', 'light bounce probe box', 'light bounce probe "
           "offsets', 'light bounce probe sources', 'light bounce probe weights' (kinds 23 to 27, an operator's probe "
           "rows) but no light-bounce operator (kinds 14 to 19)"},
          "probe rows without the operator");
  // (A version 10 file need hold neither.)
  write_file(dir.file("flat.prtt"), without_sections(s, [](std::uint32_t k) { return k >= 23; }, 10));
  EXPECT_TRUE(prt::read_transfer(dir.file("flat.prtt")).light_bounce.probes.empty());

  // Never a compressed file: its own sections followed by the five.
  expect_compressed_refuses(dir, s, 5, 10, "light bounce probe grid");
}

TEST(LightBounceWrite, RefusesWhatCouldNotBeReadBack) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  const auto expect_refused = [&](auto write, const std::string& words) {
    try {
      write();
      ADD_FAILURE() << "wrote it (" << words << ")";
    } catch (const prt::Error& e) {
      EXPECT_TRUE(contains(e.what(), path + ": cannot write this ")) << e.what();
      EXPECT_TRUE(contains(e.what(), words)) << e.what();
    }
    EXPECT_FALSE(fs::exists(path));
  };
  Transfer t = with_light_bounce(full_transfer());
  t.light_bounce.source[0] = 4;
  expect_refused([&] { prt::write_transfer(path, t); }, "transfer: light bounce: row 0 names patch 4 of 4");
  t = with_light_bounce(full_transfer());
  t.light_bounce.weight[0] = 0.1f;  // no binary16 value: the file's 16 bits could not hold it
  expect_refused([&] { prt::write_transfer(path, t); },
                 "light bounce: row 0 has the weight 0.1, not a half-precision value");
  t = with_light_bounce(full_transfer());
  t.light_bounce.offsets[1] = 1000;
  expect_refused([&] { prt::write_transfer(path, t); }, "light bounce: row 1's offsets decrease");
  t = with_probed_light_bounce(full_transfer());
  t.light_bounce.probes.weight[0] = -0.1f;  // its sign is an SH weight's; its bits no binary16's
  expect_refused([&] { prt::write_transfer(path, t); },
                 "light bounce: probe row 1 has the weight -0.1, not a half-precision value");
  t = with_light_bounce(make_transfer(TransferMode::Shadowed, 1, 2, 40, {}));
  expect_refused([&] { prt::write_transfer(path, t); },
                 "a light-bounce operator in a transfer that is not interreflected");
  prt::LightmapTransfer l = interreflected_lightmap();
  l.transfer.light_bounce = sample_light_bounce(39);  // a row short
  expect_refused([&] { prt::write_lightmap_transfer(path, l); },
                 "lightmap: light bounce: 39 patch indices for 40 points");
  // Compression keeps the operator in memory (compress_transfer copies the
  // transfer's other parts) but not in a file: the writer refuses it rather
  // than drop it.
  prt::CompressedTransfer c = compressed(with_light_bounce(full_transfer()), 2, 3, 16);
  ASSERT_FALSE(c.transfer.light_bounce.empty());
  expect_refused([&] { prt::write_compressed_transfer(path, c); },
                 "compressed transfer: its light-bounce operator (prt precompute --light-bounce) is not kept by "
                 "compression yet");
  EXPECT_TRUE(dir.listing().empty());
  c.transfer.light_bounce = {};
  prt::write_compressed_transfer(path, c);
  EXPECT_EQ(file_version(path), 4u);
}

// ---- writing -----------------------------------------------------------------------------

TEST(TransferWrite, RefusesWhatCouldNotBeReadBack) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  const auto expect_refused = [&](const Transfer& t, const std::string& words) {
    try {
      prt::write_transfer(path, t);
      ADD_FAILURE() << "wrote a bad transfer (" << words << ")";
    } catch (const prt::Error& e) {
      EXPECT_TRUE(contains(e.what(), path)) << e.what();
      EXPECT_TRUE(contains(e.what(), words)) << e.what();
    }
    EXPECT_FALSE(fs::exists(path));
  };
  Transfer t = full_transfer();
  t.coeffs.pop_back();
  expect_refused(t, "section 'coefficients' has 1919 values");
  t = full_transfer();
  t.coeffs[100] = std::numeric_limits<float>::quiet_NaN();
  expect_refused(t, "vertex 2 has a non-finite coefficient");
  t = full_transfer();
  t.bands = 0;
  expect_refused(t, "bands is 0");
  t = full_transfer();
  t.ao.resize(3);
  expect_refused(t, "'ambient occlusion' has 3 values");
  t = full_transfer();
  t.mode = TransferMode::Shadowed;
  expect_refused(t, "only an interreflected transfer");
  t = full_transfer();
  t.vertices = 0;
  t.coeffs.clear();
  t.direct.clear();
  t.ao.clear();
  t.bent_normals.clear();
  expect_refused(t, "no vertices");
  t = mixed_transfer();
  std::swap(t.slots[1], t.slots[2]);  // rows out of vertex order (the file cannot say so)
  expect_refused(t, "vertex 1 is in row 1; stored vertices must take rows 0, 1, 2, ... in vertex order (row 0)");
  t = mixed_transfer();
  t.slots.pop_back();
  expect_refused(t, "39 slots for 40 vertices");
  t = mixed_transfer();
  t.coeffs.resize(t.coeffs.size() + t.stride());  // a row for an analytic vertex
  expect_refused(t, "section 'coefficients' has 1296 values; expected stored vertices");
  for (float a : {2.0f, -1.0f, 1e30f}) {  // what compute_transfer refuses
    t = full_transfer();
    t.albedo.y = a;
    expect_refused(t, "must be in [0, 1] per channel (energy conservation)");
  }
  EXPECT_TRUE(dir.listing().empty());
}

// The one validator: what write_transfer refuses is what transfer_problem
// reports, word for word.
TEST(TransferValidator, IsWhatTheWriterRefuses) {
  EXPECT_EQ(prt::transfer_problem(full_transfer()), "");
  EXPECT_EQ(prt::transfer_problem(mixed_transfer()), "");
  EXPECT_EQ(prt::transfer_problem(make_transfer(TransferMode::Unshadowed, 1, 1, 1, {})), "");
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  std::vector<Transfer> bad(6, full_transfer());
  bad[0].bands = 65;
  bad[1].direct.pop_back();
  bad[2].mode = TransferMode(7);
  bad[3].albedo.x = 1.5f;
  bad[4].bent_normals[3].y = std::numeric_limits<float>::infinity();
  bad[5].bounce_energy.push_back(0.1);  // 4 values for 3 bounces
  for (const Transfer& t : bad) {
    const std::string problem = prt::transfer_problem(t);
    ASSERT_FALSE(problem.empty());
    try {
      prt::write_transfer(path, t);
      ADD_FAILURE() << "wrote a transfer with: " << problem;
    } catch (const prt::Error& e) {
      EXPECT_EQ(std::string(e.what()), path + ": cannot write this transfer: " + problem);
    }
  }
  EXPECT_EQ(prt::transfer_problem(bad[3]),
            "albedo is 1.5 0.5 0.25; must be in [0, 1] per channel (energy conservation)");
}

// ---- the hash (prt/hash.h) ----------------------------------------------------------------

TEST(Hash, IsXxh3WithSeedZeroInOneCallOrInPieces) {
  // Pinned: XXH3-64 of nothing, and of "abc" (xxHash 0.8's test vectors).
  EXPECT_EQ(prt::hash64(nullptr, 0), 0x2d06800538d394c2ull);
  EXPECT_EQ(prt::Hasher().digest(), 0x2d06800538d394c2ull);
  EXPECT_EQ(prt::hash64("abc", 3), XXH3_64bits("abc", 3));
  std::mt19937_64 rng(7);
  std::string bytes(100000, '\0');
  for (char& c : bytes) c = char(rng());
  for (std::size_t n : {0, 1, 3, 16, 17, 128, 129, 240, 241, 1024, 100000}) {
    EXPECT_EQ(prt::hash64(bytes.data(), n), XXH3_64bits(bytes.data(), n)) << n;
    prt::Hasher h;
    for (std::size_t done = 0; done < n;) {  // random pieces, some empty
      const std::size_t k = std::min<std::size_t>(n - done, rng() % 300);
      h.add(bytes.data() + done, k);
      done += k;
    }
    EXPECT_EQ(h.digest(), XXH3_64bits(bytes.data(), n)) << n;
  }
  const std::uint32_t x = 0xdeadbeef;
  EXPECT_EQ(prt::Hasher().add_value(x).digest(), XXH3_64bits(&x, 4));
}

TEST(Hash, MeshAndShadingHashesAreXxh3OfTheirBytes) {
  std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {1, 0.5f, 1}};
  std::vector<glm::vec3> colors = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0.5f, 0.5f, 0.5f}};
  const prt::Mesh m = prt::make_mesh(p, {{0, 2, 1}, {1, 2, 3}}, {}, colors, {}, "m.off");
  std::string pos(reinterpret_cast<const char*>(m.positions.data()), m.positions.size() * 12);
  pos.append(reinterpret_cast<const char*>(m.triangles.data()), m.triangles.size() * 12);
  EXPECT_EQ(m.hash(), XXH3_64bits(pos.data(), pos.size()));
  const std::string n(reinterpret_cast<const char*>(m.normals.data()), m.normals.size() * 12);
  EXPECT_EQ(prt::shading_hash(m, false), XXH3_64bits(n.data(), n.size()));
  std::string nc = n;
  nc.append(reinterpret_cast<const char*>(m.colors.data()), m.colors.size() * 12);
  EXPECT_EQ(prt::shading_hash(m, true), XXH3_64bits(nc.data(), nc.size()));
}

// Runs write_transfer(path, t) in a child process whose file-size limit
// (RLIMIT_FSIZE) makes the write fail part-way with EFBIG, as a full disk
// would; the limit never touches this process or its output. Returns the
// child's exit code: 0 when it threw prt::Error naming the file and the
// failure, 1 when it wrote, 2 for a wrong message, 3 for another exception.
int write_with_size_limit(const std::string& path, const Transfer& t, rlim_t limit) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit lim{};
    getrlimit(RLIMIT_FSIZE, &lim);
    lim.rlim_cur = limit;
    setrlimit(RLIMIT_FSIZE, &lim);
    int code = 1;
    try {
      prt::write_transfer(path, t);
    } catch (const prt::Error& e) {
      code = contains(e.what(), path + ": write failed") ? 0 : 2;
    } catch (...) {
      code = 3;
    }
    _exit(code);
  }
  int status = 0;
  if (pid < 0 || waitpid(pid, &status, 0) != pid || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

TEST(TransferWrite, FailedWriteLeavesTheOldFileAndNoTemporary) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  const Transfer small = make_transfer(TransferMode::Shadowed, 1, 2, 10, {});
  prt::write_transfer(path, small);
  const std::string before = read_file(path);
  ASSERT_LT(before.size(), 4096u);

  const Transfer big = make_transfer(TransferMode::Shadowed, 3, 8, 1000, {false, true, true, false});
  ASSERT_GT(prt::transfer_file_size(big), 65536u);
  EXPECT_EQ(write_with_size_limit(path, big, 65536), 0) << "0: prt::Error naming the failure; 1: no error";
  EXPECT_EQ(read_file(path), before);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"t.prtt"});
  expect_identical(prt::read_transfer(path), small);

  // Without the limit the same write succeeds.
  prt::write_transfer(path, big);
  expect_identical(prt::read_transfer(path), big);

  // A directory that does not exist: an error, and nothing written.
  EXPECT_THROW(prt::write_transfer(dir.file("no/such/dir.prtt"), small), prt::Error);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"t.prtt"});
}

// ---- the mesh check ---------------------------------------------------------------------

prt::Mesh grid(int k, float lift = 0.0f) {
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> tri;
  for (int j = 0; j <= k; ++j)
    for (int i = 0; i <= k; ++i) p.emplace_back(float(i) / k, (i == 1 && j == 1) ? lift : 0.0f, float(j) / k);
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      const unsigned a = j * (k + 1) + i, b = a + 1, c = a + k + 1, d = c + 1;
      tri.emplace_back(a, c, b);
      tri.emplace_back(b, c, d);
    }
  return prt::make_mesh(std::move(p), std::move(tri), {}, {}, {}, "grid" + std::to_string(k) + ".off");
}

TEST(TransferMesh, CheckMatchesAcceptsTheMeshAndRefusesAnother) {
  const prt::Mesh mesh = grid(4);
  Transfer t = make_transfer(TransferMode::Shadowed, 1, 3, mesh.vertex_count(), {});
  t.mesh_hash = mesh.hash();
  EXPECT_NO_THROW(prt::check_matches(t, mesh, "grid.prtt"));
  EXPECT_NO_THROW(prt::check_matches(t, grid(4), "grid.prtt"));  // same data, built again

  const auto expect_refused = [&](const prt::Mesh& other, const std::string& what) {
    try {
      prt::check_matches(t, other, "grid.prtt");
      ADD_FAILURE() << what << ": accepted";
    } catch (const prt::Error& e) {
      const std::string msg = e.what();
      for (const std::string& w :
           std::vector<std::string>{"grid.prtt was computed for a different mesh (25 vertices, hash ", other.source,
                                    std::to_string(other.vertex_count()) + " vertices", "run prt precompute again"})
        EXPECT_TRUE(contains(msg, w)) << what << ": expected '" << w << "' in: " << msg;
    }
  };
  expect_refused(grid(5), "more vertices");
  expect_refused(grid(4, 0.25f), "a moved vertex");
  // Same positions, triangles listed in another order.
  prt::Mesh swapped = grid(4);
  std::swap(swapped.triangles[0], swapped.triangles[1]);
  expect_refused(swapped, "reordered triangles");
}

// Analytic vertices are shaded from the mesh's normals (and colours), which
// the mesh hash does not cover: the shading hash does.
TEST(TransferMesh, AnalyticVerticesNeedTheSameNormals) {
  TempDir dir;
  const prt::Mesh mesh = grid(4);
  prt::TransferOptions o;
  o.bands = 2;
  o.samples = 16;
  const Transfer t = prt::compute_transfer(mesh, o);  // flat: every vertex analytic
  ASSERT_EQ(t.analytic_vertices(), mesh.vertex_count());
  EXPECT_EQ(t.shading_hash, prt::shading_hash(mesh, false));
  prt::write_transfer(dir.file("g.prtt"), t);
  const Transfer back = prt::read_transfer(dir.file("g.prtt"));
  EXPECT_NO_THROW(prt::check_matches(back, mesh, "g.prtt"));
  // The same positions and triangles with other normals: same mesh hash.
  std::vector<glm::vec3> normals(mesh.vertex_count(), glm::normalize(glm::vec3(0.1f, 1.0f, 0.0f)));
  const prt::Mesh tilted = prt::make_mesh(mesh.positions, mesh.triangles, normals, {}, {}, "tilted.off");
  ASSERT_EQ(tilted.hash(), mesh.hash());
  try {
    prt::check_matches(back, tilted, "g.prtt");
    ADD_FAILURE() << "accepted other normals";
  } catch (const prt::Error& e) {
    for (const char* w : {"g.prtt was computed with other normals than tilted.off", "25 analytic vertices",
                          "run prt precompute again"})
      EXPECT_TRUE(contains(e.what(), w)) << e.what();
  }
  // A transfer without analytic vertices does not depend on the normals.
  Transfer dense = make_transfer(TransferMode::Shadowed, 1, 2, mesh.vertex_count(), {});
  dense.mesh_hash = mesh.hash();
  EXPECT_NO_THROW(prt::check_matches(dense, tilted, "dense.prtt"));
}

// A transfer whose albedo is the mesh's colours needs a mesh with colours:
// check_matches says so for every command. A file with the flag set (and its
// checksum recomputed) passed prt info, then prt relight stopped on an
// internal check (exit 3) and prt render refused it without naming the file.
TEST(TransferMesh, VertexColourTransferNeedsAColouredMesh) {
  TempDir dir;
  const prt::Mesh mesh = grid(4);
  std::string off = "OFF\n" + std::to_string(mesh.vertex_count()) + " " + std::to_string(mesh.triangles.size()) + " 0\n";
  for (const glm::vec3& p : mesh.positions)
    off += std::to_string(p.x) + " " + std::to_string(p.y) + " " + std::to_string(p.z) + "\n";
  for (const glm::uvec3& t : mesh.triangles)
    off += "3 " + std::to_string(t.x) + " " + std::to_string(t.y) + " " + std::to_string(t.z) + "\n";
  const std::string mesh_path = dir.file("grid.off");
  write_file(mesh_path, off);
  const prt::Mesh loaded = prt::load_mesh(mesh_path);
  ASSERT_TRUE(loaded.colors.empty());
  prt::TransferOptions o;
  o.bands = 2;
  o.samples = 16;
  Transfer t = prt::compute_transfer(loaded, o);  // flat: every vertex analytic, albedo from the transfer
  const std::string plain = dir.file("plain.prtt");
  prt::write_transfer(plain, t);
  std::string bytes = read_file(plain);
  ASSERT_EQ(get<std::uint32_t>(bytes, kFlagsAt), 0u);
  put<std::uint32_t>(bytes, kFlagsAt, 1u);  // vertex colours as albedo
  reseal(bytes);
  const std::string flagged = dir.file("flagged.prtt");
  write_file(flagged, bytes);
  std::filesystem::remove(plain);
  // The reader accepts it (a legal header) ...
  const Transfer back = prt::read_transfer(flagged);
  EXPECT_TRUE(back.vertex_colors);
  EXPECT_EQ(run_prt(dir, {"info", flagged}).code, 0);
  // ... and check_matches refuses it for this mesh, naming both files.
  const std::string want = flagged + " uses vertex colours as albedo (computed with --vertex-colors), but " +
                           mesh_path + " has no vertex colours";
  try {
    prt::check_matches(back, loaded, flagged);
    ADD_FAILURE() << "accepted a vertex-colour transfer for a mesh without colours";
  } catch (const prt::Error& e) {
    EXPECT_TRUE(contains(e.what(), want)) << e.what();
  }
  prt::write_image(dir.file("sky.exr"), 8, 4, std::vector<float>(8 * 4 * 3, 1.0f));
  const std::vector<std::string> inputs = dir.listing();
  for (const auto& args : std::vector<std::vector<std::string>>{
           {"relight", mesh_path, flagged, dir.file("sky.exr"), "-o", dir.file("out.csv")},
           {"render", mesh_path, flagged, dir.file("sky.exr"), "-o", dir.file("out.png"), "--width", "16", "--height",
            "16"}}) {
    const Result r = run_prt(dir, args);
    EXPECT_EQ(r.code, 1) << args[0] << "\n" << describe_run(r);
    EXPECT_TRUE(contains(r.err, want)) << args[0] << "\n" << r.err;
    EXPECT_EQ(dir.listing(), inputs) << args[0] << ": something was written";
  }
}

TEST(TransferMesh, HashSurvivesTheFile) {
  TempDir dir;
  const prt::Mesh mesh = grid(3);
  Transfer t = make_transfer(TransferMode::Unshadowed, 1, 2, mesh.vertex_count(), {});
  t.mesh_hash = mesh.hash();
  prt::write_transfer(dir.file("g.prtt"), t);
  EXPECT_NO_THROW(prt::check_matches(prt::read_transfer(dir.file("g.prtt")), mesh, dir.file("g.prtt")));
}

// ---- describe_transfer and prt info -------------------------------------------------------

TEST(TransferDescribe, NamesEveryField) {
  Transfer t = make_transfer(TransferMode::Shadowed, 1, 5, 37706, {false, true, true, false});
  t.mesh_hash = 0x00ab00cd00ef0012ull;
  std::fill(t.ao.begin(), t.ao.end(), 0.5f);
  t.ao[3] = 0.25f;
  t.ao[9] = 1.0f;
  const std::string d = prt::describe_transfer(t);
  for (const char* w : {"bands", "5 (25 coefficients", "channels", "mode", "shadowed", "bounces", "samples", "1024",
                        "albedo", "0.8 0.5 0.25", "37706", "0x00ab00cd00ef0012", "coefficients", "3770600 bytes",
                        "(100 per vertex)", "ambient occlusion", "bent normals", "bytes per vertex", "116",
                        "4374108 bytes", "min 0.25", "max 1"})
    EXPECT_TRUE(contains(d, w)) << "expected '" << w << "' in:\n" << d;
  EXPECT_EQ(d.back(), '\n');
}

TEST(PrtInfo, PrintsTheHeader) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  const Transfer t = make_transfer(TransferMode::Interreflected, 3, 5, 321, {true, true, false, true});
  prt::write_transfer(path, t);
  Result r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, path)) << r.out;
  EXPECT_TRUE(contains(r.out, "5 (25 coefficients")) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(^  vertices +321$)", std::regex::multiline))) << r.out;
  EXPECT_TRUE(contains(r.out, "interreflected")) << r.out;

  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 2);
  EXPECT_EQ(j.at("analytic_vertices"), 0);
  EXPECT_EQ(j.at("stored_vertices"), 321);
  EXPECT_EQ(j.at("analytic_bytes_saved"), 0);
  EXPECT_EQ(j.at("bands"), 5);
  EXPECT_EQ(j.at("channels"), 3);
  EXPECT_EQ(j.at("mode"), "interreflected");
  EXPECT_EQ(j.at("bounces"), 3);
  EXPECT_EQ(j.at("vertices"), 321);
  EXPECT_EQ(j.at("seed").get<std::uint64_t>(), t.seed);
  EXPECT_EQ(j.at("mesh_hash"), "0xfedcba9876543211");
  EXPECT_EQ(j.at("sections").size(), 4u);
  EXPECT_EQ(j.at("sections").at(0).at("bytes"), 321 * 300);
  EXPECT_EQ(j.at("bytes_per_vertex"), 604);
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(path));
  EXPECT_TRUE(j.contains("ambient_occlusion"));
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"t.prtt"});
}

TEST(PrtInfo, CountsAnalyticVertices) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  const Transfer t = mixed_transfer();
  prt::write_transfer(path, t);
  Result r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::string saved = std::to_string(prt::analytic_bytes_saved(t));
  EXPECT_TRUE(contains(r.out, "14 of 40 vertices (35.0%")) << r.out;
  EXPECT_TRUE(contains(r.out, saved + " bytes saved")) << r.out;
  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("analytic_vertices"), 14);
  EXPECT_EQ(j.at("stored_vertices"), 26);
  EXPECT_EQ(j.at("analytic_bytes_saved"), prt::analytic_bytes_saved(t));
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(path));
}

TEST(PrtInfo, ReportsInterpolatedVertices) {
  TempDir dir;
  const std::string path = dir.file("t.prtt"), packed = dir.file("c.prtt"), plain = dir.file("p.prtt");
  prt::write_transfer(path, adaptive_transfer());
  Result r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "prt transfer (format version 7)")) << r.out;
  EXPECT_TRUE(std::regex_search(
      r.out, std::regex(R"(^  adaptive +traced 10 of 40 vertices \(25\.0%\), 30 interpolated)", std::regex::multiline)))
      << r.out;
  EXPECT_TRUE(contains(r.out, "interpolated vertices")) << r.out;  // the section
  EXPECT_FALSE(contains(r.out, "prt now writes")) << r.out;
  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 7);
  EXPECT_EQ(j.at("interpolated_vertices"), 30);
  EXPECT_EQ(j.at("traced_vertices"), 10);
  EXPECT_DOUBLE_EQ(j.at("traced_fraction").get<double>(), 0.25);
  EXPECT_EQ(j.at("analytic_vertices"), 14);
  EXPECT_EQ(j.at("sections").back().at("kind"), 13);
  EXPECT_EQ(j.at("sections").back().at("name"), "interpolated vertices");

  // Compressed: the same report.
  prt::write_compressed_transfer(packed, compressed(adaptive_transfer(), 2, 3, 16));
  r = run_prt(dir, {"info", packed});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "traced 10 of 40 vertices (25.0%), 30 interpolated")) << r.out;
  r = run_prt(dir, {"info", packed, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 7);
  EXPECT_EQ(j.at("interpolated_vertices"), 30);
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(packed));

  // Without the mask every vertex was traced: no text line, and 0, V, 1 in the JSON.
  prt::write_transfer(plain, mixed_transfer());
  r = run_prt(dir, {"info", plain});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_FALSE(contains(r.out, "adaptive")) << r.out;
  r = run_prt(dir, {"info", plain, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("interpolated_vertices"), 0);
  EXPECT_EQ(j.at("traced_vertices"), 40);
  EXPECT_EQ(j.at("traced_fraction").get<double>(), 1.0);
}

// A lightmap with interpolated texels: the same report, counting texels.
TEST(PrtInfo, ReportsInterpolatedTexels) {
  TempDir dir;
  const std::string path = dir.file("l.prtt"), plain = dir.file("p.prtt");
  prt::LightmapTransfer l = sample_lightmap(true);
  prt::write_lightmap_transfer(plain, l);
  l.transfer = with_interpolated(l.transfer, [](std::size_t v) { return v % 4 != 0; });
  prt::write_lightmap_transfer(path, l);
  Result r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "prt transfer (format version 7)")) << r.out;
  EXPECT_TRUE(std::regex_search(
      r.out, std::regex(R"(^  adaptive +traced 10 of 40 texels \(25\.0%\), 30 interpolated)", std::regex::multiline)))
      << r.out;
  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 7);
  EXPECT_EQ(j.at("interpolated_vertices"), 30);
  EXPECT_EQ(j.at("traced_vertices"), 10);
  EXPECT_DOUBLE_EQ(j.at("traced_fraction").get<double>(), 0.25);
  EXPECT_EQ(j.at("lightmap").at("interpolated_texels"), 30);
  EXPECT_EQ(j.at("sections").back().at("kind"), 13);
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(path));

  // Every texel traced: version 5, no text line, and 0, V, 1 in the JSON.
  r = run_prt(dir, {"info", plain});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "prt transfer (format version 5)")) << r.out;
  EXPECT_FALSE(contains(r.out, "adaptive")) << r.out;
  r = run_prt(dir, {"info", plain, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 5);
  EXPECT_EQ(j.at("interpolated_vertices"), 0);
  EXPECT_EQ(j.at("traced_vertices"), 40);
  EXPECT_EQ(j.at("traced_fraction").get<double>(), 1.0);
  EXPECT_EQ(j.at("lightmap").at("interpolated_texels"), 0);
}

// The light-bounce operator's size (issue 48: "prt info gives its size per
// receiver and per source patch"): the text line and the JSON object, for a
// transfer and a lightmap; neither without an operator.
TEST(PrtInfo, ReportsTheLightBounceOperator) {
  TempDir dir;
  const std::string path = dir.file("t.prtt"), lightmap = dir.file("l.prtt"), plain = dir.file("p.prtt");
  const Transfer t = with_light_bounce(full_transfer());  // 3 channels, 4 bands: SH rows of 3 x 16 x 4 = 192 bytes
  prt::write_transfer(path, t);
  // Its arrays as the file stores them: a patch and an offset per point
  // (and one more offset), a u32 source and an f16 weight per entry, a
  // parent per patch.
  const std::size_t points = 40, patches = 4, entries = t.light_bounce.source.size();
  const std::size_t bytes = 4 * points + 4 * (points + 1) + 6 * entries + 4 * patches;
  char want[512];  // the longest line, with cluster rows, is about 240 characters
  std::snprintf(want, sizeof want,
                "2 bounces (applied at run time), 4 source patches, %zu entries: %.2f per receiver (vertex), %.2f per "
                "source patch; %zu bytes, %.1f per receiver against 192 of an SH row (3 x 16 x 4 bytes)\n",
                entries, double(entries) / points, double(entries) / patches, bytes, double(bytes) / points);
  Result r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "prt transfer (format version 8)")) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(^  light bounce +2 bounces)", std::regex::multiline))) << r.out;
  EXPECT_TRUE(contains(r.out, want)) << "expected: " << want << "in:\n" << r.out;
  EXPECT_TRUE(contains(r.out, "light bounce weights")) << r.out;  // the sections
  EXPECT_FALSE(contains(r.out, "prt now writes")) << r.out;
  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 8);
  const nlohmann::json& b = j.at("light_bounce");
  EXPECT_EQ(b.at("bounces"), 2);
  EXPECT_EQ(b.at("patches"), patches);
  EXPECT_EQ(b.at("entries"), entries);
  EXPECT_DOUBLE_EQ(b.at("entries_per_vertex").get<double>(), double(entries) / points);
  EXPECT_DOUBLE_EQ(b.at("entries_per_patch").get<double>(), double(entries) / patches);
  EXPECT_EQ(b.at("bytes"), bytes);
  EXPECT_DOUBLE_EQ(b.at("bytes_per_vertex").get<double>(), double(bytes) / points);
  EXPECT_EQ(b.at("sh_row_bytes"), 192);
  EXPECT_EQ(b.at("cluster_entries"), 0);  // no cluster rows
  EXPECT_EQ(b.at("clusters"), 0);
  EXPECT_EQ(j.at("sections").back().at("kind"), 19);
  EXPECT_EQ(j.at("sections").back().at("name"), "light bounce parents");
  std::uint64_t stored = 0;  // the bytes of kinds 15 to 19 in the file's own section table
  for (const auto& sec : j.at("sections"))
    if (sec.at("kind") >= 15 && sec.at("kind") <= 19) stored += sec.at("bytes").get<std::uint64_t>();
  EXPECT_EQ(stored, bytes);
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(path));

  // A lightmap's receivers are its covered texels (2 bands, one channel: 16-byte rows).
  prt::LightmapTransfer l = interreflected_lightmap(true);
  l.transfer.light_bounce = sample_light_bounce(40);
  prt::write_lightmap_transfer(lightmap, l);
  r = run_prt(dir, {"info", lightmap});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  std::snprintf(want, sizeof want, "%zu bytes, %.1f per receiver against 16 of an SH row (1 x 4 x 4 bytes)", bytes,
                double(bytes) / points);
  EXPECT_TRUE(contains(r.out, "entries: 1.32 per receiver (texel)")) << r.out;  // 53 / 40
  EXPECT_TRUE(contains(r.out, want)) << "expected: " << want << "\nin:\n" << r.out;
  r = run_prt(dir, {"info", lightmap, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("light_bounce").at("entries"), entries);
  EXPECT_EQ(j.at("light_bounce").at("sh_row_bytes"), 16);
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(lightmap));

  // With cluster rows (4 entries in the rows of 3 of the 4 patches, counted
  // in the entries): the line says how many, --json has them, the file is
  // version 9, its last sections kinds 20 to 22.
  const Transfer ct = with_clustered_light_bounce(full_transfer());
  prt::write_transfer(path, ct);
  const std::size_t all = entries + 4;
  const std::size_t cbytes = bytes + 4 * (patches + 1) + 6 * 4;
  std::snprintf(want, sizeof want,
                "2 bounces (applied at run time), 4 source patches, %zu entries, of which 4 in cluster rows (3 "
                "clusters with rows): %.2f per receiver (vertex), %.2f per source patch; %zu bytes, %.1f per receiver "
                "against 192 of an SH row (3 x 16 x 4 bytes)\n",
                all, double(all) / points, double(all) / patches, cbytes, double(cbytes) / points);
  r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "prt transfer (format version 9)")) << r.out;
  EXPECT_TRUE(contains(r.out, want)) << "expected: " << want << "in:\n" << r.out;
  EXPECT_TRUE(contains(r.out, "light bounce cluster weights")) << r.out;
  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 9);
  EXPECT_EQ(j.at("light_bounce").at("entries"), all);
  EXPECT_EQ(j.at("light_bounce").at("cluster_entries"), 4);
  EXPECT_EQ(j.at("light_bounce").at("clusters"), 3);
  EXPECT_EQ(j.at("light_bounce").at("bytes"), cbytes);
  EXPECT_EQ(j.at("sections").back().at("kind"), 22);
  EXPECT_EQ(j.at("sections").back().at("name"), "light bounce cluster weights");
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(path));

  // Without probe rows: no probe line, no probe_rows key.
  EXPECT_FALSE(contains(prt::describe_transfer(ct), "bounce probes"));
  EXPECT_FALSE(j.at("light_bounce").contains("probe_rows")) << r.out;

  // With probe rows (a 2 x 2 x 2 grid of 3 bands, 13 entries): their own
  // line and object; their arrays (u32 offsets and sources, 9 f16 weights
  // an entry) counted in the operator's bytes in the JSON, left out of the
  // light-bounce line and its bytes per receiver (the points' rows); the
  // file is version 10, its last sections kinds 23 to 27.
  const Transfer pt = with_probed_light_bounce(full_transfer());
  prt::write_transfer(path, pt);
  const std::size_t probe_bytes = 4 * 9 + 4 * 13 + 2 * 9 * 13, pbytes = bytes + probe_bytes;
  std::snprintf(want, sizeof want,
                "2 bounces (applied at run time), 4 source patches, %zu entries: %.2f per receiver (vertex), %.2f per "
                "source patch; %zu bytes, %.1f per receiver against 192 of an SH row (3 x 16 x 4 bytes)\n",
                entries, double(entries) / points, double(entries) / patches, bytes, double(bytes) / points);
  r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "prt transfer (format version 10)")) << r.out;
  EXPECT_TRUE(contains(r.out, want)) << "expected: " << want << "in:\n" << r.out;
  std::snprintf(want, sizeof want,
                "  bounce probes     2x2x2 probe grid (8 probes), 3 bands (9 weights per entry), 13 entries: %.2f per "
                "probe; %zu bytes, %.1f per probe\n",
                13.0 / 8, probe_bytes, double(probe_bytes) / 8);
  EXPECT_TRUE(contains(r.out, want)) << "expected: " << want << "in:\n" << r.out;
  EXPECT_TRUE(contains(r.out, "light bounce probe weights")) << r.out;
  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 10);
  EXPECT_EQ(j.at("light_bounce").at("entries"), entries);  // the points' rows'
  EXPECT_EQ(j.at("light_bounce").at("bytes"), pbytes);
  EXPECT_DOUBLE_EQ(j.at("light_bounce").at("bytes_per_vertex").get<double>(), double(bytes) / points);
  const nlohmann::json& probe_rows = j.at("light_bounce").at("probe_rows");
  EXPECT_EQ(probe_rows.at("dims"), nlohmann::json::array({2, 2, 2}));
  EXPECT_EQ(probe_rows.at("bands"), 3);
  EXPECT_EQ(probe_rows.at("entries"), 13);
  EXPECT_EQ(probe_rows.at("bytes"), probe_bytes);
  EXPECT_EQ(j.at("sections").back().at("kind"), 27);
  EXPECT_EQ(j.at("sections").back().at("name"), "light bounce probe weights");
  EXPECT_EQ(j.at("file_bytes"), fs::file_size(path));

  // Without one: no line, no key.
  prt::write_transfer(plain, full_transfer());
  r = run_prt(dir, {"info", plain});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_FALSE(contains(r.out, "light bounce")) << r.out;
  r = run_prt(dir, {"info", plain, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_FALSE(nlohmann::json::parse(r.out).contains("light_bounce")) << r.out;
}

// prt compress refuses a transfer with an operator, naming it, before any
// work: the compressed file would lose it.
TEST(PrtCompress, RefusesATransferWithALightBounceOperator) {
  TempDir dir;
  const std::string in = dir.file("t.prtt"), out = dir.file("c.prtt");
  prt::write_transfer(in, with_light_bounce(full_transfer()));
  Result r = run_prt(dir, {"compress", in, "-o", out, "--clusters", "2", "--pca", "2", "-q"});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_TRUE(contains(r.err, in + ": holds a light-bounce operator (prt precompute --light-bounce), which is not "
                                   "kept by compression yet"))
      << describe_run(r);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"t.prtt"});
  // The same transfer without it compresses.
  prt::write_transfer(in, full_transfer());
  r = run_prt(dir, {"compress", in, "-o", out, "--clusters", "2", "--pca", "2", "-q"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(fs::exists(out));
}

TEST(PrtInfo, BadFilesExitNonZeroNamingTheFile) {
  TempDir dir;
  const std::string path = dir.file("t.prtt");
  prt::write_transfer(path, full_transfer());
  std::string b = read_file(path);
  b[b.size() / 2] = static_cast<char>(b[b.size() / 2] ^ 1);
  write_file(path, b);
  Result r = run_prt(dir, {"info", path});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_TRUE(contains(r.err, path + ": corrupt: checksum mismatch")) << describe_run(r);
  EXPECT_TRUE(r.out.empty()) << r.out;

  write_file(path, b.substr(0, 1000));
  r = run_prt(dir, {"info", path, "--json"});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_TRUE(contains(r.err, path + ": truncated")) << describe_run(r);

  r = run_prt(dir, {"info", dir.file("missing.prtt")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_TRUE(contains(r.err, dir.file("missing.prtt") + ": no such file")) << describe_run(r);

  r = run_prt(dir, {"info"});
  EXPECT_NE(r.code, 0) << describe_run(r);
}

// The reader's peak (docs/FORMAT.md, "Files at scale"): prt info holds a
// file's arrays once, read section by section into their final vectors, and
// no whole-file buffer. Between two files its peak resident set grows by
// the arrays it keeps (rows, occlusion, bent normals, 4 bytes of slot per
// vertex) and hardly more; a reader holding a file twice (a buffer of the
// file, a copied Transfer, a copy of the rows) would grow by about twice.
// Two large files, not a large and a tiny one: a child's peak (wait4) is at
// least this test's own resident set when it forked (Linux counts it at
// exec), which would hide a tiny file's peak.
TEST(PrtInfo, PeakMemoryIsOneCopyOfTheArrays) {
#if defined(__SANITIZE_ADDRESS__)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine change the resident set";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
  GTEST_SKIP() << "AddressSanitizer's shadow memory and quarantine change the resident set";
#endif
#endif
  TempDir dir;
  // V vertices, 4 bands, one channel, every 8th vertex analytic: 7/8 V rows
  // of 64 bytes, 4 + 12 bytes of occlusion and bent normal and 4 of slot per
  // vertex: 76 bytes per vertex held. Returns the bytes held.
  const auto write = [&](const std::string& path, std::size_t V) {
    prt::Transfer t;
    t.bands = 4;
    t.channels = 1;
    t.mode = prt::TransferMode::Shadowed;
    t.samples = 16;
    t.albedo = glm::vec3(0.8f);
    t.vertices = V;
    t.slots.resize(V);
    std::uint32_t rows = 0;
    for (std::size_t v = 0; v < V; ++v) t.slots[v] = v % 8 == 3 ? prt::Transfer::kAnalytic : rows++;
    t.coeffs.resize(std::size_t(rows) * t.stride());
    for (std::size_t i = 0; i < t.coeffs.size(); ++i) t.coeffs[i] = float(i % 1000) * 1e-4f;
    t.ao.assign(V, 0.5f);
    t.bent_normals.assign(V, glm::vec3(0.0f, 1.0f, 0.0f));
    t.shading_hash = 1;
    prt::write_transfer(path, t);
    return double(t.coeffs.size() * 4 + t.ao.size() * 4 + t.bent_normals.size() * 12 + t.slots.size() * 4);
  };
  const std::string a = dir.file("a.prtt"), b = dir.file("b.prtt");
  const double held_a = write(a, 600000), held_b = write(b, 1200000);  // 45 MB and 91 MB
  const BoundedResult ra = run_prt_bounded(dir, {"info", a});
  const BoundedResult rb = run_prt_bounded(dir, {"info", b});
  ASSERT_EQ(ra.code, 0) << describe_run(ra);
  ASSERT_EQ(rb.code, 0) << describe_run(rb);
  const double growth = double(rb.max_rss_kb - ra.max_rss_kb) * 1024.0, held = held_b - held_a;
  // Beyond the arrays: allocator and page rounding of each array and the
  // analytic-vertex mask (1 bit per vertex) while the slots are made from
  // it; the buffers of constant size (the checksum's 1 MiB, streams) cancel
  // between the two files. A few MiB at most, far below a second copy.
  constexpr double kReaderSlackBytes = 4.0 * 1024 * 1024;
  // Below: each array is written whole (zero-filled, then read into), so
  // all of it is resident; 5% for the pages of the smaller run that the
  // allocator had already mapped.
  constexpr double kResidentFraction = 0.95;
  const std::string what = "peak RSS " + std::to_string(rb.max_rss_kb) + " KiB and " + std::to_string(ra.max_rss_kb) +
                           " KiB, arrays " + std::to_string(held_b) + " and " + std::to_string(held_a) + " bytes";
  EXPECT_LE(growth, held + kReaderSlackBytes) << what;
  EXPECT_GE(growth, kResidentFraction * held) << what;
  RecordProperty("reader_growth_bytes", std::to_string(growth));
  RecordProperty("arrays_growth_bytes", std::to_string(held));
}

// ---- the subsurface material (version 11, kind 28) ---------------------------------------

// Jensen 2001's marble at D3DX's 25 mm a mesh unit.
prt::SubsurfaceRecord sample_record(std::string name = "marble") {
  prt::SubsurfaceRecord r;
  r.material.name = std::move(name);
  r.material.sigma_a = {0.0021, 0.0041, 0.0071};
  r.material.sigma_s = {2.19, 2.62, 3.0};
  r.material.eta = 1.5;
  r.length_scale = 25.0;
  return r;
}

// A translucent transfer (prt/subsurface_scatter.h): RGB, every vertex
// stored, with ambient occlusion and sample_record().
Transfer translucent_transfer() {
  Transfer t = make_transfer(TransferMode::Shadowed, 3, 3, 40, {false, true, false, false});
  t.vertex_colors = false;
  t.subsurface = sample_record();
  return t;
}

// `t` without its subsurface record.
Transfer without_record(Transfer t) {
  t.subsurface.reset();
  return t;
}

// The kinds of the sections of `s`, in file order.
std::vector<std::uint32_t> kinds_of(const Sample& s) {
  std::vector<std::uint32_t> kinds;
  for (std::size_t at : s.section_at) kinds.push_back(get<std::uint32_t>(s.bytes, at));
  return kinds;
}

// The bytes `with` (a file whose last section is the record) without that
// section: version `version`, one section fewer, resealed.
std::string strip_last_section(const Sample& with, std::uint32_t version) {
  std::string b = with.bytes.substr(0, with.section_at.back()) + with.bytes.substr(with.bytes.size() - kTrailer);
  put<std::uint32_t>(b, kVersionAt, version);
  put<std::uint32_t>(b, kSectionCountAt, get<std::uint32_t>(with.bytes, kSectionCountAt) - 1);
  reseal(b);
  return b;
}

// `bytes` (a valid file) with one more section after its last: `kind`,
// element type `type`, `count` elements in `data`; version `version`, the
// section count one more, resealed (as a buggy or foreign writer would).
std::string with_section(const std::string& bytes, std::uint32_t kind, std::uint32_t type, std::uint64_t count,
                         const std::string& data, std::uint32_t version) {
  std::string head(kSectionHeader, '\0');
  put(head, 0, kind);
  put(head, 4, type);
  put(head, 8, count);
  put<std::uint64_t>(head, 16, data.size());
  std::string b = bytes.substr(0, bytes.size() - kTrailer) + head + data +
                  std::string((8 - data.size() % 8) % 8, '\0') + bytes.substr(bytes.size() - kTrailer);
  put(b, kVersionAt, version);
  put(b, kSectionCountAt, get<std::uint32_t>(bytes, kSectionCountAt) + 1);
  reseal(b);
  return b;
}

TEST(SubsurfaceFile, RoundTripsBitExactAsVersionEleven) {
  TempDir dir;
  Transfer t = translucent_transfer();
  t.subsurface->material.sigma_a.x = 0.1 + 0.2;  // 0.30000000000000004: 17 significant digits
  const Sample plain = sample_file(dir, without_record(t));
  EXPECT_EQ(get<std::uint32_t>(plain.bytes, kVersionAt), 2u);
  for (std::uint32_t kind : kinds_of(plain)) EXPECT_NE(kind, 28u);
  EXPECT_EQ(prt::transfer_format_version(t), 11u);
  const Sample s = sample_file(dir, t);
  const std::string path = dir.file("sample.prtt");
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 11u);
  EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(t));
  // The last section: kind 28, u8, one JSON object of the record's five keys.
  const std::size_t at = s.section_at.back();
  const std::string json = prt::subsurface_record_json(*t.subsurface);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, at), 28u);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, at + 4), 6u);
  EXPECT_EQ(get<std::uint64_t>(s.bytes, at + 8), json.size());
  EXPECT_EQ(get<std::uint64_t>(s.bytes, at + 16), json.size());
  EXPECT_EQ(s.bytes.substr(at + kSectionHeader, json.size()), json);
  const nlohmann::json j = nlohmann::json::parse(json);
  ASSERT_TRUE(j.is_object()) << json;
  EXPECT_EQ(j.size(), 5u) << json;
  EXPECT_EQ(j.at("name"), "marble");
  EXPECT_EQ(j.at("sigma_a").get<std::vector<double>>(), (std::vector<double>{0.1 + 0.2, 0.0041, 0.0071}));
  EXPECT_EQ(j.at("sigma_s").get<std::vector<double>>(), (std::vector<double>{2.19, 2.62, 3.0}));
  EXPECT_EQ(j.at("eta").get<double>(), 1.5);
  EXPECT_EQ(j.at("length_scale").get<double>(), 25.0);
  const auto sections = prt::transfer_sections(t);
  ASSERT_EQ(sections.size(), s.section_at.size());
  EXPECT_EQ(sections.back().kind, 28u);
  EXPECT_STREQ(sections.back().name, "subsurface material");
  EXPECT_FALSE(sections.back().per_vertex);
  EXPECT_EQ(prt::transfer_bytes_per_vertex(t), prt::transfer_bytes_per_vertex(without_record(t)));
  // Everything before it is the file without the record, byte for byte.
  EXPECT_EQ(strip_last_section(s, 2), plain.bytes);
  // Read back bit for bit, and written again the same.
  const Transfer back = prt::read_transfer(path);
  expect_identical(t, back);
  ASSERT_TRUE(back.subsurface.has_value());
  EXPECT_EQ(back.subsurface->material.sigma_a.x, 0.1 + 0.2);
  EXPECT_EQ(back.subsurface->material.name, "marble");
  EXPECT_EQ(back.subsurface->length_scale, 25.0);
  EXPECT_EQ(file_version(path), 11u);
  prt::write_transfer(dir.file("again.prtt"), back);
  EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
  const std::string d = prt::describe_transfer(back);
  EXPECT_TRUE(contains(d, "format version 11")) << d;
  EXPECT_TRUE(contains(d, "subsurface material")) << d;  // the section
  // A file without the record reads back without one.
  prt::write_transfer(dir.file("plain.prtt"), without_record(t));
  EXPECT_FALSE(prt::read_transfer(dir.file("plain.prtt")).subsurface.has_value());
  EXPECT_FALSE(contains(prt::describe_transfer(without_record(t)), "subsurface")) << prt::describe_transfer(without_record(t));

  // A record without a name (coefficients given directly).
  t.subsurface->material.name.clear();
  sample_file(dir, t);
  const Transfer unnamed = prt::read_transfer(path);
  ASSERT_TRUE(unnamed.subsurface.has_value());
  EXPECT_TRUE(*unnamed.subsurface == *t.subsurface);
  EXPECT_TRUE(contains(prt::describe_transfer(unnamed), "subsurface: sigma_a 0.3, 0.0041")) << prt::describe_transfer(unnamed);
}

TEST(SubsurfaceDescribe, NamesTheMaterialOnItsLine) {
  const std::string d = prt::describe_transfer(translucent_transfer());
  EXPECT_TRUE(std::regex_search(d, std::regex(R"(^  material +subsurface, marble: sigma_a 0\.0021, 0\.0041, 0\.0071 /mm; )"
                                              R"(sigma_s' 2\.19, 2\.62, 3 /mm; eta 1\.5; 25 mm a unit$)",
                                              std::regex::multiline)))
      << d;
  EXPECT_EQ(prt::describe_subsurface_record(sample_record("")),
            "subsurface: sigma_a 0.0021, 0.0041, 0.0071 /mm; sigma_s' 2.19, 2.62, 3 /mm; eta 1.5; 25 mm a unit");
}

// After every other section: an adaptive transfer's mask (13) and a
// light-bounce operator (14 to 27) come before it.
TEST(SubsurfaceFile, ComesAfterEveryOtherSection) {
  TempDir dir;
  Transfer t = with_interpolated(full_transfer(), [](std::size_t v) { return v % 4 != 0; });
  t.light_bounce = with_probe_rows(with_cluster_rows(sample_light_bounce(t.vertices)));
  t.subsurface = sample_record();
  const Sample s = sample_file(dir, t);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 11u);
  const std::vector<std::uint32_t> kinds = kinds_of(s);
  ASSERT_GE(kinds.size(), 16u);
  EXPECT_TRUE(std::adjacent_find(kinds.begin(), kinds.end(), std::greater_equal<>()) == kinds.end());
  EXPECT_EQ(kinds[kinds.size() - 2], 27u);
  EXPECT_EQ(kinds.back(), 28u);
  EXPECT_EQ(std::count(kinds.begin(), kinds.end(), 13u), 1);
  expect_identical(t, prt::read_transfer(dir.file("sample.prtt")));
  EXPECT_EQ(strip_last_section(s, 10), sample_file(dir, without_record(t)).bytes);
}

TEST(SubsurfaceFile, CompressedFileKeepsTheRecord) {
  TempDir dir;
  const Transfer t = with_interpolated(translucent_transfer(), [](std::size_t v) { return v % 4 != 0; });
  prt::CompressedTransfer c = compressed(t, 2, 3, 16);
  ASSERT_TRUE(c.transfer.subsurface.has_value());  // compress_transfer keeps the header whole
  c.choice = sample_choice();
  EXPECT_EQ(prt::transfer_format_version(c), 11u);
  const Sample s = compressed_sample(dir, c);
  const std::string path = dir.file("sample.prtt");
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 11u);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kFlagsAt) & 4u, 4u);  // flag bit 2: compressed
  EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(c));
  // By increasing kind: the records (8), the choice (12), the mask (13), the material (28).
  const std::vector<std::uint32_t> kinds = kinds_of(s);
  ASSERT_GE(kinds.size(), 4u);
  EXPECT_EQ(std::vector<std::uint32_t>(kinds.end() - 4, kinds.end()), (std::vector<std::uint32_t>{8, 12, 13, 28}));
  const auto sections = prt::transfer_sections(c);
  ASSERT_EQ(sections.size(), kinds.size());
  EXPECT_EQ(sections.back().kind, 28u);
  const prt::CompressedTransfer back = prt::read_compressed_transfer(path);
  ASSERT_TRUE(back.transfer.subsurface.has_value());
  EXPECT_TRUE(*back.transfer.subsurface == sample_record());
  EXPECT_TRUE(prt::decompress(back).subsurface == c.transfer.subsurface);
  prt::write_compressed_transfer(dir.file("again.prtt"), back);
  EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
  std::uint32_t version = 0;
  EXPECT_EQ(prt::kind_of(prt::read_transfer_file(path, &version)), prt::TransferKind::Compressed);
  EXPECT_EQ(version, 11u);
  const std::string d = prt::describe_transfer(back);
  EXPECT_TRUE(contains(d, "format version 11")) << d;
  EXPECT_TRUE(contains(d, "  material          subsurface, marble: sigma_a 0.0021")) << d;
  // Without the record: the version 7 (with the mask) or 6 file of before.
  c.transfer.subsurface.reset();
  EXPECT_EQ(strip_last_section(s, 7), compressed_sample(dir, c).bytes);
  c.transfer.interpolated.clear();
  EXPECT_EQ(get<std::uint32_t>(compressed_sample(dir, c).bytes, kVersionAt), 6u);
}

TEST(SubsurfaceFile, LightmapKeepsTheRecord) {
  TempDir dir;
  prt::LightmapTransfer l = sample_lightmap();
  l.transfer = translucent_transfer();
  EXPECT_EQ(prt::transfer_format_version(l), 11u);
  const Sample s = lightmap_sample(dir, l);
  const std::string path = dir.file("lightmap.prtt");
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kVersionAt), 11u);
  EXPECT_EQ(get<std::uint32_t>(s.bytes, kFlagsAt) & 8u, 8u);  // flag bit 3: a lightmap
  EXPECT_EQ(s.bytes.size(), prt::transfer_file_size(l));
  const std::vector<std::uint32_t> kinds = kinds_of(s);
  ASSERT_GE(kinds.size(), 3u);
  EXPECT_EQ(std::vector<std::uint32_t>(kinds.end() - 3, kinds.end()), (std::vector<std::uint32_t>{10, 11, 28}));
  EXPECT_EQ(prt::transfer_sections(l).back().kind, 28u);
  const prt::LightmapTransfer back = prt::read_lightmap_transfer(path);
  expect_identical(l.transfer, back.transfer);
  EXPECT_EQ(back.layout.texels, l.layout.texels);
  prt::write_lightmap_transfer(dir.file("again.prtt"), back);
  EXPECT_EQ(read_file(dir.file("again.prtt")), s.bytes);
  const std::string d = prt::describe_transfer(back);
  EXPECT_TRUE(contains(d, "format version 11")) << d;
  EXPECT_TRUE(contains(d, "subsurface, marble: sigma_a")) << d;
  // Without the record: the version 5 lightmap of before.
  l.transfer.subsurface.reset();
  EXPECT_EQ(prt::transfer_format_version(l), 5u);
  EXPECT_EQ(strip_last_section(s, 5), lightmap_sample(dir, l).bytes);
}

TEST(SubsurfaceRead, BadRecordsAreRefusedByName) {
  TempDir dir;
  const Sample s = sample_file(dir, translucent_transfer());
  const std::size_t data = s.section_at.back() + kSectionHeader;
  const std::string json = prt::subsurface_record_json(sample_record());
  // `text` padded with spaces to the record's length (the layout stays valid).
  const auto pad = [&](std::string text) {
    EXPECT_LE(text.size(), json.size()) << text;
    text.resize(json.size(), ' ');
    return text;
  };
  // The record with `from` (found in it) replaced by `to`.
  const auto edited = [&](const std::string& from, const std::string& to) {
    std::string text = json;
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from << " in " << json;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return pad(text);
  };
  const auto with_json = [&](const std::string& text, const std::string& problem, const std::string& what) {
    ASSERT_EQ(text.size(), json.size()) << what;
    std::string b = s.bytes;
    b.replace(data, json.size(), text);
    reseal(b);
    expect_bytes_error(dir, b, {"bad section 'subsurface material': " + problem}, what);
  };
  ASSERT_EQ(json.substr(0, 17), R"({"name":"marble",)");  // what the edits below find
  with_json(pad(R"({"name": "marble")"), "not a JSON object", "truncated JSON");
  with_json(pad("[1, 2]"), "not a JSON object", "an array");
  with_json(pad("\xff\"x\""), "not a JSON object", "not UTF-8 JSON");
  with_json(edited(R"("eta")", R"("etx")"), "the key 'eta' is missing", "eta missing");
  with_json(edited(R"("sigma_s")", R"("sigma_z")"), "the key 'sigma_s' is missing", "sigma_s missing");
  with_json(edited(R"("length_scale")", R"("length_scald")"), "the key 'length_scale' is missing", "no length scale");
  with_json(edited(R"("marble")", "12345678"), "'name' is not a string (got 12345678)", "a number for a name");
  with_json(edited(",0.0071]", "]"), "'sigma_a' is not an array of 3 numbers (got [0.0021,0.0041])", "2 numbers");
  with_json(edited("[0.0021,", R"(["0.01",)"), "'sigma_a' is not an array of 3 numbers", "a string in sigma_a");
  with_json(edited(R"("eta":1.5)", R"("eta":"1")"), R"('eta' is not a number (got "1"))", "eta a string");
  with_json(edited(R"("length_scale":25.0)", R"("length_scale":true)"), "'length_scale' is not a number",
            "length scale a boolean");
  // Well-formed, but a material check_subsurface_material refuses.
  with_json(edited(R"("eta":1.5)", R"("eta":4.5)"),
            "the material: the relative index of refraction must be 1 to 3, got 4.5", "eta 4.5");
  with_json(edited("[0.0021", "[-0.002"), "the material: sigma_a (red) must be finite and >= 0 (1/mm), got -0.002",
            "a negative sigma_a");
  // (JSON has no infinity: a number too large for a double is refused as it is read.)
  const std::string overflow = "not a JSON object: [json.exception.out_of_range.406] number overflow parsing '1e999'";
  with_json(edited("[2.19,2.62", "[1e999,2.6"), overflow, "an infinite sigma_s");
  // A length scale that is not finite and > 0.
  const std::string scale = "the length scale must be finite and > 0 (mm per mesh unit), got ";
  with_json(edited(R"("length_scale":25.0)", R"("length_scale":-1)"), scale + "-1", "length scale -1");
  with_json(edited(R"("length_scale":25.0)", R"("length_scale":0)"), scale + "0", "length scale 0");
  with_json(edited(R"("eta":1.5,"length_scale":25.0)", R"("eta":2,"length_scale":1e999)"), overflow,
            "an infinite length scale");
  // Other keys are ignored.
  std::string b = s.bytes;
  b.replace(data, json.size(), edited(R"("name":"marble")", R"("name":"","x":0)"));
  reseal(b);
  write_file(dir.file("extra.prtt"), b);
  const Transfer extra = prt::read_transfer(dir.file("extra.prtt"));
  ASSERT_TRUE(extra.subsurface.has_value());
  EXPECT_TRUE(*extra.subsurface == sample_record(""));
}

TEST(SubsurfaceRead, MisplacedRecordsAreRefusedByName) {
  TempDir dir;
  const std::string json = prt::subsurface_record_json(sample_record());
  // In a file older than version 11.
  Sample s = sample_file(dir, translucent_transfer());
  put<std::uint32_t>(s.bytes, kVersionAt, 10);
  reseal(s.bytes);
  expect_bytes_error(dir, s.bytes,
                     {"bad section table: section 3 of 3 has unknown kind 28 in a version 10 file ('subsurface "
                      "material' sections are version 11 and later)"},
                     "kind 28 in version 10");
  // In a grey transfer, and in a glossy one: a translucent transfer is RGB and diffuse.
  const Sample grey = sample_file(dir, make_transfer(TransferMode::Shadowed, 1, 3, 40, {false, true, false, false}));
  expect_bytes_error(dir, with_section(grey.bytes, 28, 6, json.size(), json, 11),
                     {"bad section table: has a 'subsurface material' section, but the header says 1 channel (a "
                      "translucent transfer is RGB: 3 channels)"},
                     "grey");
  const Sample glossy = sample_file(dir, with_glossy(without_record(translucent_transfer())));
  expect_bytes_error(dir, with_section(glossy.bytes, 28, 6, json.size(), json, 11),
                     {"bad section table: has a 'subsurface material' section, but the header's flags say it has "
                      "glossy matrices (a translucent transfer is diffuse)"},
                     "glossy");
  // Of another element type, or too short to be a record.
  const Sample rgb = sample_file(dir, without_record(translucent_transfer()));
  expect_bytes_error(dir, with_section(rgb.bytes, 28, 1, 1, std::string(4, '\0'), 11),
                     {"section 'subsurface material' has element type 1; expected 6 (u8)"}, "f32");
  expect_bytes_error(dir, with_section(rgb.bytes, 28, 6, 1, "{", 11),
                     {"section 'subsurface material' has 1 bytes; a record has 2 to 65536"}, "one byte");
  // The same section appended by hand reads as the writer's.
  write_file(dir.file("hand.prtt"), with_section(rgb.bytes, 28, 6, json.size(), json, 11));
  EXPECT_EQ(read_file(dir.file("hand.prtt")), sample_file(dir, translucent_transfer()).bytes);
  // A compressed file and a lightmap are read by the same rules.
  const Sample c = compressed_sample(dir, compressed(translucent_transfer(), 2, 3, 16));
  std::string old = c.bytes;
  put<std::uint32_t>(old, kVersionAt, 10);
  reseal(old);
  write_file(dir.file("bad.prtt"), old);
  expect_error_of(prt::read_compressed_transfer, dir.file("bad.prtt"), {"unknown kind 28 in a version 10 file"},
                  "compressed, version 10");
  const Sample lightmap = lightmap_sample(dir, sample_lightmap());  // grey
  write_file(dir.file("bad.prtt"), with_section(lightmap.bytes, 28, 6, json.size(), json, 11));
  expect_error_of(prt::read_lightmap_transfer, dir.file("bad.prtt"),
                  {"has a 'subsurface material' section, but the header says 1 channel"}, "grey lightmap");
}

TEST(SubsurfaceWrite, RefusesWhatCouldNotBeReadBack) {
  TempDir dir;
  const std::string path = dir.file("out.prtt");
  const auto refused = [&](const Transfer& t, const std::string& problem, const std::string& what) {
    EXPECT_EQ(prt::transfer_problem(t).substr(0, problem.size()), problem) << what;
    try {
      prt::write_transfer(path, t);
      ADD_FAILURE() << what << ": written";
    } catch (const prt::Error& e) {
      EXPECT_TRUE(contains(e.what(), path + ": cannot write this transfer: " + problem)) << what << ": " << e.what();
    }
    EXPECT_FALSE(fs::exists(path)) << what;
  };
  Transfer grey = make_transfer(TransferMode::Shadowed, 1, 3, 40, {});
  grey.subsurface = sample_record();
  refused(grey, "a subsurface material in a transfer of 1 channel (a translucent transfer is RGB: 3 channels)", "grey");
  refused(with_glossy(translucent_transfer()),
          "a subsurface material in a glossy transfer (a translucent transfer is diffuse)", "glossy");
  Transfer t = translucent_transfer();
  t.subsurface->material.eta = 0.5;
  refused(t, "subsurface material: the material: the relative index of refraction must be 1 to 3, got 0.5", "eta");
  t = translucent_transfer();
  t.subsurface->material.sigma_s.z = std::numeric_limits<double>::quiet_NaN();
  refused(t, "subsurface material: the material: sigma_s' (blue) must be finite and >= 0 (1/mm), got nan", "NaN");
  for (double scale : {0.0, -25.0, std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    t = translucent_transfer();
    t.subsurface->length_scale = scale;
    refused(t, "subsurface material: the length scale must be finite and > 0 (mm per mesh unit)",
            "length scale " + std::to_string(scale));
  }
  EXPECT_EQ(prt::transfer_problem(translucent_transfer()), "");
  // A name that is not UTF-8 cannot be stored as JSON.
  t = translucent_transfer();
  t.subsurface->material.name = "marble\xff";
  EXPECT_THROW(prt::write_transfer(path, t), prt::Error);
  EXPECT_FALSE(fs::exists(path));
  // The compressed and lightmap writers alike.
  prt::CompressedTransfer c = compressed(translucent_transfer(), 2, 3, 16);
  c.transfer.subsurface->length_scale = 0;
  EXPECT_THROW(prt::write_compressed_transfer(path, c), prt::Error);
  EXPECT_FALSE(fs::exists(path));
  prt::LightmapTransfer l = sample_lightmap();  // grey
  l.transfer.subsurface = sample_record();
  EXPECT_THROW(prt::write_lightmap_transfer(path, l), prt::Error);
  EXPECT_FALSE(fs::exists(path));
}

TEST(PrtInfo, NamesTheSubsurfaceMaterial) {
  TempDir dir;
  const std::string path = dir.file("t.prtt"), packed = dir.file("c.prtt"), plain = dir.file("p.prtt");
  prt::write_transfer(path, translucent_transfer());
  Result r = run_prt(dir, {"info", path});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(contains(r.out, "format version 11")) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(^  material +subsurface, marble: sigma_a 0\.0021, 0\.0041, )"
                                                  R"(0\.0071 /mm; sigma_s' 2\.19, 2\.62, 3 /mm; eta 1\.5; 25 mm a )"
                                                  R"(unit$)",
                                                  std::regex::multiline)))
      << r.out;
  EXPECT_FALSE(contains(r.out, "prt now writes version")) << r.out;
  r = run_prt(dir, {"info", path, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 11);
  EXPECT_EQ(j.at("material"), "subsurface");
  const nlohmann::json& m = j.at("subsurface");
  EXPECT_EQ(m.size(), 5u) << m;
  EXPECT_EQ(m.at("name"), "marble");
  EXPECT_EQ(m.at("sigma_a").get<std::vector<double>>(), (std::vector<double>{0.0021, 0.0041, 0.0071}));
  EXPECT_EQ(m.at("sigma_s").get<std::vector<double>>(), (std::vector<double>{2.19, 2.62, 3.0}));
  EXPECT_EQ(m.at("eta").get<double>(), 1.5);
  EXPECT_EQ(m.at("length_scale").get<double>(), 25.0);
  // A compressed file's too.
  prt::write_compressed_transfer(packed, compressed(translucent_transfer(), 2, 3, 16));
  r = run_prt(dir, {"info", packed, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("format_version"), 11);
  EXPECT_EQ(j.at("subsurface").at("name"), "marble");
  // Without a record: no line, no key.
  prt::write_transfer(plain, without_record(translucent_transfer()));
  r = run_prt(dir, {"info", plain});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_FALSE(contains(r.out, "material")) << r.out;
  r = run_prt(dir, {"info", plain, "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("material"), "diffuse");
  EXPECT_FALSE(j.contains("subsurface"));
}

}  // namespace
