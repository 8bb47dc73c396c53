#include "ray_scene.h"

#include <prt/error.h>
#include <prt/precompute.h>
#include <prt/transfer.h>

#include <fmt/format.h>

#include <embree3/rtcore.h>
#include <pmmintrin.h>
#include <xmmintrin.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>
#include <string>

namespace prt::detail {

namespace {

thread_local std::string embree_error;

void on_embree_error(void*, RTCError code, const char* str) {
  embree_error = fmt::format("Embree error {}{}{}", int(code), str ? ": " : "", str ? str : "");
}

RTCScene scene_of(void* s) { return static_cast<RTCScene>(s); }

}  // namespace

void enable_ftz_daz() {
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
}

void check_common_options(const glm::vec3& albedo, bool vertex_colors, int threads, double offset, const Mesh& mesh) {
  // The limits every transfer's albedo keeps (transfer_problem checks them too).
  for (int c = 0; c < 3; ++c)
    if (!albedo_in_range(glm::vec3(albedo[c])))
      throw Error(fmt::format("--albedo must be in [{}, {}] per channel (energy conservation), got {:f}", kMinAlbedo,
                              kMaxAlbedo, double(albedo[c])));
  if (vertex_colors && mesh.colors.empty())
    throw Error(mesh.source + ": --vertex-colors given but the mesh has no vertex colours");
  if (threads < 0 || threads > kMaxThreads)
    throw Error(fmt::format("--threads must be between 0 (every core) and {}, got {}", kMaxThreads, threads));
  check_ray_offset(offset, mesh, "--offset");
}

double max_ray_offset(const Mesh& mesh) { return std::max(0.1 * mesh.diagonal(), default_ray_offset(mesh)); }

void check_ray_offset(double offset, const Mesh& mesh, const char* option) {
  if (!(offset >= 0.0) || !std::isfinite(offset))
    throw Error(fmt::format("{} must be a finite number > 0 (0: the default), got {}", option, offset));
  if (offset > max_ray_offset(mesh))
    throw Error(fmt::format("{} {:g} is too large for {}: at most a tenth of its bounding-box diagonal ({:g}) (the "
                            "default is 1e-4 x the diagonal, {:g})",
                            option, offset, mesh.source, max_ray_offset(mesh), default_ray_offset(mesh)));
}

double default_ray_offset(const Mesh& mesh) {
  // Relative to the model's size, and never below the float spacing of its
  // coordinates (a small model far from the origin).
  const glm::vec3 lo = mesh.bounds_min(), hi = mesh.bounds_max();
  const double magnitude = std::max({std::abs(lo.x), std::abs(lo.y), std::abs(lo.z), std::abs(hi.x),
                                     std::abs(hi.y), std::abs(hi.z)});
  return std::max({1e-4 * mesh.diagonal(), 64.0 * FLT_EPSILON * magnitude, 1e-30});
}

RayScene::RayScene(const Mesh& mesh, bool robust, bool all_hits) : mesh_(mesh), all_hits_(all_hits) {
  // make_mesh refuses larger coordinates; a Mesh built by hand is checked here.
  const glm::vec3 lo = mesh.bounds_min(), hi = mesh.bounds_max();
  const double extent = std::max({std::abs(lo.x), std::abs(lo.y), std::abs(lo.z), std::abs(hi.x), std::abs(hi.y),
                                  std::abs(hi.z)});
  if (!(extent <= kMaxCoordinate))
    throw Error(fmt::format("{}: a coordinate of {:g} is beyond prt's limit of {:g}, where float ray tracing breaks "
                            "down; scale the mesh down",
                            mesh.source, extent, kMaxCoordinate));
  const double diagonal = mesh.diagonal();
  if (diagonal > 0 && diagonal < kMinRayDiagonal)
    throw Error(fmt::format("{}: its bounding-box diagonal {:g} is below {:g}, where float ray tracing loses every hit; "
                            "scale the mesh up",
                            mesh.source, diagonal, kMinRayDiagonal));
  RTCDevice device = rtcNewDevice(nullptr);
  if (!device) throw Error(fmt::format("Embree: cannot create a device (error {})", int(rtcGetDeviceError(nullptr))));
  device_ = device;
  rtcSetDeviceErrorFunction(device, on_embree_error, nullptr);
  embree_error.clear();
  RTCScene scene = rtcNewScene(device);
  scene_ = scene;
  rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
  rtcSetSceneFlags(scene, RTCSceneFlags((robust ? RTC_SCENE_FLAG_ROBUST : 0) |
                                        (all_hits ? RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION : 0)));
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  // Embree's own buffers (rtcSetNewGeometryBuffer) are padded as it needs.
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), mesh.positions.size()));
  auto* t = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                           3 * sizeof(unsigned), mesh.triangles.size()));
  if (!v || !t) {
    rtcReleaseGeometry(geom);
    release();
    throw Error("Embree: cannot allocate geometry buffers: " + embree_error);
  }
  for (std::size_t i = 0; i < mesh.positions.size(); ++i) {
    v[3 * i] = mesh.positions[i].x;
    v[3 * i + 1] = mesh.positions[i].y;
    v[3 * i + 2] = mesh.positions[i].z;
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    t[3 * i] = mesh.triangles[i].x;
    t[3 * i + 1] = mesh.triangles[i].y;
    t[3 * i + 2] = mesh.triangles[i].z;
  }
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  if (!embree_error.empty()) {
    const std::string why = embree_error;
    release();
    throw Error("Embree: cannot build the scene: " + why);
  }
}

