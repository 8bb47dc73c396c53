// Transfer at scale (docs/PRECOMPUTE.md, "Memory" and "Many processes"): a
// memory limit that sends records to the temporary file, and the vertices
// split over ranks, give the same bits as one unlimited process. The ranks
// run here as threads sharing memory (ThreadRanks); tests/mpi runs the same
// split under mpirun.
#include "test_meshes.h"

#include <prt/communicator.h>
#include <prt/error.h>
#include <prt/precompute.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <barrier>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

namespace prt {
namespace {

// N ranks as threads: each operation is a rendezvous of all of them.
class ThreadRanks {
 public:
  explicit ThreadRanks(int n) : n_(n), barrier_(n), data_(std::size_t(n)), mine_(std::size_t(n)) {}

  class Rank final : public Communicator {
   public:
    Rank(ThreadRanks& all, int r) : all_(all), r_(r) {}
    int rank() const override { return r_; }
    int size() const override { return all_.n_; }
    void all_gather(void* data, std::span<const std::size_t> blocks) const override {
      all_.data_[std::size_t(r_)] = data;
      all_.barrier_.arrive_and_wait();
      for (int q = 0; q < all_.n_; ++q)
        if (q != r_)
          std::memcpy(static_cast<char*>(data) + blocks[std::size_t(q)],
                      static_cast<const char*>(all_.data_[std::size_t(q)]) + blocks[std::size_t(q)],
                      blocks[std::size_t(q) + 1] - blocks[std::size_t(q)]);
      all_.barrier_.arrive_and_wait();
    }
    void gather_to_root(const void* mine, void* all, std::span<const std::size_t> blocks) const override {
      all_.mine_[std::size_t(r_)] = mine;
      all_.barrier_.arrive_and_wait();
      if (r_ == 0)
        for (int q = 0; q < all_.n_; ++q)
          std::memmove(static_cast<char*>(all) + blocks[std::size_t(q)], all_.mine_[std::size_t(q)],
                       blocks[std::size_t(q) + 1] - blocks[std::size_t(q)]);
      all_.barrier_.arrive_and_wait();
    }

   private:
    ThreadRanks& all_;
    int r_;
  };

  // Runs f(communicator) on every rank at once; returns rank 0's result.
  template <typename F>
  auto run(F f) -> decltype(f(std::declval<const Communicator&>())) {
    std::vector<decltype(f(std::declval<const Communicator&>()))> results(static_cast<std::size_t>(n_));
    std::vector<std::thread> threads;
    for (int r = 0; r < n_; ++r)
      threads.emplace_back([&, r] {
        const Rank rank(*this, r);
        results[std::size_t(r)] = f(rank);
      });
    for (auto& t : threads) t.join();
    return std::move(results[0]);
  }

