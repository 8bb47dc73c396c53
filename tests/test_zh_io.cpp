// Zonal-harmonic (local deformable) transfers in files (docs/FORMAT.md,
// "Zonal-harmonic transfer"): bit-exact round trips with and without
// analytic vertices and the rest pose's occlusion, the header and sections
// where the document puts them, refusal of damaged files and of the other
// bases (both ways), and a writer that refuses an inconsistent transfer
// without leaving a file.
#include "test_files.h"
#include "test_meshes.h"

#include <prt/error.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>
#include <prt/wavelet.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh.h>
#include <prt/zh_transfer.h>

#include <gtest/gtest.h>
// xxHash itself, compiled in (nothing links libxxhash): the checksum is
// resealed with it, not with prt::Hasher.
#define XXH_INLINE_ALL
#include <xxhash.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

namespace prt {
namespace {

using namespace prt::test;

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

// ---- fixtures -------------------------------------------------------------------

// A transfer built by hand, consistent with its header: every third vertex
// analytic when `analytic`, unit axes (some exactly the frame's, the others
// random), coefficients falling with band, one -0 (bit-exactness counts it),
// tangent rules of the three kinds in turn (edge, UV, none; none alone below
// 3 vertices).
ZhTransfer make_zh(std::size_t V, int bands, int lobes, int channels, bool analytic, bool vertex_colors,
                   unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  ZhTransfer t;
  t.bands = bands;
  t.lobes = lobes;
  t.channels = channels;
  t.mode = channels == 3 ? TransferMode::Interreflected : TransferMode::Shadowed;
  t.bounces = channels == 3 ? 2 : 0;
  t.samples = 256;
  t.albedo = {0.8f, 0.5f, 0.25f};
  t.vertex_colors = vertex_colors;
  t.seed = 0xfeedull + seed;
  t.vertices = V;
  t.mesh_hash = 0x1234567890abcdefull ^ seed;
  t.topology_hash = 0x0fedcba987654321ull ^ seed;
  t.fit_error = 0.0123 + 1e-3 * seed;
  std::size_t stored = V;
  if (analytic) {
    t.slots.assign(V, ZhTransfer::kAnalytic);
    std::uint32_t row = 0;
    for (std::size_t v = 0; v < V; ++v)
      if (v % 3 != 1) t.slots[v] = row++;
    stored = row;
  }
  for (std::size_t r = 0; r < stored; ++r)
    for (int i = 0; i < lobes; ++i) {
      if (i == 0) {  // the normal, exactly
        t.axes.insert(t.axes.end(), {0.0f, 0.0f, 1.0f});
        continue;
      }
      const double x = g(rng), y = g(rng), z = g(rng), len = std::sqrt(x * x + y * y + z * z);
      t.axes.insert(t.axes.end(), {float(x / len), float(y / len), float(z / len)});
    }
  for (std::size_t r = 0; r < stored; ++r)
    for (int c = 0; c < channels; ++c)
      for (int i = 0; i < lobes; ++i)
        for (int l = 0; l < bands; ++l) t.coeffs.push_back(float(g(rng) / (1.0 + l)));
  if (!t.coeffs.empty()) t.coeffs.back() = -0.0f;
  for (std::size_t v = 0; v < V; ++v) {
    const auto a = std::uint32_t((v + 1) % V), b = std::uint32_t((v + 2) % V), self = std::uint32_t(v);
    if (V < 3 || v % 3 == 2)
      t.tangents.push_back({self, self, 0.0f, 0.0f});
    else if (v % 3 == 0)
      t.tangents.push_back({a, a, 1.0f, 0.0f});
    else
      t.tangents.push_back({a, b, float(g(rng)), -0.0f});
  }
  return t;
}

// Bit-exact (memcmp, not ==: -0/+0 and NaN payloads count); empty arrays may have null data().
template <typename V>
bool same_bytes(const V& x, const V& y) {
  return x.size() == y.size() && (x.empty() || std::memcmp(x.data(), y.data(), x.size() * sizeof x[0]) == 0);
}

void expect_identical(const ZhTransfer& a, const ZhTransfer& b) {
  EXPECT_EQ(a.bands, b.bands);
  EXPECT_EQ(a.lobes, b.lobes);
  EXPECT_EQ(a.channels, b.channels);
  EXPECT_EQ(a.mode, b.mode);
  EXPECT_EQ(a.bounces, b.bounces);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(std::memcmp(&a.albedo, &b.albedo, sizeof a.albedo), 0);
  EXPECT_EQ(a.vertex_colors, b.vertex_colors);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.mesh_hash, b.mesh_hash);
  EXPECT_EQ(a.topology_hash, b.topology_hash);
  EXPECT_EQ(std::memcmp(&a.fit_error, &b.fit_error, sizeof(double)), 0);
  EXPECT_EQ(a.slots, b.slots);
  EXPECT_TRUE(same_bytes(a.axes, b.axes));
  EXPECT_TRUE(same_bytes(a.coeffs, b.coeffs));
  EXPECT_TRUE(same_bytes(a.rest_ao, b.rest_ao));
  EXPECT_TRUE(same_bytes(a.tangents, b.tangents));
}

// A rest occlusion for every vertex of `t`: its ends 0 and 1 exactly, the
// rest between.
void add_rest_ao(ZhTransfer& t, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  t.rest_ao.resize(t.vertices);
  for (float& a : t.rest_ao) a = u(rng);
  t.rest_ao.front() = 0.0f;
  t.rest_ao.back() = 1.0f;
}

template <typename T>
void put(std::string& b, std::size_t at, T v) {
  std::memcpy(&b[at], &v, sizeof v);
}
template <typename T>
T get(const std::string& b, std::size_t at) {
  T v;
  std::memcpy(&v, &b[at], sizeof v);
  return v;
}
// Recomputes the trailer's checksum after an edit, as a buggy or foreign
// writer would produce: the reader must then catch the edit itself.
void reseal(std::string& b) { put<std::uint64_t>(b, b.size() - 12, XXH3_64bits(b.data(), b.size() - 12)); }

// Offsets of the data of the sections of a file, in order (docs/FORMAT.md).
std::vector<std::size_t> section_data(const std::string& b) {
  std::vector<std::size_t> at;
  std::size_t off = 128;
  const std::uint32_t count = get<std::uint32_t>(b, 80);
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::uint64_t bytes = get<std::uint64_t>(b, off + 16);
    at.push_back(off + 24);
    off += 24 + bytes + (8 - bytes % 8) % 8;
  }
  return at;
}