RayScene::~RayScene() { release(); }

void RayScene::release() {
  if (scene_) rtcReleaseScene(scene_of(scene_));
  if (device_) rtcReleaseDevice(static_cast<RTCDevice>(device_));
  scene_ = device_ = nullptr;
}

namespace {
// An 8-wide packet from one origin: lanes >= count are invalid.
void fill_packet(const glm::vec3& o, const glm::vec3* dirs, int count, float tnear, int* valid, RTCRay8& ray) {
  for (int i = 0; i < 8; ++i) {
    valid[i] = i < count ? -1 : 0;
    const glm::vec3 d = i < count ? dirs[i] : glm::vec3(0, 0, 1);
    ray.org_x[i] = o.x;
    ray.org_y[i] = o.y;
    ray.org_z[i] = o.z;
    ray.dir_x[i] = d.x;
    ray.dir_y[i] = d.y;
    ray.dir_z[i] = d.z;
    ray.tnear[i] = tnear;
    ray.tfar[i] = std::numeric_limits<float>::infinity();
    ray.time[i] = 0.0f;
    ray.mask[i] = ~0u;
    ray.id[i] = unsigned(i);
    ray.flags[i] = 0;
  }
}

// One ray.
RTCRay single_ray(const glm::vec3& o, const glm::vec3& d, float tnear) {
  RTCRay ray;
  ray.org_x = o.x;
  ray.org_y = o.y;
  ray.org_z = o.z;
  ray.dir_x = d.x;
  ray.dir_y = d.y;
  ray.dir_z = d.z;
  ray.tnear = tnear;
  ray.tfar = std::numeric_limits<float>::infinity();
  ray.time = 0.0f;
  ray.mask = ~0u;
  ray.id = 0;
  ray.flags = 0;
  return ray;
}
}  // namespace

std::uint32_t RayScene::occluded8(const glm::vec3& o, const glm::vec3* dirs, int count, float tnear) const {
  PRT_CHECK(count >= 0 && count <= 8);
  alignas(32) int valid[8];
  alignas(32) RTCRay8 ray;
  fill_packet(o, dirs, count, tnear, valid, ray);
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcOccluded8(valid, scene_of(scene_), &ctx, &ray);
  std::uint32_t bits = 0;
  for (int i = 0; i < count; ++i)
    if (ray.tfar[i] < 0.0f) bits |= 1u << i;  // Embree sets tfar = -inf on occlusion
  return bits;
}

