// prt/gpu_tracer.h - occlusion jobs (prt/point_tracer.h) traced in OpenGL
// 4.5 compute shaders over a flat BVH built on the CPU (prt::build_flat_bvh
// in prt/precompute.h; docs/PRECOMPUTE.md "On the GPU").
//
// The shader (shaders/occlusion.comp.glsl) mirrors flat_bvh_occluded: the
// same node order, slab test and Moller-Trumbore test in float (marked
// `precise`, so that no multiply-add is fused), and sums each point's rays
// in double in direction order, as compute_transfer does on the CPU. Where
// the GL implementation divides in float as the CPU does, correctly rounded
// (llvmpipe does; GLSL allows 2.5 ulp), every sum equals the CPU's bit for
// bit (tests/test_gpu_tracer.cpp: measured on llvmpipe, not one differs).
//
// Threads: the tracer owns a headless EGL context of its own (the display
// egl_context picks: Mesa's surfaceless platform, else the first EGL device,
// else the default display). trace() makes that context current on the
// calling thread for the call and then restores whatever context the thread
// had current before; calls are serialised by a mutex inside the tracer, so
// any thread may call trace(), one at a time. Destroy the tracer on a thread
// where its context is not current elsewhere (trace() never leaves it current).
//
// Memory (GPU): the BVH's nodes (32 bytes each) and corners (48 bytes per
// triangle) for the tracer's lifetime; per trace() call the directions (16
// bytes each) and the basis (4 M nc bytes); per chunk of points their
// positions and normals (32 bytes per point) and their sums (8 (nc + 5) + 4
// bytes per point), allocated once at the chunk's size and reused. Each of
// these arrays must fit GL_MAX_SHADER_STORAGE_BLOCK_SIZE (llvmpipe: 128 MiB):
// make_gl_point_tracer and trace() throw prt::Error naming the array, its
// bytes and the limit otherwise (the chunk shrinks to fit before that).
//
// Work: one shader invocation per point (work groups of 64), each tracing its
// point's rays above the horizon in direction order and owning its row of
// sums (no atomics). Points go in chunks of about 2^20 rays (2^21 / M points,
// a multiple of 64), one dispatch each with glFinish after it, so that a
// dispatch stays well under a second even on llvmpipe; progress is called
// after each chunk.
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
