// bench/ldprt_frame.cpp - prt_ldprt_frame: the frame of a deforming mesh
// (local deformable PRT, docs/LDPRT.md) against the static diffuse PRT frame
// of the same mesh at the same bands, in one process on one context.
//
//   prt_ldprt_frame MESH [--frames N] [--size S] [--lobes K] [--bands n] [--channels C] [--deform bend:ANGLE]
//                        [--tangent uv|edge]
//
// --tangent uv (the default) reads the mesh's texture coordinates, so its
// vertex frames take the UV tangent where it has them (two neighbours posed
// per vertex); edge: the edge rule (one).
// Transfers are synthetic (random; the cost does not depend on the values).
// Each frame turns the lighting (SH rotation on the CPU, uploaded) and draws
// (background + mesh, glFinish, no read-back); the deforming mesh's frame
// also animates the bend (0 to the whole angle and back over the frames) and
// its pass poses, frames and relights every vertex on the GPU. A third kind
// of frame gives the same pose as arrays deformed on the CPU each frame
// (deform_mesh + upload: what a pose from elsewhere costs). The kinds are
// interleaved frame by frame (the machine's drift hits them alike) and the
// medians compared: the target is the deforming frame within 2x of
// the static one (K = 4, n = 5, 100k vertices, llvmpipe).
#include <prt/deform.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/zh_transfer.h>

#include "synthetic_transfer.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <numbers>
#include <random>
#include <string>
#include <vector>

namespace {

prt::ZhTransfer synthetic_zh(const prt::Mesh& m, int lobes, int bands, int channels) {
  prt::ZhTransfer z;
  z.bands = bands;
  z.lobes = lobes;
  z.channels = channels;
  z.albedo = glm::vec3(0.8f);
  z.vertices = m.vertex_count();
  z.mesh_hash = m.hash();
  z.topology_hash = prt::topology_hash(m);
  z.tangents = prt::vertex_frames(m).rules;  // UV tangents where the mesh was read with its UVs
  std::mt19937 rng(1);
  std::normal_distribution<float> g;
  std::uniform_real_distribution<float> u(-0.1f, 0.3f);
  z.axes.resize(z.vertices * z.axes_stride());
  for (std::size_t i = 0; i < z.axes.size(); i += 3) {
    glm::vec3 a(g(rng), g(rng), std::abs(g(rng)) + 0.5f);
    a = glm::normalize(a);
    z.axes[i] = a.x, z.axes[i + 1] = a.y, z.axes[i + 2] = a.z;
  }
  z.coeffs.resize(z.vertices * z.coeffs_stride());
  for (float& c : z.coeffs) c = u(rng);
  return z;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::strcmp(argv[1], "--help") == 0) {
    std::fprintf(stderr,
                 "usage: %s MESH [--frames N] [--size S] [--lobes K] [--bands n] [--channels C] "
                 "[--deform bend:ANGLE] [--tangent uv|edge]\n",
                 argv[0]);
    return 2;
  }
  int frames = 60, size = 512, lobes = 4, bands = 5, channels = 1;
  std::string deform_text = "bend:90", frame_rule = "uv";
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--frames") frames = std::atoi(v.c_str());
    else if (k == "--size") size = std::atoi(v.c_str());
    else if (k == "--lobes") lobes = std::atoi(v.c_str());
    else if (k == "--bands") bands = std::atoi(v.c_str());
    else if (k == "--channels") channels = std::atoi(v.c_str());
    else if (k == "--deform") deform_text = v;
    else if (k == "--tangent") frame_rule = v;
    else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  try {
    prt::MeshOptions mo;
    mo.uvs = frame_rule == "uv";  // the UV tangent's rule reads two neighbours a vertex, the edge rule's one
    const prt::Mesh mesh = prt::load_mesh(argv[1], mo);
    const prt::Deform deform = prt::parse_deform(deform_text);
    const prt::EnvMap env = prt::load_envmap(PRT_SOURCE_DIR "/envmaps/forest.exr");
    const std::vector<glm::dvec3> light = prt::project(env, bands);
    std::vector<glm::dvec3> turned(light.size());
    prt::Renderer r;
    r.set_environment(env);
    const prt::Transfer sh = prt::bench::synthetic_transfer(mesh, bands, channels);
    const prt::ZhTransfer zh = synthetic_zh(mesh, lobes, bands, channels);
    const prt::Camera cam = prt::framing_camera(mesh);
    using clock = std::chrono::steady_clock;
    std::vector<double> t_static, t_gpu, t_cpu;
    prt::sh::Rotation rot(bands, glm::dmat3(1.0));
    // One renderer holds one mesh at a time, and uploading a mesh each frame
    // would time the upload: each kind runs a block of frames in turn (its
    // upload and a warm-up frame untimed), the blocks interleaved.
    const int block = 5;
    for (int first = 0; first < frames; first += block) {
      for (int kind = 0; kind < 3; ++kind) {
        if (kind == 0) {
          r.set_mesh(mesh, sh);
        } else {
          r.set_mesh(mesh, zh);
        }
        r.set_lighting(light);
        r.draw_only(cam, size, size);  // warm: programs, buffers
        for (int f = first; f < std::min(frames, first + block); ++f) {
          const double phase = double(f) / frames;
          const auto t0 = clock::now();
          rot.set(prt::sh::rotation_axis_angle({0, 1, 0}, 2 * std::numbers::pi * phase));
          rot.apply(light, turned);
          r.set_lighting(turned);
          const double amount = 0.5 * (1 - std::cos(2 * std::numbers::pi * phase));
          if (kind == 1) r.set_pose(deform, amount);
          if (kind == 2) {
            const prt::Mesh posed = prt::deform_mesh(mesh, deform, amount);
            r.set_pose(posed.positions, posed.normals);
          }
          r.draw_only(cam, size, size);
          const double ms = std::chrono::duration<double, std::milli>(clock::now() - t0).count();
          (kind == 0 ? t_static : kind == 1 ? t_gpu : t_cpu).push_back(ms);
        }
      }
    }
    const double s = median(t_static), g = median(t_gpu), c = median(t_cpu);
    std::printf("device: %s\nmesh: %s, %zu vertices, %zu triangles; %dx%d; %d frames each (median)\n",
                r.device().c_str(), argv[1], mesh.vertex_count(), mesh.triangles.size(), size, size, frames);
    std::printf("static diffuse PRT, %d bands, %d channel(s):             %8.2f ms\n", bands, channels, s);
    std::printf("deforming (%s on the GPU), %d lobes x %d bands, %s tangents:  %8.2f ms  (%.2fx the static frame)\n",
                deform_text.c_str(), lobes, bands, frame_rule.c_str(), g, g / s);
    std::printf("deforming (pose deformed on the CPU, uploaded):        %8.2f ms  (%.2fx)\n", c, c / s);
    return 0;
  } catch (const prt::Error& e) {
    std::fprintf(stderr, "prt_ldprt_frame: %s\n", e.what());
    return 1;
  }
}
