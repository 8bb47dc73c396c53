// prt/dynamic_ao.h - object-space dynamic ambient occlusion (Bunnell,
// "Dynamic Ambient Occlusion and Indirect Lighting", GPU Gems 2, chapter 14,
// 2005): an approximate ambient occlusion of a mesh in any pose, from its
// vertices alone, without rays. Local deformable PRT (prt/zh_transfer.h,
// docs/LDPRT.md) keeps each vertex's transfer in its own frame and so cannot
// follow distant occluders (a bent tube's far half shading the inside of the
// bend); this restores that global occlusion on a posed mesh.
//
// What it approximates: the ambient occlusion (accessibility) of each vertex,
// A = (1/pi) integral V(w) max(n.w, 0) dw (1: nothing in the way, 0: fully
// covered), as Transfer::ao holds it (prt/transfer.h) - roughly. Every vertex
// is an element: a disc at its position, with its normal and an area of one
// third of the areas of its triangles. Element e shadows receiver r by
//
//   S(e, r) = (1 - 1 / sqrt(1 + A_e / (pi d^2))) * clamp(n_e . v) * clamp(4 n_r . v),
//
// v the unit vector from the receiver to the emitter, d their distance,
// clamp(x) = min(max(x, 0), 1) (the chapter's ElementShadow; HLSL saturate).
// The first factor is the solid angle of a disc of area A_e seen face on at
// distance d, over 2 pi. clamp(4 n_r . v): only what is in front of the
// receiver shadows it; the factor 4 is the chapter's (a small disc's exact
// weight in the cosine-weighted hemisphere is 2 n_r . v times the first
// factor: the chapter's is half that near the normal, twice it near the
// horizon, the same at 60 degrees). clamp(n_e . v) > 0 when the emitter faces
// *away* from the receiver: an element casts shadow from its back face
// ("Light is emitted and reflected from the front-facing side. Light is
// transmitted and shadows are cast from the back."). On a closed surface
// every line of sight through an occluder crosses exactly one back face, so
// the occluder counts once. An open sheet (a single-sided wall, a floor)
// therefore shadows only what lies behind it: a receiver that sees its front
// is not shadowed by it (the floor under a ball does not darken the ball's
// underside); model such geometry closed (with thickness, or as two
// coincident sheets facing both ways) where its shadow matters. Coincident
// elements (d = 0) have no direction between them and do not shadow each
// other; no element shadows itself.
//
// Passes (Bunnell's correction of double shadowing): the first pass sums
// the shadows, A_r = 1 - sum_e S(e, r), clamped to [0, 1]: a point behind
// two occluders, one behind the other, is shadowed twice. Each further pass
// weighs every emitter by its own accessibility from the pass before,
// A_r = 1 - sum_e S(e, r) A_e (clamped): an emitter that is itself in shadow
// casts less (what hides it also hides the receiver). Pass 2 is lighter than
// pass 1 where pass 1 double-counted; passes alternate about the answer
// (pass 3 darker again), converging slowly; two by default.
//
// How close: the approximation is rough. It knows no visibility between
// elements but what the passes give, and the disc's solid angle and the
// factor 4 are approximations. Against traced AO (tests/test_dynamic_ao.cpp,
// two passes): the floor under a ball off by 0.031 on average (correlation
// 0.998), the floor of a box with two-sided walls by 0.040 (0.978; its
// centre 0.47 where the exact value is 0.55), the bundled tube bent 90
// degrees by 0.038 (0.89); single vertices by up to a quarter (a third on
// the tube bent 180 degrees).
//
// The hierarchy: the elements are the leaves of a bounding-volume hierarchy
// (split at the median of the longest axis; at most 4 elements a leaf, summed
// one by one once the leaf is reached). Each inner node is also an aggregate
// disc: the sum of its elements' areas, their area-weighted mean position,
// and their area-weighted mean normal, normalised. A node whose receiver is
// farther from its position than `far` times its radius (the radius of a
// sphere about that position holding every element's disc) is taken as that
// one disc, with the area-weighted mean of its elements' accessibilities
// after the first pass; a nearer node is opened. A node whose normals diverge
// (the area-weighted mean of its unit normals shorter than
// kMinNormalCoherence; a closed object, or most of one, has a mean normal
// near zero) is always opened. A node lying wholly behind the receiver's
// tangent plane is skipped (every one of its elements has n_r . v <= 0:
// exact). far = infinity (or any far whose square overflows) sums every pair
// exactly; at far = 4 the hierarchy is off that by 0.002 to 0.005 on
// average and 0.016 at most on the bundled tube bent (90, 180 degrees) or
// twisted (180) (a little lighter: one disc of the sum shadows less than its
// parts).
//
// Cost: building the hierarchy O(V log V) (a linear median split a level);
// each pass, per receiver, the nodes it opens or takes whole, about
// (far^2 x a few) per doubling of distance on a surface: O(far^2 log V)
// instead of the V of every pair (at far = 4, 500 to 1,300 nodes and leaf
// elements a receiver on meshes of 2k to 100k vertices). Two passes over a
// 100k-vertex mesh take about a second on one core, half that on two.
// Parallel over receivers only (TBB), each receiver's sum in a fixed order
// in double: the same bits for any thread count.
#pragma once

#include <prt/mesh.h>

#include <vector>

namespace prt {

// Below this length of the area-weighted mean of a node's unit normals (1 for
// a flat cluster) its normals are taken to diverge and the node is never one
// disc. One disc of the cluster's whole area stands for elements that,
// curved, cover less: a spherical cap seen along its axis covers (mean normal
// length) of its area, so 0.8 (a cap of 53 degrees half-angle) bounds that
// excess to a quarter. Measured against the exact sum
// (tests/test_dynamic_ao.cpp): 0.5 (a hemisphere) leaves twice the error on a
// twisted tube, for 10-20% fewer nodes visited.
inline constexpr double kMinNormalCoherence = 0.8;

struct DynamicAoOptions {
  int passes = 2;     // 1: the plain sum; 2 and more: each weighing emitters by the pass before (at least 1)
  // A cluster of discs whose distance from the receiver is more than `far`
  // times its radius is taken as one disc (the hierarchy above); at least 1
  // (nearer, a cluster would hold the receiver); infinity: every pair exactly.
  double far = 4.0;
  int threads = 0;    // 0: all cores
};

// Every vertex's accessibility in [0, 1] (1: unoccluded), in vertex order;
// 1 for a vertex with a zero normal (which also shadows nothing). Throws
// prt::Error for passes < 1, far < 1 or NaN, threads < 0, or normals not one
// per vertex.
std::vector<float> dynamic_ao(const Mesh& mesh, const DynamicAoOptions& o = {});

}  // namespace prt
