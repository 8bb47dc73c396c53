// build_flat_bvh (prt/precompute.h): Embree 3's BVH builder (rtcBuildBVH,
// binned SAH, two children per node) builds a temporary tree in Embree's
// thread-local allocator through our callbacks; we flatten it depth first
// into prt/point_tracer.h's FlatBvh.
//
// Deterministic: the same mesh gives the same bytes on every machine.
// Embree's parallel partitioning splits the primitive array into as many
// blocks as the arena has threads, so the order of the primitives within a
// node, and with it every split that falls back to the array's order (all
// centroids in one bin; the balanced subtrees near the depth limit) and the
// order of a leaf's triangles, depends on the thread count. The build
// therefore runs in a TBB arena of one thread (Embree's TBB tasks run in the
// caller's arena; no global setting changes), and each leaf's triangles are
// sorted by mesh index besides.
//
// Bounds: every node's lo/hi are the float min/max of the corners of the
// triangles under it, recomputed here from the corners (Embree's boxes are
// the same unions, but we do not rely on that).
#include <prt/precompute.h>

#include <prt/error.h>

#include <fmt/format.h>

#include <embree3/rtcore.h>
#include <tbb/task_arena.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <mutex>
#include <new>
#include <string>
#include <vector>

namespace prt {

namespace {

// A node of the temporary tree (Embree's allocator owns its memory).
struct FbvhTmpNode {
  const FbvhTmpNode* child[2];
  std::uint32_t count;                 // 0: an inner node; else a leaf of `count` triangles
  std::uint32_t ids[kFlatBvhMaxLeaf];  // a leaf's mesh triangle indices, ascending
};

// What the callbacks share (rtcBuildArguments::userPtr).
struct FbvhBuildState {
  std::size_t max_leaf = 0;
  std::atomic<bool> failed{false};  // a callback could not do its part (the reason below)
  std::mutex mutex;
  std::string why;
  void fail(const std::string& reason) {
    std::lock_guard<std::mutex> lock(mutex);
    if (why.empty()) why = reason;
    failed = true;
  }
};

void fbvh_on_embree_error(void* user, RTCError code, const char* str) {
  static_cast<FbvhBuildState*>(user)->fail(
      fmt::format("Embree error {}{}{}", int(code), str ? ": " : "", str ? str : ""));
}

void* fbvh_create_node(RTCThreadLocalAllocator alloc, unsigned child_count, void* user) {
  auto* state = static_cast<FbvhBuildState*>(user);
  if (child_count != 2) {
    state->fail(fmt::format("Embree made a node of {} children (asked for 2)", child_count));
    return nullptr;
  }
  void* memory = rtcThreadLocalAlloc(alloc, sizeof(FbvhTmpNode), alignof(FbvhTmpNode));
  if (!memory) {
    state->fail("Embree could not allocate a node");
    return nullptr;
  }
  return new (memory) FbvhTmpNode{{nullptr, nullptr}, 0, {}};
}

void fbvh_set_children(void* node, void** children, unsigned child_count, void*) {
  if (!node || child_count != 2) return;  // create_node failed already
  auto* n = static_cast<FbvhTmpNode*>(node);
  n->child[0] = static_cast<const FbvhTmpNode*>(children[0]);
  n->child[1] = static_cast<const FbvhTmpNode*>(children[1]);
}

// The bounds are recomputed from the corners when flattening.
void fbvh_set_bounds(void*, const RTCBounds**, unsigned, void*) {}

void* fbvh_create_leaf(RTCThreadLocalAllocator alloc, const RTCBuildPrimitive* prims, std::size_t count, void* user) {
  auto* state = static_cast<FbvhBuildState*>(user);
  if (count < 1 || count > state->max_leaf) {
    state->fail(fmt::format("Embree made a leaf of {} triangles (at most {} asked)", count, state->max_leaf));
    return nullptr;
  }
  void* memory = rtcThreadLocalAlloc(alloc, sizeof(FbvhTmpNode), alignof(FbvhTmpNode));
  if (!memory) {
    state->fail("Embree could not allocate a leaf");
    return nullptr;
  }
  auto* leaf = new (memory) FbvhTmpNode{{nullptr, nullptr}, std::uint32_t(count), {}};
  for (std::size_t i = 0; i < count; ++i) leaf->ids[i] = prims[i].primID;
  std::sort(leaf->ids, leaf->ids + count);
  return leaf;
}

// The build primitives: the mesh's triangles that have an area (twice the
// area, in double, > 0 and finite: as prt's mesh loader counts degenerate
// ones) and finite corners; primID = the mesh's triangle index.
std::vector<RTCBuildPrimitive> fbvh_primitives(const Mesh& mesh) {
  std::vector<RTCBuildPrimitive> prims;
  prims.reserve(mesh.triangles.size());
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const glm::uvec3 t = mesh.triangles[i];
    PRT_CHECK(t.x < mesh.positions.size() && t.y < mesh.positions.size() && t.z < mesh.positions.size());
    const glm::vec3 a = mesh.positions[t.x], b = mesh.positions[t.y], c = mesh.positions[t.z];
    bool finite = true;
    for (int k = 0; k < 3; ++k) finite = finite && std::isfinite(a[k]) && std::isfinite(b[k]) && std::isfinite(c[k]);
    const double twice_area =
        glm::length(glm::cross(glm::dvec3(b) - glm::dvec3(a), glm::dvec3(c) - glm::dvec3(a)));
    if (!finite || !(twice_area > 0.0) || !std::isfinite(twice_area)) continue;
    const glm::vec3 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
    RTCBuildPrimitive p;
    p.lower_x = lo.x;
    p.lower_y = lo.y;
    p.lower_z = lo.z;
    p.geomID = 0;
    p.upper_x = hi.x;
    p.upper_y = hi.y;
    p.upper_z = hi.z;
    p.primID = unsigned(i);
    prims.push_back(p);
  }
  return prims;
}

// Embree's device and BVH, released on every path.
struct FbvhEmbree {
  RTCDevice device = nullptr;
  RTCBVH bvh = nullptr;
  ~FbvhEmbree() {
    if (bvh) rtcReleaseBVH(bvh);
    if (device) rtcReleaseDevice(device);
  }
};

// The temporary tree's root (valid while `embree` lives); throws prt::Error
// naming the reason when Embree fails.
const FbvhTmpNode* fbvh_build_tree(std::vector<RTCBuildPrimitive>& prims, int max_leaf, FbvhEmbree& embree,
                                   FbvhBuildState& state) {
  embree.device = rtcNewDevice(nullptr);
  if (!embree.device)
    throw Error(fmt::format("Embree: cannot create a device (error {})", int(rtcGetDeviceError(nullptr))));
  rtcSetDeviceErrorFunction(embree.device, fbvh_on_embree_error, &state);
  embree.bvh = rtcNewBVH(embree.device);
  if (!embree.bvh) throw Error("Embree: cannot create a BVH: " + state.why);
  state.max_leaf = std::size_t(max_leaf);
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.byteSize = sizeof(args);
  args.buildQuality = RTC_BUILD_QUALITY_HIGH;  // binned SAH (no spatial splits: no splitPrimitive)
  args.maxBranchingFactor = 2;
  args.maxDepth = kFlatBvhMaxDepth + 1;  // Embree's root is at depth 1, ours at 0
  args.sahBlockSize = 1;
  args.minLeafSize = 1;
  args.maxLeafSize = unsigned(max_leaf);
  args.bvh = embree.bvh;
  args.primitives = prims.data();
  args.primitiveCount = prims.size();
  args.primitiveArrayCapacity = prims.size();
  args.createNode = fbvh_create_node;
  args.setNodeChildren = fbvh_set_children;
  args.setNodeBounds = fbvh_set_bounds;
  args.createLeaf = fbvh_create_leaf;
  args.userPtr = &state;
  void* root = nullptr;
  tbb::task_arena one_thread(1);  // determinism: see the top of this file
  one_thread.execute([&] { root = rtcBuildBVH(&args); });
  if (state.failed || !root)
    throw Error(fmt::format("building the flat BVH (at most {} deep, leaves of at most {} triangles) failed: {}",
                            kFlatBvhMaxDepth, max_leaf, state.why.empty() ? "Embree returned no tree" : state.why));
  return static_cast<const FbvhTmpNode*>(root);
}

// Flattens the temporary tree depth first (a node, then its first child's
// subtree, then its second's) into out.nodes, the leaves' triangles into
// out.corners and out.triangle_ids; sets out.depth. Leaf bounds only.
void fbvh_flatten(const FbvhTmpNode* root, const Mesh& mesh, FlatBvh& out) {
  struct Pending {
    const FbvhTmpNode* node;
    std::int64_t parent;  // -1: the root
    int side;             // 0: the parent's a, 1: its b
    int depth;
  };
  std::vector<Pending> todo{{root, -1, 0, 0}};
  while (!todo.empty()) {
    const Pending p = todo.back();
    todo.pop_back();
    const std::uint32_t index = std::uint32_t(out.nodes.size());
    if (p.parent >= 0) (p.side == 0 ? out.nodes[p.parent].a : out.nodes[p.parent].b) = index;
    out.depth = std::max(out.depth, p.depth);
    FlatBvhNode node{};
    if (p.node->count == 0) {
      out.nodes.push_back(node);
      todo.push_back({p.node->child[1], index, 1, p.depth + 1});
      todo.push_back({p.node->child[0], index, 0, p.depth + 1});
      continue;
    }
    node.a = std::uint32_t(out.triangle_ids.size());
    node.b = kFlatBvhLeaf | p.node->count;
    glm::vec3 lo(INFINITY), hi(-INFINITY);
    for (std::uint32_t k = 0; k < p.node->count; ++k) {
      const std::uint32_t id = p.node->ids[k];
      out.triangle_ids.push_back(id);
      for (int c = 0; c < 3; ++c) {
        const glm::vec3 v = mesh.positions[mesh.triangles[id][c]];
        out.corners.emplace_back(v, 0.0f);
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
      }
    }
    for (int c = 0; c < 3; ++c) {
      node.lo[c] = lo[c];
      node.hi[c] = hi[c];
    }
    out.nodes.push_back(node);
  }
}

// Inner nodes' bounds: the union of their children's. Depth first, a child
// comes after its parent, so one pass from the back sees children first.
void fbvh_inner_bounds(FlatBvh& out) {
  for (std::size_t i = out.nodes.size(); i-- > 0;) {
    FlatBvhNode& n = out.nodes[i];
    if (n.b & kFlatBvhLeaf) continue;
    const FlatBvhNode &l = out.nodes[n.a], &r = out.nodes[n.b];
    for (int c = 0; c < 3; ++c) {
      n.lo[c] = std::min(l.lo[c], r.lo[c]);
      n.hi[c] = std::max(l.hi[c], r.hi[c]);
    }
  }
}

}  // namespace