 private:
  int n_;
  std::barrier<> barrier_;
  std::vector<void*> data_;
  std::vector<const void*> mine_;
};

void expect_same(const Transfer& a, const Transfer& b, const std::string& what) {
  EXPECT_EQ(a.vertices, b.vertices) << what;
  EXPECT_EQ(a.coeffs, b.coeffs) << what;
  EXPECT_EQ(a.direct, b.direct) << what;
  EXPECT_EQ(a.slots, b.slots) << what;
  EXPECT_EQ(a.ao, b.ao) << what;
  EXPECT_EQ(a.bent_normals, b.bent_normals) << what;
  EXPECT_EQ(a.glossy_matrices, b.glossy_matrices) << what;
  EXPECT_EQ(a.bounces, b.bounces) << what;
  EXPECT_EQ(a.bounce_energy, b.bounce_energy) << what;
  EXPECT_EQ(a.direct_energy, b.direct_energy) << what;
  EXPECT_EQ(a.shading_hash, b.shading_hash) << what;
}

struct Case {
  const char* name;
  TransferOptions o;
};

std::vector<Case> cases() {
  std::vector<Case> c;
  TransferOptions o;
  o.bands = 4;
  o.samples = 128;
  o.albedo = glm::vec3(0.8f);
  o.mode = TransferMode::Unshadowed;
  c.push_back({"unshadowed", o});
  o.mode = TransferMode::Shadowed;
  c.push_back({"shadowed", o});
  o.mode = TransferMode::Interreflected;
  o.bounces = 3;
  c.push_back({"interreflected, 3 bounces", o});
  o.albedo = glm::vec3(0.9f, 0.6f, 0.3f);
  o.bounces = 1;
  c.push_back({"interreflected RGB", o});
  o.bands = 3;
  o.glossy = true;
  c.push_back({"glossy interreflected RGB", o});
  o.mode = TransferMode::Shadowed;
  o.albedo = glm::vec3(0.8f);
  c.push_back({"glossy shadowed", o});
  return c;
}

TEST(TransferScale, RanksGiveTheSameBits) {
  const Mesh m = test::floor_and_ball(24);
  for (const Case& c : cases()) {
    const Transfer one = compute_transfer(m, c.o);
    if (c.o.mode != TransferMode::Unshadowed) {
      ASSERT_GT(one.stored_vertices(), 100u) << c.name;
    }
    for (int n : {2, 3}) {
      ThreadRanks ranks(n);
      const Transfer split = ranks.run([&](const Communicator& comm) {
        TransferOptions o = c.o;
        o.comm = &comm;
        return compute_transfer(m, o);
      });
      expect_same(one, split, std::string(c.name) + ", " + std::to_string(n) + " ranks");
    }
  }
}

TEST(TransferScale, WaveletRanksGiveTheSameBits) {
  const Mesh m = test::floor_and_ball(16);
  WaveletOptions o;
  o.cube_res = 8;
  const WaveletTransfer one = compute_wavelet_transfer(m, o);
  ASSERT_GT(one.kept(), 1000u);
  for (int n : {2, 3}) {
    ThreadRanks ranks(n);
    const WaveletTransfer split = ranks.run([&](const Communicator& comm) {
      WaveletOptions w = o;
      w.comm = &comm;
      return compute_wavelet_transfer(m, w);
    });
    EXPECT_EQ(one.vertex_scale, split.vertex_scale) << n;
    EXPECT_EQ(one.vertex_kept, split.vertex_kept) << n;
    EXPECT_EQ(one.col_offsets, split.col_offsets) << n;
    EXPECT_EQ(one.col_vertices, split.col_vertices) << n;
    EXPECT_EQ(one.col_values, split.col_values) << n;
  }
}

// Records past what may stay in memory go to the temporary file and come
// back for each bounce: the same bits as all in memory. The cap
// (records_in_memory_max) is what memory_limit sets from what the rest
// leaves; set directly, it does not depend on this process's own size.
TEST(TransferScale, RecordsPastTheLimitGiveTheSameBits) {
  const Mesh m = test::floor_and_ball(40);
  for (const Case& c : cases()) {
    if (c.o.mode != TransferMode::Interreflected) continue;  // only the bounces keep records
    TransferMemory all_in_memory, capped;
    TransferOptions o = c.o;
    o.memory_report = &all_in_memory;
    const Transfer free_run = compute_transfer(m, o);
    EXPECT_EQ(all_in_memory.records_spilled, 0u) << c.name;
    ASSERT_GT(all_in_memory.records_in_memory, 0u) << c.name;
    o.records_in_memory_max = all_in_memory.records_in_memory / 3;
    o.memory_report = &capped;
    const Transfer spilled = compute_transfer(m, o);
    EXPECT_GT(capped.records_spilled, 0u) << c.name << ": nothing went to the temporary file";
    EXPECT_LE(capped.records_in_memory, o.records_in_memory_max) << c.name;
    EXPECT_EQ(capped.records_in_memory + capped.records_spilled, all_in_memory.records_in_memory) << c.name;
    expect_same(free_run, spilled, c.name);
    // A memory limit the run fits under: blocks sized from it, the same bits.
    TransferMemory limited;
    o.records_in_memory_max = std::numeric_limits<std::size_t>::max();
    o.memory_limit = transfer_memory(m, o).minimum + (64u << 20);
    o.memory_report = &limited;
    expect_same(free_run, compute_transfer(m, o), std::string(c.name) + ", limited");
    EXPECT_GE(limited.block, 64u) << c.name;
  }
}

// Adaptive sample points (precompute/adaptive.cpp) split every batch over
// the ranks, which all make the same choices: the same bits as one process,
// the interpolated vertices included; and under a memory limit that sends
// the bounces' records to the temporary file.
TEST(TransferScale, AdaptiveRanksAndLimitsGiveTheSameBits) {
  const Mesh m = test::floor_and_ball(60);
  for (const Case& c : cases()) {
    if (c.o.mode == TransferMode::Unshadowed) continue;
    AdaptiveReport r;
    const Transfer one = compute_adaptive_transfer(m, c.o, {}, {}, &r);
    ASSERT_GT(one.interpolated_vertices(), 100u) << c.name;
    for (int n : {2, 3}) {
      ThreadRanks ranks(n);
      const Transfer split = ranks.run([&](const Communicator& comm) {
        TransferOptions o = c.o;
        o.comm = &comm;
        return compute_adaptive_transfer(m, o, {});
      });
      expect_same(one, split, std::string(c.name) + ", adaptive, " + std::to_string(n) + " ranks");
      EXPECT_EQ(one.interpolated, split.interpolated) << c.name;
    }
    if (c.o.mode != TransferMode::Interreflected) continue;
    TransferOptions o = c.o;
    o.records_in_memory_max = 4096;  // a few vertices' records: the rest to the temporary file
    const Transfer capped = compute_adaptive_transfer(m, o, {});
    expect_same(one, capped, std::string(c.name) + ", adaptive, records capped");
    EXPECT_EQ(one.interpolated, capped.interpolated) << c.name;
  }
}

TEST(TransferScale, TooSmallALimitIsRefusedBeforeAnyRay) {
  const Mesh m = test::floor_and_ball(24);
  TransferOptions o = cases()[2].o;
  const TransferMemory need = transfer_memory(m, o);
  EXPECT_GT(need.fixed, 0u);
  EXPECT_GT(need.minimum, need.base + need.fixed);
  o.memory_limit = need.base + need.fixed / 2;
  bool traced = false;
  try {
    compute_transfer(m, o, [&](std::size_t, std::size_t, const char*) {
      traced = true;
      return true;
    });
    FAIL() << "a limit below the minimum was taken";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("--memory-limit"), std::string::npos) << msg;
    EXPECT_NE(msg.find("the smallest limit that works is"), std::string::npos) << msg;
  }
  EXPECT_FALSE(traced) << "rays were traced before the limit was refused";
}

// Points (SamplePoints) where the vertices are: the same first pass, so the
// same bits without bounces; with bounces the vertices' light is gathered
// once from their totals instead of bounce by bounce, the same sums grouped
// otherwise: float rounding apart.
SamplePoints vertices_of(const Mesh& m) {
  SamplePoints p;
  p.positions = m.positions;
  p.normals = m.normals;
  return p;
}

// Relative to the largest coefficient: float storage of sums of a few
// hundred terms regrouped (each ~6e-8 relative); 1e-5 leaves room for the
// regrouping, while a missing or doubled bounce (energy 7-25% of the direct
// part here) is 1e-2 and more.
constexpr double kRegroupedTol = 1e-5;

// Float storage of a clamped cosine evaluated twice (relight's analytic rows
// in dense_transfer, the first pass's direct rows): a few ulps of |T| <= 1.
constexpr double kAnalyticTol = 1e-6;

TEST(TransferScale, PointsAtTheVerticesAreTheVertices) {
  const Mesh m = test::floor_and_ball(24);
  for (const Case& c : cases()) {
    if (c.o.glossy) continue;
    const Transfer at_vertices = compute_transfer(m, c.o);
    const Transfer at_points = compute_point_transfer(m, vertices_of(m), c.o);
    EXPECT_EQ(at_points.vertices, at_vertices.vertices) << c.name;
    EXPECT_TRUE(at_points.slots.empty()) << c.name << ": points keep every row";
    EXPECT_EQ(at_points.ao, at_vertices.ao) << c.name;
    EXPECT_EQ(at_points.bent_normals, at_vertices.bent_normals) << c.name;
    // Stored vertices: the same bits (direct part); analytic ones: the same
    // clamped cosine, evaluated again.
    const std::vector<float> dense = dense_transfer(at_vertices, m), dense_direct =
        c.o.mode == TransferMode::Interreflected ? dense_transfer(at_vertices, m, true) : dense;
    const std::vector<float>& direct = c.o.mode == TransferMode::Interreflected ? at_points.direct : at_points.coeffs;
    ASSERT_EQ(direct.size(), dense_direct.size()) << c.name;
    const std::size_t stride = at_vertices.stride();
    std::size_t analytic = 0;
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      const bool stored = !at_vertices.is_analytic(v);
      analytic += !stored;
      for (std::size_t k = 0; k < stride; ++k) {
        const std::size_t i = v * stride + k;
        if (stored) {
          ASSERT_EQ(direct[i], dense_direct[i]) << c.name << ", vertex " << v;
        } else {
          ASSERT_NEAR(direct[i], dense_direct[i], kAnalyticTol) << c.name << ", vertex " << v;
        }
      }
    }
    if (c.o.mode == TransferMode::Unshadowed) {
      EXPECT_EQ(analytic, m.vertex_count()) << c.name;
    }
    if (c.o.mode != TransferMode::Interreflected) continue;
    double largest = 0, worst = 0, bounce = 0;
    for (std::size_t i = 0; i < dense.size(); ++i) {
      largest = std::max(largest, double(std::abs(dense[i])));
      worst = std::max(worst, double(std::abs(at_points.coeffs[i] - dense[i])));
      bounce = std::max(bounce, double(std::abs(dense[i] - dense_direct[i])));
    }
    EXPECT_LT(worst, kRegroupedTol * largest) << c.name;
    EXPECT_GT(bounce, 100 * kRegroupedTol * largest) << c.name << ": the bounces should be far above the tolerance";
  }
}