void expect_error(const std::function<void()>& f, const std::vector<std::string>& words, const std::string& what) {
  try {
    f();
    ADD_FAILURE() << what << ": no error";
  } catch (const Error& e) {
    for (const auto& w : words) EXPECT_TRUE(contains(e.what(), w)) << what << ": '" << e.what() << "' lacks '" << w << "'";
  }
}

// ---- files --------------------------------------------------------------------------

TEST(ZhTransferIo, RoundTripIsBitExact) {
  TempDir dir;
  const std::string path = dir.file("z.prtt");
  unsigned seed = 1;
  // 37 vertices: the analytic-vertex mask's last word is partly used.
  for (int channels : {1, 3})
    for (bool analytic : {false, true})
      for (bool vc : {false, true})
        for (bool ao : {false, true}) {
          const std::string what = "channels " + std::to_string(channels) + (analytic ? ", analytic" : "") +
                                   (vc ? ", vertex colours" : "") + (ao ? ", rest occlusion" : "");
          ZhTransfer t = make_zh(37, 4, 3, channels, analytic, vc, seed++);
          if (ao) add_rest_ao(t, seed);
          ASSERT_EQ(zh_transfer_problem(t), "") << what;
          EXPECT_EQ(t.analytic_vertices(), analytic ? 12u : 0u) << what;
          write_zh_transfer(path, t);
          EXPECT_EQ(std::filesystem::file_size(path), transfer_file_size(t)) << what;
          std::uint32_t version = 0;
          EXPECT_EQ(kind_of(read_transfer_file(path, &version)), TransferKind::ZH) << what;
          EXPECT_EQ(version, kZhFormatVersion) << what;
          const ZhTransfer back = read_zh_transfer(path);
          expect_identical(t, back);
          const std::string first = read_file(path);
          write_zh_transfer(path, back);  // writing what was read gives the same bytes
          EXPECT_EQ(read_file(path), first) << what;
        }
  // Every vertex analytic: no row stored, the axes and coefficients sections empty but there.
  ZhTransfer all = make_zh(5, 2, 1, 1, false, false, 40);
  all.slots.assign(5, ZhTransfer::kAnalytic);
  all.axes.clear();
  all.coeffs.clear();
  write_zh_transfer(path, all);
  EXPECT_EQ(std::filesystem::file_size(path), transfer_file_size(all));
  expect_identical(all, read_zh_transfer(path));
  // The rest occlusion is every vertex's, analytic ones too.
  add_rest_ao(all, 43);
  write_zh_transfer(path, all);
  EXPECT_EQ(std::filesystem::file_size(path), transfer_file_size(all));
  expect_identical(all, read_zh_transfer(path));
  // The most lobes and bands, one vertex.
  const ZhTransfer big = make_zh(1, zh::kMaxBands, zh::kMaxLobes, 3, false, false, 41);
  write_zh_transfer(path, big);
  expect_identical(big, read_zh_transfer(path));
  // Slots numbering every vertex (none analytic) come back empty: the file
  // keeps only the mask, as an SH file.
  ZhTransfer numbered = make_zh(6, 3, 2, 1, false, false, 42);
  numbered.slots = {0, 1, 2, 3, 4, 5};
  write_zh_transfer(path, numbered);
  const ZhTransfer back = read_zh_transfer(path);
  EXPECT_TRUE(back.slots.empty());
  numbered.slots.clear();
  expect_identical(numbered, back);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"z.prtt"});  // no temporaries left
}