FlatBvh build_flat_bvh(const Mesh& mesh, int max_leaf) {
  if (max_leaf < 1 || max_leaf > kFlatBvhMaxLeaf)
    throw Error(fmt::format("the flat BVH's leaves take 1 to {} triangles, got {}", kFlatBvhMaxLeaf, max_leaf));
  // Node indices keep kFlatBvhLeaf clear: at most 2 N - 1 nodes < 2^31.
  constexpr std::size_t kMaxTriangles = std::size_t(1) << 30;
  if (mesh.triangles.size() > kMaxTriangles)
    throw Error(fmt::format("{}: {} triangles, more than the flat BVH takes ({})", mesh.source,
                            mesh.triangles.size(), kMaxTriangles));
  FlatBvh out;
  std::vector<RTCBuildPrimitive> prims = fbvh_primitives(mesh);
  if (prims.empty()) return out;
  FbvhEmbree embree;
  FbvhBuildState state;
  const FbvhTmpNode* root = fbvh_build_tree(prims, max_leaf, embree, state);
  out.nodes.reserve(2 * prims.size());
  out.triangle_ids.reserve(prims.size());
  out.corners.reserve(3 * prims.size());
  fbvh_flatten(root, mesh, out);
  fbvh_inner_bounds(out);
  if (out.depth > kFlatBvhMaxDepth)
    throw Error(fmt::format("{}: the flat BVH is {} deep, more than the GPU's traversal takes ({})", mesh.source,
                            out.depth, kFlatBvhMaxDepth));
  return out;
}

}  // namespace prt