bool front_facing(const Mesh& m, std::uint32_t tri, const glm::vec3& dir) {
  const glm::uvec3 t = m.triangles[tri];
  const glm::vec3 n = glm::cross(m.positions[t.y] - m.positions[t.x], m.positions[t.z] - m.positions[t.x]);
  return glm::dot(n, dir) < 0.0f;
}

void RayScene::intersect8(const glm::vec3& o, const glm::vec3* dirs, int count, float tnear, Hit* hits) const {
  PRT_CHECK(count >= 0 && count <= 8);
  alignas(32) int valid[8];
  alignas(32) RTCRayHit8 rh;
  fill_packet(o, dirs, count, tnear, valid, rh.ray);
  for (int i = 0; i < 8; ++i) {
    rh.hit.geomID[i] = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0][i] = RTC_INVALID_GEOMETRY_ID;
  }
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcIntersect8(valid, scene_of(scene_), &ctx, &rh);
  for (int i = 0; i < count; ++i) {
    Hit& h = hits[i];
    if (rh.hit.geomID[i] == RTC_INVALID_GEOMETRY_ID) {
      h = Hit{};
      continue;
    }
    h.triangle = rh.hit.primID[i];
    h.u = rh.hit.u[i];
    h.v = rh.hit.v[i];
    h.t = rh.ray.tfar[i];
    h.front = front_facing(mesh_, h.triangle, dirs[i]);
  }
}

namespace {
// intersect_all's context: Embree passes the RTCIntersectContext to the
// filter, which finds the rest of the struct behind it.
struct AllHits {
  RTCIntersectContext ctx;
  const Mesh* mesh;
  glm::vec3 dir;
  std::vector<Hit>* hits;
};

// Records the hit and rejects it, so that the traversal goes on to the next.
void collect_hit(const RTCFilterFunctionNArguments* args) {
  const auto* all = reinterpret_cast<const AllHits*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] == 0) continue;
    Hit h;
    h.triangle = RTCHitN_primID(args->hit, args->N, i);
    h.u = RTCHitN_u(args->hit, args->N, i);
    h.v = RTCHitN_v(args->hit, args->N, i);
    h.t = RTCRayN_tfar(args->ray, args->N, i);
    h.front = front_facing(*all->mesh, h.triangle, all->dir);
    all->hits->push_back(h);
    args->valid[i] = 0;
  }
}
}  // namespace

void RayScene::intersect_all(const glm::vec3& o, const glm::vec3& d, float tnear, float tfar,
                             std::vector<Hit>& hits) const {
  if (!all_hits_) throw Error("RayScene::intersect_all: the scene was not built with all_hits");
  hits.clear();
  RTCRayHit rh;
  rh.ray = single_ray(o, d, tnear);
  rh.ray.tfar = tfar;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  AllHits all{{}, &mesh_, d, &hits};
  rtcInitIntersectContext(&all.ctx);
  all.ctx.filter = collect_hit;
  rtcIntersect1(scene_of(scene_), &all.ctx, &rh);
  // Embree may report a triangle more than once (its filter's contract): keep each once.
  std::sort(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.triangle < b.triangle; });
  hits.erase(std::unique(hits.begin(), hits.end(), [](const Hit& a, const Hit& b) { return a.triangle == b.triangle; }),
             hits.end());
}

Hit RayScene::intersect1(const glm::vec3& o, const glm::vec3& d, float tnear) const {
  RTCRayHit rh;
  rh.ray = single_ray(o, d, tnear);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcIntersect1(scene_of(scene_), &ctx, &rh);
  Hit h;
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return h;
  h.triangle = rh.hit.primID;
  h.u = rh.hit.u;
  h.v = rh.hit.v;
  h.t = rh.ray.tfar;
  h.front = front_facing(mesh_, h.triangle, d);
  return h;
}