TEST(ZhTransferIo, HeaderAndSectionsAreWhereTheDocumentSays) {
  TempDir dir;
  const std::string path = dir.file("z.prtt");
  const ZhTransfer t = make_zh(10, 5, 3, 3, true, true, 3);
  write_zh_transfer(path, t);
  const std::string b = read_file(path);
  const std::size_t S = t.stored_vertices();
  EXPECT_EQ(S, 7u);
  EXPECT_EQ(b.substr(0, 8), std::string("PRTT\r\n\x1a\n", 8));
  EXPECT_EQ(get<std::uint32_t>(b, 8), 2u);     // version
  EXPECT_EQ(get<std::uint32_t>(b, 12), 128u);  // header size
  EXPECT_EQ(get<std::uint32_t>(b, 16), 2u);    // basis: zonal harmonics
  EXPECT_EQ(get<std::uint32_t>(b, 20), 5u);    // bands
  EXPECT_EQ(get<std::uint32_t>(b, 24), 3u);    // channels
  EXPECT_EQ(get<std::uint32_t>(b, 28), 2u);    // interreflected
  EXPECT_EQ(get<std::uint32_t>(b, 32), 2u);    // bounces
  EXPECT_EQ(get<std::uint32_t>(b, 36), 256u);  // samples
  EXPECT_EQ(get<float>(b, 44), 0.5f);          // albedo G
  EXPECT_EQ(get<std::uint32_t>(b, 52), 1u);    // vertex colours
  EXPECT_EQ(get<std::uint64_t>(b, 56), t.seed);
  EXPECT_EQ(get<std::uint64_t>(b, 64), 10u);   // vertices
  EXPECT_EQ(get<std::uint64_t>(b, 72), t.mesh_hash);
  EXPECT_EQ(get<std::uint32_t>(b, 80), 5u);    // sections
  EXPECT_EQ(get<std::uint32_t>(b, 84), 3u);    // lobes
  EXPECT_EQ(get<std::uint64_t>(b, 88), S);     // stored rows
  EXPECT_EQ(get<std::uint64_t>(b, 96), t.topology_hash);
  EXPECT_EQ(get<double>(b, 104), t.fit_error);
  for (std::size_t i = 112; i < 128; ++i) EXPECT_EQ(b[i], 0) << "reserved byte " << i;
  const std::vector<std::size_t> at = section_data(b);
  ASSERT_EQ(at.size(), 5u);
  const std::uint32_t kinds[5] = {24, 25, 26, 28, 29}, types[5] = {4, 1, 1, 4, 1};
  const std::uint64_t counts[5] = {1, S * 3 * 3, S * 3 * 3 * 5, 2 * 10, 2 * 10};
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(get<std::uint32_t>(b, at[i] - 24), kinds[i]);
    EXPECT_EQ(get<std::uint32_t>(b, at[i] - 20), types[i]);
    EXPECT_EQ(get<std::uint64_t>(b, at[i] - 16), counts[i]);
    EXPECT_EQ(get<std::uint64_t>(b, at[i] - 8), 4 * counts[i]);
    EXPECT_EQ(at[i] % 8, 0u);
  }
  // Vertices 1, 4 and 7 are analytic.
  EXPECT_EQ(get<std::uint32_t>(b, at[0]), (1u << 1) | (1u << 4) | (1u << 7));
  EXPECT_EQ(get<float>(b, at[1] + 4 * (9 * 1 + 3 * 2 + 1)), t.axes[9 * 1 + 3 * 2 + 1]);    // row 1, lobe 2, y
  EXPECT_EQ(get<float>(b, at[2] + 4 * (15 * 2 + 5 * 1 + 2)), t.coeffs[15 * 2 + 5 * 1 + 2]);  // row 0, channel 2, lobe 1, band 2
  // Tangent rules, every vertex's: neighbours (a, b), then weights (wa, wb).
  for (std::size_t v = 0; v < 10; ++v) {
    EXPECT_EQ(get<std::uint32_t>(b, at[3] + 8 * v), t.tangents[v].a) << v;
    EXPECT_EQ(get<std::uint32_t>(b, at[3] + 8 * v + 4), t.tangents[v].b) << v;
    EXPECT_EQ(get<float>(b, at[4] + 8 * v), t.tangents[v].wa) << v;
    EXPECT_EQ(get<float>(b, at[4] + 8 * v + 4), t.tangents[v].wb) << v;
  }
  EXPECT_EQ(b.substr(b.size() - 4), "PRTE");
  // Without analytic vertices, no mask section.
  write_zh_transfer(path, make_zh(10, 5, 3, 1, false, false, 4));
  const std::string c = read_file(path);
  EXPECT_EQ(get<std::uint32_t>(c, 80), 4u);
  EXPECT_EQ(get<std::uint64_t>(c, 88), 10u);
  EXPECT_EQ(get<std::uint32_t>(c, 128), 25u);
  const std::vector<TransferSection> s = transfer_sections(make_zh(10, 5, 3, 1, false, false, 4));
  ASSERT_EQ(s.size(), 4u);
  EXPECT_STREQ(s[0].name, "zh axes");
  EXPECT_STREQ(s[1].name, "zh coefficients");
  EXPECT_TRUE(s[1].per_vertex);
  EXPECT_EQ(s[1].bytes, 4u * 10 * 3 * 5);
  EXPECT_STREQ(s[2].name, "zh tangent rule vertices");
  EXPECT_STREQ(s[3].name, "zh tangent rule weights");
  EXPECT_EQ(s[2].bytes + s[3].bytes, 16u * 10);
  // The rest occlusion: a last section, kind 27, one f32 per vertex (all 10,
  // the analytic ones too), the section count one more.
  ZhTransfer r = t;
  add_rest_ao(r, 9);
  write_zh_transfer(path, r);
  const std::string d = read_file(path);
  EXPECT_EQ(get<std::uint32_t>(d, 80), 6u);
  const std::vector<std::size_t> ad = section_data(d);
  ASSERT_EQ(ad.size(), 6u);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(ad[i], at[i]);  // the others where they were
  EXPECT_EQ(get<std::uint32_t>(d, ad[5] - 24), 27u);
  EXPECT_EQ(get<std::uint32_t>(d, ad[5] - 20), 1u);
  EXPECT_EQ(get<std::uint64_t>(d, ad[5] - 16), 10u);
  EXPECT_EQ(get<std::uint64_t>(d, ad[5] - 8), 40u);
  EXPECT_EQ(ad[5] % 8, 0u);
  for (std::size_t v = 0; v < 10; ++v) EXPECT_EQ(get<float>(d, ad[5] + 4 * v), r.rest_ao[v]) << v;
  EXPECT_EQ(d.size(), b.size() + 24 + 40);
  const std::vector<TransferSection> rs = transfer_sections(r);
  ASSERT_EQ(rs.size(), 6u);
  EXPECT_EQ(rs[5].kind, 27u);
  EXPECT_STREQ(rs[5].name, "zh rest occlusion");
  EXPECT_TRUE(rs[5].per_vertex);
  EXPECT_EQ(rs[5].count, 10u);
  EXPECT_EQ(rs[5].bytes, 40u);
}

