// prt/deform.h - procedural deformations of a mesh (a pose for local
// deformable PRT: prt/zh_transfer.h, docs/LDPRT.md).
//
// Both act along the mesh's y extent [y0, y1] (Y is up, docs/CONVENTIONS.md),
// s = (y - y0) / (y1 - y0), about the line through the bounding box's centre
// in x and z:
//  - bend:ANGLE bends the y axis into a circular arc of ANGLE degrees in the
//    xy-plane, towards +x for a positive angle (Barr, "Global and Local
//    Deformations of Solid Primitives", SIGGRAPH 1984): lengths along the
//    centre line are kept, the bottom (y0) stays put;
//  - twist:ANGLE turns each slice about the y axis by s * ANGLE degrees
//    (counter-clockwise seen from +y).
// Normals are carried by the deformation's cofactor matrix det(J) J^-T (the
// exact normal of a smooth surface, with the triangles' winding), so a mesh
// with authored normals keeps them; a zero normal stays zero.
#pragma once

#include <prt/mesh.h>

#include <string>
#include <string_view>

namespace prt {

struct Deform {
  enum class Kind { None, Bend, Twist };
  Kind kind = Kind::None;
  double degrees = 0;
};

// "bend:ANGLE" or "twist:ANGLE" (degrees, finite, |ANGLE| <= 720); throws
// prt::Error naming the text otherwise.
Deform parse_deform(std::string_view text);
std::string deform_name(const Deform& d);  // "bend:45"

// `rest` deformed by d at `amount` (0: the rest pose, 1: the whole angle):
// the same vertices, triangles and colours, new positions and normals.
Mesh deform_mesh(const Mesh& rest, const Deform& d, double amount = 1.0);

}  // namespace prt