namespace {

// The point of triangle abc nearest p (Ericson, Real-Time Collision
// Detection, 5.1.5), in double.
glm::dvec3 closest_on_triangle(const glm::dvec3& p, const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c) {
  const glm::dvec3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = glm::dot(ab, ap), d2 = glm::dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const glm::dvec3 bp = p - b;
  const double d3 = glm::dot(ab, bp), d4 = glm::dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const glm::dvec3 cp = p - c;
  const double d5 = glm::dot(ab, cp), d6 = glm::dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

struct ClosestQuery {
  const Mesh* mesh;
  glm::dvec3 p;
  double best2;
  std::uint32_t triangle = ~0u;
  glm::dvec3 point{0.0};
};

bool closest_callback(RTCPointQueryFunctionArguments* args) {
  auto* q = static_cast<ClosestQuery*>(args->userPtr);
  const glm::uvec3& t = q->mesh->triangles[args->primID];
  const glm::dvec3 c = closest_on_triangle(q->p, glm::dvec3(q->mesh->positions[t.x]), glm::dvec3(q->mesh->positions[t.y]),
                                           glm::dvec3(q->mesh->positions[t.z]));
  const glm::dvec3 d = c - q->p;
  const double d2 = glm::dot(d, d);
  if (d2 >= q->best2) return false;
  q->best2 = d2;
  q->triangle = args->primID;
  q->point = c;
  args->query->radius = float(std::sqrt(d2));
  return true;
}

}  // namespace

std::uint32_t RayScene::closest_point(const glm::vec3& p, float radius, glm::dvec3& point) const {
  RTCPointQuery query;
  query.x = p.x;
  query.y = p.y;
  query.z = p.z;
  query.time = 0.0f;
  query.radius = radius;
  RTCPointQueryContext context;
  rtcInitPointQueryContext(&context);
  ClosestQuery q{&mesh_, glm::dvec3(p), double(radius) * double(radius)};
  rtcPointQuery(scene_of(scene_), &query, &context, closest_callback, &q);
  point = q.point;
  return q.triangle;
}

bool RayScene::occluded1(const glm::vec3& o, const glm::vec3& d, float tnear, float tfar) const {
  RTCRay ray = single_ray(o, d, tnear);
  ray.tfar = tfar;
  RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  rtcOccluded1(scene_of(scene_), &ctx, &ray);
  return ray.tfar < 0.0f;
}

namespace {

// ---- a portable, seeded direction set ---------------------------------------

// splitmix64: the standard's distributions are implementation-defined, so
// prt draws its own bits to stay bit-reproducible across standard libraries.
struct SplitMix64 {
  std::uint64_t s;
  std::uint64_t next() {
    std::uint64_t z = (s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
  }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }
};

// Uniform random rotation from three uniforms (Shoemake, Graphics Gems III).
glm::dmat3 random_rotation(SplitMix64& rng) {
  const double u1 = rng.uniform(), u2 = 2 * M_PI * rng.uniform(), u3 = 2 * M_PI * rng.uniform();
  const double a = std::sqrt(1 - u1), b = std::sqrt(u1);
  const double x = a * std::sin(u2), y = a * std::cos(u2), z = b * std::sin(u3), w = b * std::cos(u3);
  glm::dmat3 R;  // from the unit quaternion (x, y, z, w); glm: R[col][row]
  R[0] = {1 - 2 * (y * y + z * z), 2 * (x * y + z * w), 2 * (x * z - y * w)};
  R[1] = {2 * (x * y - z * w), 1 - 2 * (x * x + z * z), 2 * (y * z + x * w)};
  R[2] = {2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)};
  return R;
}

}  // namespace

// M directions of a spherical Fibonacci set (equal area), turned by a
// seeded random rotation; each stands for 4 pi / M steradians.
std::vector<glm::vec3> direction_set(int M, std::uint64_t seed) {
  SplitMix64 rng{seed};
  const glm::dmat3 R = random_rotation(rng);
  const double golden = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<glm::vec3> d(M);
  for (int i = 0; i < M; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / M, r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double phi = 2.0 * M_PI * std::fmod(i / golden, 1.0);
    d[i] = glm::vec3(R * glm::dvec3(r * std::cos(phi), r * std::sin(phi), z));
  }
  return d;
}


}  // namespace prt::detail
