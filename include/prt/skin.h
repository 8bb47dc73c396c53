// prt/skin.h - glTF 2.0 skins and their animations: a pose of a skinned mesh
// for local deformable PRT (prt/zh_transfer.h, docs/LDPRT.md), on the CPU.
//
// A skinned glTF is precomputed as load_mesh reads it (its rest pose);
// load_skin reads the same file's skin (JOINTS_0, WEIGHTS_0, the joints and
// their animations) in load_mesh's vertex order, joint_matrices gives the
// joints' matrices at a time, and skin_mesh poses the rest mesh with them
// (linear blend skinning). skin_mesh is the CPU reference that the GPU
// skinning must match (the same blended matrix, the same normal rule).
//
// The skinned mesh's node transform: glTF ignores it (the joints place the
// mesh), while load_mesh applies every node's transform, that one's too
// (Assimp flattens the node tree). joint_matrices keeps load_mesh's frame:
// it returns W G_j B_j W^-1 (W the skinned node's world transform, G_j the
// joint's world transform, B_j its inverse bind matrix), so the posed mesh
// is the glTF's own pose placed by W as load_mesh placed the rest, and the
// bind pose (G_j = B_j^-1) gives load_mesh's mesh back exactly, whatever W
// is. With W the identity (models/tube-skinned.gltf) that is plain glTF
// skinning.
#pragma once

#include <prt/mesh.h>

#include <glm/gtc/quaternion.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstddef>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace prt {

// A node of the skeleton: a joint, or a node above one (whose transform
// moves the joints below it).
struct SkinNode {
  std::string name;
  int parent = -1;  // index into Skin::nodes; -1: a root of the file's node tree
  // The rest (unanimated) local transform T R S...
  glm::vec3 translation{0.0f};
  glm::quat rotation{1.0f, 0.0f, 0.0f, 0.0f};  // unit (glm's constructor order: w, x, y, z)
  glm::vec3 scale{1.0f};
  // ... or the file's matrix instead (glTF: such a node is never animated).
  std::optional<glm::mat4> matrix;
  glm::mat4 inverse_bind{1.0f};  // joints only (the skin's inverseBindMatrices; identity when it has none)
};

// One animated property of one node: keyframes and how to interpolate them.
struct SkinChannel {
  enum class Path { Translation, Rotation, Scale };
  // Linear: lerp, slerp (shortest arc) for rotations; Step: the key at or
  // before the time; CubicSpline: glTF's Hermite spline (a rotation's result
  // normalised). Before the first key the first value, after the last the last.
  enum class Interpolation { Linear, Step, CubicSpline };
  int node = 0;  // index into Skin::nodes
  Path path = Path::Rotation;
  Interpolation interpolation = Interpolation::Linear;
  std::vector<float> times;  // seconds, finite, strictly increasing, at least one
  // Per key: (x, y, z, 0), or a rotation's quaternion (x, y, z, w) as glTF
  // stores it. CubicSpline: three per key, in-tangent, value, out-tangent.
  std::vector<glm::vec4> values;
};

struct SkinAnimation {
  std::string name;
  std::vector<SkinChannel> channels;  // those that move the skeleton (others in the file are left out)
  double duration = 0;                // seconds: the last key of any channel of the file's animation
};

struct Skin {
  // Per vertex of load_mesh's mesh: four joints (indices below joint_count)
  // and their weights, >= 0, summing to 1 (normalised on load).
  std::vector<glm::uvec4> vertex_joints;  // JOINTS_0
  std::vector<glm::vec4> vertex_weights;  // WEIGHTS_0
  // [0, joint_count): the skin's joints, joint j at nodes[j]; then the other
  // nodes above them. Every parent index is of this list.
  std::vector<SkinNode> nodes;
  std::size_t joint_count = 0;
  glm::mat4 mesh_transform{1.0f};         // W: the skinned node's world transform at rest (what load_mesh applied)
  std::vector<SkinAnimation> animations;  // the file's, in its order
  std::string source;                     // the file

  std::size_t vertex_count() const { return vertex_joints.size(); }
};

// Reads the skin of the glTF 2.0 / GLB file `path`, whose load_mesh is
// `mesh` (its per-vertex data in mesh's vertex order). The file is checked
// as load_mesh checks it (bounded memory, every count and index against the
// bytes there) before it is read. Throws prt::Error naming the file when:
// it is not glTF; its scene has no mesh, more than one mesh node, or an
// unskinned one; it has several skins; the skinned mesh lacks JOINTS_0 or
// WEIGHTS_0, has JOINTS_1 (more than four joints a vertex), points, lines or
// sparse accessors; a joint index is out of range, a weight negative or not
// finite, a vertex's weights all zero; a joint is listed twice; a matrix,
// transform or key is not finite, a rotation not a quaternion, key times
// not increasing; an animation uses an interpolation glTF does not define;
// or `mesh` does not match the file (another vertex count, or positions that
// are not the file's in load_mesh's order: a --weld mesh, another file).
Skin load_skin(const std::string& path, const Mesh& mesh);

// The joints' matrices at `time_seconds` of animation `animation` (time
// wraps modulo the animation's duration; negative times too), one per joint
// in the skin's order, M_j = W G_j B_j W^-1 (see the top of this file).
// `animation` < 0, or a skin without animations: the rest pose (every node
// at its rest transform). Throws prt::Error for a non-finite time or an
// animation the file does not have.
std::vector<glm::mat4> joint_matrices(const Skin& skin, double time_seconds, int animation = 0);

// `rest` (load_mesh's mesh of the skin's file) posed by linear blend
// skinning: per vertex M = sum_k w_k M_{j_k}, the position M p, the normal
// the cofactor of M's 3x3 part (det(M) M^-T, the normal rule of prt/deform.h)
// times n, normalised; a zero normal (or one the blend collapses) stays
// zero. Computed in double, stored in float. The same vertices, triangles
// and colours. The CPU reference for the GPU skinning. Throws prt::Error
// when rest's vertex count or the matrix count is not the skin's.
Mesh skin_mesh(const Mesh& rest, const Skin& skin, std::span<const glm::mat4> joint_matrices);

}  // namespace prt