TEST(ZhTransferIo, DamagedFilesAreRefusedWithClearMessages) {
  TempDir dir;
  const std::string path = dir.file("z.prtt"), bad = dir.file("bad.prtt");
  // 25 stored rows of 3 lobes: 225 axis values and 225 coefficients, both padded.
  const ZhTransfer t = make_zh(37, 3, 3, 1, true, false, 5);
  write_zh_transfer(path, t);
  const std::string good = read_file(path);
  const std::vector<std::size_t> at = section_data(good);
  ASSERT_EQ(at.size(), 5u);
  auto expect_bytes = [&](const std::string& bytes, const std::vector<std::string>& words, const std::string& what) {
    write_file(bad, bytes);
    std::vector<std::string> w = words;
    w.push_back(bad);  // every message names the file
    expect_error([&] { read_zh_transfer(bad); }, w, what);
  };
  // Integrity: a flipped byte anywhere, a truncation.
  std::string b = good;
  b[at[2] + 5] ^= 0x10;
  expect_bytes(b, {"corrupt: checksum mismatch"}, "flipped byte");
  b = good;
  b[90] ^= 0x01;
  expect_bytes(b, {"corrupt: checksum mismatch"}, "flipped header byte");
  expect_bytes(good.substr(0, good.size() - 100), {"truncated"}, "truncated");
  expect_bytes(good.substr(0, 60), {"truncated"}, "truncated header");
  // Resealed values a checksum cannot catch.
  struct Case {
    std::function<void(std::string&)> edit;
    std::vector<std::string> words;
  };
  const std::vector<Case> cases = {
      {[](std::string& x) { put<std::uint32_t>(x, 84, 9); }, {"bad header", "lobes is 9", "1 to 8"}},
      {[](std::string& x) { put<std::uint32_t>(x, 84, 0); }, {"bad header", "lobes is 0"}},
      // A lobe count in range that the sections do not have.
      {[](std::string& x) { put<std::uint32_t>(x, 84, 2); }, {"'zh axes' has 225 values", "25 x 2 x 3 = 150"}},
      {[](std::string& x) { put<std::uint32_t>(x, 20, 17); }, {"bands is 17", "1 to 16"}},
      {[](std::string& x) { put<std::uint32_t>(x, 24, 2); }, {"channels is 2"}},
      {[](std::string& x) { put<std::uint32_t>(x, 28, 3); }, {"unknown transfer mode 3"}},
      {[](std::string& x) { put<float>(x, 40, 1.5f); }, {"albedo"}},
      {[](std::string& x) { put<std::uint32_t>(x, 52, 2); }, {"unknown flags 0x2"}},
      {[](std::string& x) { put<std::uint64_t>(x, 64, 0); }, {"no vertices"}},
      {[](std::string& x) { put<std::uint64_t>(x, 88, 38); }, {"more than its 37 vertices"}},
      // Stored rows that the sections do not hold (the size check comes first when they cannot fit).
      {[](std::string& x) { put<std::uint64_t>(x, 88, 26); }, {"'zh axes' has 225 values", "26 x 3 x 3 = 234"}},
      {[](std::string& x) {
         put<std::uint64_t>(x, 64, 200);
         put<std::uint64_t>(x, 88, 200);
       },
       {"200 stored vertices cannot fit"}},
      {[](std::string& x) {
         put<std::uint64_t>(x, 64, 1ull << 40);
         put<std::uint64_t>(x, 88, 1ull << 40);
       },
       {"stored vertices cannot fit in a file of"}},
      {[](std::string& x) { put<std::uint64_t>(x, 64, 1ull << 40); }, {"analytic-vertex mask alone"}},
      {[](std::string& x) { put<std::uint64_t>(x, 64, 1000); }, {"1000 vertices cannot fit", "tangent rules alone"}},
      {[](std::string& x) { put<double>(x, 104, NAN); }, {"fit error"}},
      {[](std::string& x) { put<double>(x, 104, -1.0); }, {"fit error"}},
      {[](std::string& x) { x[120] = 1; }, {"reserved byte 120"}},
      {[](std::string& x) { put<std::uint32_t>(x, 8, 3); }, {"format version 3", "zonal-harmonic files are version 2"}},
      {[](std::string& x) { put<std::uint32_t>(x, 8, 1); }, {"format version 1", "no tangent rules", "precompute"}},
      {[](std::string& x) { put<std::uint32_t>(x, 16, 7); }, {"unknown basis 7", "2 zonal harmonics"}},
      {[](std::string& x) { put<std::uint32_t>(x, 80, 2); }, {"2 sections", "with 12 analytic vertices has 5"}},
      {[&](std::string& x) { put<std::uint32_t>(x, at[1] - 24, 26); }, {"section 2 has kind 26", "'zh axes'"}},
      {[&](std::string& x) { put<std::uint32_t>(x, at[1] - 20, 2); }, {"'zh axes' has element type 2", "f32"}},
      {[&](std::string& x) { put<std::uint64_t>(x, at[2] - 8, 12); }, {"'zh coefficients'", "but 12 bytes"}},
      {[&](std::string& x) { put<std::uint64_t>(x, at[0] - 16, 1ull << 40); }, {"'zh analytic vertices' has"}},
      // The mask: a bit past the last vertex, one vertex too many, one too few.
      {[&](std::string& x) { put<std::uint32_t>(x, at[0] + 4, get<std::uint32_t>(x, at[0] + 4) | (1u << 5)); },
       {"bits set past the last vertex (37)"}},
      {[&](std::string& x) { put<std::uint32_t>(x, at[0], get<std::uint32_t>(x, at[0]) | 1u); },
       {"13 vertices marked analytic; the header says 12"}},
      {[&](std::string& x) { put<std::uint32_t>(x, at[0], get<std::uint32_t>(x, at[0]) & ~(1u << 1)); },
       {"11 vertices marked analytic"}},
      // Values: zh_transfer_problem.
      {[&](std::string& x) { put<float>(x, at[1] + 4 * 3, 2.0f); }, {"not a unit vector"}},
      {[&](std::string& x) { put<float>(x, at[2] + 4 * 7, INFINITY); }, {"not finite"}},
      {[&](std::string& x) { x[at[2] + 4 * t.coeffs.size()] = 1; }, {"padding after section 'zh coefficients'"}},
      // The tangent rules: a section's kind or type, a neighbour out of range, a
      // weight not finite, a shape none of the three.
      {[&](std::string& x) { put<std::uint32_t>(x, at[3] - 24, 29); }, {"section 4 has kind 29", "expected 28"}},
      {[&](std::string& x) { put<std::uint32_t>(x, at[4] - 20, 4); }, {"'zh tangent rule weights' has element type 4"}},
      {[&](std::string& x) { put<std::uint64_t>(x, at[3] - 16, 73); }, {"'zh tangent rule vertices' has 73", "two per vertex, 74"}},
      {[&](std::string& x) { put<std::uint32_t>(x, at[3] + 8 * 4, 37); }, {"tangent rule of vertex 4", "vertex 37, out of range"}},
      {[&](std::string& x) { put<float>(x, at[4] + 8 * 3, NAN); }, {"tangent rule of vertex 3", "non-finite weight"}},
      {[&](std::string& x) { put<float>(x, at[4] + 8 * 3 + 4, 0.5f); }, {"tangent rule of vertex 3", "is none of"}},
      {[&](std::string& x) { put<float>(x, at[4] + 8 * 2, 1.0f); }, {"tangent rule of vertex 2", "is none of"}},
  };
  ASSERT_NE((4 * t.coeffs.size()) % 8, 0u);  // the coefficients are padded (the last case)
  for (std::size_t i = 0; i < cases.size(); ++i) {
    b = good;
    cases[i].edit(b);
    reseal(b);
    expect_bytes(b, cases[i].words, "case " + std::to_string(i));
  }
  // Data after the end.
  b = good;
  b.insert(b.size() - 12, 8, '\0');
  reseal(b);
  expect_bytes(b, {"8 bytes between the last section and the trailer"}, "extra bytes");
}