TEST(TransferScale, PointsSplitAndSpillLikeVertices) {
  const Mesh m = test::floor_and_ball(24);
  // Off the vertices: the triangles' centres, face normals, their own albedo.
  SamplePoints pts;
  for (const glm::uvec3& t : m.triangles) {
    const glm::vec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
    const glm::vec3 n = glm::cross(b - a, c - a);
    if (glm::length(n) == 0.0f) continue;
    pts.positions.push_back((a + b + c) / 3.0f);
    pts.normals.push_back(glm::normalize(n));
    pts.albedo.push_back(glm::vec3(0.9f, 0.5f, float(pts.albedo.size() % 7) / 7.0f));
  }
  TransferOptions o = cases()[2].o;  // interreflected, 3 bounces
  const Transfer one = compute_point_transfer(m, pts, o);
  EXPECT_EQ(one.vertices, pts.positions.size());
  EXPECT_EQ(one.channels, 3);
  EXPECT_GT(one.stored_vertices(), 100u);
  for (int n : {2, 3}) {
    ThreadRanks ranks(n);
    const Transfer split = ranks.run([&](const Communicator& comm) {
      TransferOptions r = o;
      r.comm = &comm;
      return compute_point_transfer(m, pts, r);
    });
    expect_same(one, split, "points, " + std::to_string(n) + " ranks");
  }
  TransferOptions capped = o;
  capped.records_in_memory_max = 1000;  // the vertex pass's records go to the file
  expect_same(one, compute_point_transfer(m, pts, capped), "points, records spilled");
}

TEST(TransferScale, BadPointsAreRefused) {
  const Mesh m = test::floor_and_ball(8);
  TransferOptions o = cases()[1].o;
  SamplePoints p = vertices_of(m);
  p.normals[3] = glm::vec3(0.5f, 0.0f, 0.0f);
  EXPECT_THROW(compute_point_transfer(m, p, o), Error);
  p = vertices_of(m);
  p.normals.pop_back();
  EXPECT_THROW(compute_point_transfer(m, p, o), Error);
  p = vertices_of(m);
  p.albedo.assign(p.positions.size(), glm::vec3(0.5f));
  p.albedo[2].y = 1.5f;
  EXPECT_THROW(compute_point_transfer(m, p, o), Error);
  p = vertices_of(m);
  p.positions[0].x = std::numeric_limits<float>::infinity();
  EXPECT_THROW(compute_point_transfer(m, p, o), Error);
  o.glossy = true;
  EXPECT_THROW(compute_point_transfer(m, vertices_of(m), o), Error);
}

}  // namespace
}  // namespace prt
