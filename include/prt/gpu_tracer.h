// prt/gpu_tracer.h - occlusion jobs (prt/point_tracer.h) traced in OpenGL
// 4.5 compute shaders over a flat BVH built on the CPU (prt::build_flat_bvh
// in prt/precompute.h; docs/PRECOMPUTE.md "On the GPU").
//
// trace()'s shader (shaders/occlusion.comp.glsl) mirrors flat_bvh_occluded:
// the same node order, slab test and Moller-Trumbore test in float (marked
// `precise`, so that no multiply-add is fused), and sums each point's rays
// in double in direction order, as compute_transfer does on the CPU.
// trace_hits()'s (shaders/hits.comp.glsl) mirrors flat_bvh_closest the same
// way (its entry distances, push order, tie rules). Where the GL
// implementation divides in float as the CPU does, correctly rounded
// (llvmpipe does; GLSL allows 2.5 ulp), every sum and every hit equals the
// CPU's bit for bit (tests/test_gpu_tracer.cpp: measured on llvmpipe, not
// one differs).
//
// Threads: the tracer owns a headless EGL context of its own (the display
// egl_context picks: Mesa's surfaceless platform, else the first EGL device,
// else the default display). trace() makes that context current on the
// calling thread for the call and then restores whatever context the thread
// had current before; calls are serialised by a mutex inside the tracer, so
// any thread may call trace() or trace_hits(), one at a time. trace_hits()
// calls `consume` on the calling thread with the tracer's context current
// and its mutex held: `consume` must not call the tracer (it would wait for
// itself) nor use OpenGL. Destroy the tracer on a thread where its context is
// not current elsewhere (neither call leaves it current).
//
// Memory (GPU): the BVH's nodes (32 bytes each) and corners (48 bytes per
// triangle) for the tracer's lifetime (and on the CPU its triangle ids, 4
// bytes per triangle); per trace() or trace_hits() call the directions (16
// bytes each) and, for trace(), the basis (4 M nc bytes); per chunk of
// points their positions and normals (32 bytes per point) and, for trace(),
// their sums (8 (nc + 5) + 4 bytes per point), for trace_hits() their hits
// (16 M bytes per point, and as much again on the CPU to read them back),
// allocated once at the chunk's size and reused. Each of these arrays must
// fit GL_MAX_SHADER_STORAGE_BLOCK_SIZE (llvmpipe: 128 MiB):
// make_gl_point_tracer, trace() and trace_hits() throw prt::Error naming the
// array, its bytes and the limit otherwise (the chunk shrinks to fit before
// that: down to one point, whose 16 M bytes of hits must fit).
//
// Work: trace(): one shader invocation per point (work groups of 64; 1 on
// llvmpipe), each tracing its point's rays above the horizon in direction
// order and owning its row of sums (no atomics). Points go in chunks of
// about 2^20 rays (2^21 / M points, counting half the directions above the
// horizon, a multiple of 64), one dispatch each with glFinish after it, so
// that a dispatch stays well under a second even on llvmpipe; progress is
// called after each chunk. trace_hits(): one invocation per ray slot (point,
// direction), a slot below the horizon writing a miss; chunks of about 2^20
// slots (2^20 / M points, counting all M slots, about half of them traced:
// 16 MiB of hits), dispatched in 2-D where the slots' work groups exceed
// GL_MAX_COMPUTE_WORK_GROUP_COUNT in x, glFinish after each; the leaf-order
// triangles read back are mapped to the mesh's on the CPU and `consume` is
// called after each chunk, in point order. A job of no points calls
// `consume` zero times.
//
// llvmpipe's loop limit: llvmpipe ends a shader invocation's loops, without
// a word, once they have run 65535 iterations in all. trace() there counts
// its steps and, past a budget, pauses a point before its next ray and
// dispatches the chunk again until every point is done (the same sums in
// the same order); every shader stops a single ray's walk well before the
// limit and throws prt::Error("... loop limit ...") rather than answer from
// a cut walk (a degenerate mesh: tens of thousands of triangles' boxes on
// one ray). Other drivers have no such limit.
#pragma once

#include <prt/point_tracer.h>

#include <memory>

// In prt::runtime (the library; the namespace is prt, as for prt/render.h).
namespace prt {

// A tracer of `bvh` (copied to the GPU; `bvh` may go after the call).
// Throws prt::NoGlContext("no OpenGL 4.5 context: ...") when no OpenGL 4.5
// core context can be made (as prt::Renderer does), prt::Error when the
// shader does not build or the BVH exceeds GL_MAX_SHADER_STORAGE_BLOCK_SIZE.
std::unique_ptr<PointTracer> make_gl_point_tracer(const FlatBvh& bvh);

}  // namespace prt