TEST(ZhTransferIo, DamagedRestOcclusionIsRefused) {
  TempDir dir;
  const std::string path = dir.file("z.prtt"), bad = dir.file("bad.prtt");
  ZhTransfer t = make_zh(37, 3, 3, 1, true, false, 11);
  write_zh_transfer(path, t);
  const std::string without = read_file(path);
  add_rest_ao(t, 12);
  write_zh_transfer(path, t);
  const std::string good = read_file(path);
  const std::vector<std::size_t> at = section_data(good);
  ASSERT_EQ(at.size(), 6u);
  struct Case {
    const std::string* file;
    std::function<void(std::string&)> edit;
    std::vector<std::string> words;
  };
  const std::vector<Case> cases = {
      // Values outside [0, 1] (zh_transfer_problem).
      {&good, [&](std::string& x) { put<float>(x, at[5] + 4 * 5, 1.5f); }, {"rest occlusion of vertex 5 is 1.5"}},
      {&good, [&](std::string& x) { put<float>(x, at[5] + 4 * 6, -0.25f); }, {"rest occlusion of vertex 6", "[0, 1]"}},
      {&good, [&](std::string& x) { put<float>(x, at[5], NAN); }, {"rest occlusion of vertex 0"}},
      // Section counts and the section itself.
      {&good, [](std::string& x) { put<std::uint32_t>(x, 80, 7); },
       {"7 sections", "has 5 (6 with its rest occlusion)"}},
      {&good, [](std::string& x) { put<std::uint32_t>(x, 80, 5); }, {"between the last section and the trailer"}},
      {&without, [](std::string& x) { put<std::uint32_t>(x, 80, 6); }, {"section 6 of 6 is missing"}},
      {&good, [&](std::string& x) { put<std::uint32_t>(x, at[5] - 24, 28); }, {"section 6 has kind 28", "expected 27"}},
      {&good, [&](std::string& x) { put<std::uint32_t>(x, at[5] - 20, 2); },
       {"'zh rest occlusion' has element type 2"}},
      {&good, [&](std::string& x) { put<std::uint64_t>(x, at[5] - 16, 36); },
       {"'zh rest occlusion' has 36 values", "one per vertex, 37"}},
      // More vertices than the file can hold values for (the mask would fit).
      {&good, [](std::string& x) { put<std::uint64_t>(x, 64, 2000); },
       {"2000 vertices cannot fit", "tangent rules alone"}},
  };
  for (std::size_t i = 0; i < cases.size(); ++i) {
    std::string b = *cases[i].file;
    cases[i].edit(b);
    reseal(b);
    write_file(bad, b);
    std::vector<std::string> w = cases[i].words;
    w.push_back(bad);
    expect_error([&] { read_zh_transfer(bad); }, w, "case " + std::to_string(i));
  }
  // The writer refuses a wrong count or a value out of range, writing nothing.
  const std::string out = dir.file("out.prtt");
  ZhTransfer z = t;
  z.rest_ao.pop_back();
  expect_error([&] { write_zh_transfer(out, z); }, {out, "36 rest occlusion values for 37 vertices"}, "short");
  z = t;
  z.rest_ao[3] = 1.0f + 1e-6f;
  expect_error([&] { write_zh_transfer(out, z); }, {out, "rest occlusion of vertex 3"}, "above 1");
  z.rest_ao[3] = NAN;
  expect_error([&] { write_zh_transfer(out, z); }, {out, "rest occlusion of vertex 3"}, "NaN");
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(ZhTransferIo, EachReaderRefusesTheOtherBasesNamingThem) {
  TempDir dir;
  const std::string zh = dir.file("z.prtt"), sh = dir.file("s.prtt"), wl = dir.file("w.prtt");
  write_zh_transfer(zh, make_zh(4, 3, 2, 1, false, false, 6));
  Transfer s;
  s.bands = 3;
  s.vertices = 2;
  s.coeffs.assign(2 * 9, 0.5f);
  write_transfer(sh, s);
  WaveletTransfer w;  // no coefficient kept: the smallest valid wavelet transfer
  w.cube_res = 2;
  w.vertices = 2;
  w.col_offsets.assign(wavelet::cube_size(2) + 1, 0);
  w.vertex_scale.assign(2, 0.0f);
  w.vertex_kept.assign(2, 0);
  write_wavelet_transfer(wl, w);

  EXPECT_EQ(kind_of(read_transfer_file(zh)), TransferKind::ZH);
  EXPECT_EQ(kind_names(TransferKind::ZH).id, "zh");
  expect_error([&] { read_transfer(zh); },
               {zh, "holds a zonal-harmonic (local deformable) transfer", "2 lobes of 3 bands", "prt::read_zh_transfer"},
               "SH reader");
  expect_error([&] { read_wavelet_transfer(zh); },
               {zh, "holds a zonal-harmonic (local deformable) transfer", "prt::read_zh_transfer"}, "wavelet reader");
  expect_error([&] { read_compressed_transfer(zh); }, {zh, "zonal-harmonic", "prt::read_zh_transfer"},
               "compressed reader");
  expect_error([&] { read_zh_transfer(sh); }, {sh, "spherical-harmonics", "3 bands", "prt::read_transfer"}, "ZH on SH");
  expect_error([&] { read_zh_transfer(wl); }, {wl, "wavelet transfer", "prt::read_wavelet_transfer"}, "ZH on wavelet");
  // Not taken for a compressed transfer or a lightmap: their typed readers
  // refuse it, naming what it holds.
  expect_error([&] { (void)read_transfer_as<CompressedTransfer>(zh); },
               {zh, "holds a zonal-harmonic (local deformable) transfer", "not a compressed SH transfer"},
               "read as compressed");
  expect_error([&] { (void)read_transfer_as<LightmapTransfer>(zh); },
               {zh, "holds a zonal-harmonic (local deformable) transfer", "not an SH lightmap"}, "read as a lightmap");
}

TEST(ZhTransferIo, WriterRefusesInconsistentTransfersAndWritesNothing) {
  TempDir dir;
  const std::string path = dir.file("z.prtt");
  const ZhTransfer good = make_zh(8, 3, 2, 3, true, false, 7);
  std::vector<std::pair<ZhTransfer, std::string>> cases;
  ZhTransfer t = good;
  t.axes.pop_back();
  cases.push_back({t, "axis values"});
  t = good;
  t.coeffs.push_back(0.0f);
  cases.push_back({t, "coefficients for"});
  t = good;
  t.lobes = 9;
  cases.push_back({t, "lobes is 9"});
  t = good;
  t.bands = 17;
  cases.push_back({t, "bands is 17"});
  t = good;
  t.channels = 2;
  cases.push_back({t, "channels is 2"});
  t = good;
  t.axes[4] = 3.0f;
  cases.push_back({t, "not a unit vector"});
  t = good;
  t.coeffs[2] = NAN;
  cases.push_back({t, "not finite"});
  t = good;
  t.slots[0] = 1;
  cases.push_back({t, "slot of vertex 0"});
  t = good;
  t.fit_error = -0.5;
  cases.push_back({t, "fit error"});
  t = good;
  t.tangents.pop_back();
  cases.push_back({t, "7 tangent rules for 8 vertices"});
  t = good;
  t.tangents[1].b = 8;
  cases.push_back({t, "names vertex 8, out of range"});
  for (const auto& [z, words] : cases) {
    expect_error([&] { write_zh_transfer(path, z); }, {path, "cannot write this zonal-harmonic transfer", words}, words);
    EXPECT_FALSE(std::filesystem::exists(path)) << words;
  }
  EXPECT_TRUE(dir.listing().empty());
  // A refused write leaves an existing file as it was.
  write_zh_transfer(path, good);
  const std::string before = read_file(path);
  expect_error([&] { write_zh_transfer(path, cases[0].first); }, {path}, "over an existing file");
  EXPECT_EQ(read_file(path), before);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"z.prtt"});
}

TEST(ZhTransferIo, DescribeAndCheckMatchesTheRestPose) {
  const Mesh m = test::quad(2);
  ZhTransfer t = make_zh(m.vertex_count(), 3, 2, 1, true, false, 8);
  t.mesh_hash = m.hash();
  t.topology_hash = topology_hash(m);
  const std::string d = describe_transfer(t);
  for (const char* w : {"zonal-harmonic", "format version 2", "lobes", "tangents", "3 from texture coordinates",
                        "3 by the edge rule", "3 none", "2 per stored vertex", "bands", "fit error",
                        "bytes per vertex", "topology hash", "file size"})
    EXPECT_TRUE(contains(d, w)) << "'" << w << "' missing from:\n" << d;
  EXPECT_TRUE(contains(d, std::to_string(transfer_file_size(t)) + " bytes")) << d;
  EXPECT_TRUE(contains(d, std::to_string(t.analytic_vertices()) + " analytic")) << d;
  ASSERT_FALSE(d.empty());
  EXPECT_EQ(d.back(), '\n');
  EXPECT_TRUE(contains(d, "rest occlusion") && contains(d, "none")) << d;
  ZhTransfer r = t;
  r.rest_ao = {0.25f, 0.5f, 0.75f, 1.0f, 1.0f, 1.0f, 1.0f, 1.0f, 0.0f};  // the quad's 9 vertices: mean 0.7222
  const std::string e = describe_transfer(r);
  EXPECT_TRUE(contains(e, "mean 0.7222, 0.0000 to 1.0000")) << e;
  EXPECT_TRUE(contains(e, std::to_string(transfer_file_size(r)) + " bytes")) << e;
  EXPECT_TRUE(contains(e, "4 per vertex (rest occlusion)")) << e;

  EXPECT_NO_THROW(check_matches(t, m, "z.prtt"));
  const Mesh other = test::quad(3);
  expect_error([&] { check_matches(t, other, "z.prtt"); }, {"z.prtt", "different mesh", "prt precompute --basis zh"},
               "other mesh");
  t.vertex_colors = true;
  expect_error([&] { check_matches(t, m, "z.prtt"); }, {"z.prtt", "vertex colours"}, "no colours");
}

}  // namespace
}  // namespace prt
