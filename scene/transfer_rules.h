// The validators' rules in the pieces the file reader applies before it
// holds a whole transfer (private to prt::scene). transfer_problem (prt/transfer.h,
// prt/wavelet_transfer.h) is these rules applied to a whole transfer: the
// reader checks the header values as soon as it has read them, each array's
// size before reading it, and finally calls transfer_problem.
#pragma once

#include <prt/names.h>
#include <prt/transfer.h>
#include <prt/wavelet_transfer.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <string>

namespace prt::detail {

// The scalar values of an SH transfer, wide enough for anything a file holds.
struct HeaderValues {
  std::int64_t bands, channels, mode, bounces, samples;
  glm::vec3 albedo;
  std::uint64_t vertices;
  std::uint64_t stored;  // vertices with a row in the coefficients; the rest are analytic
  bool glossy = false;   // holds glossy transfer matrices
  std::int64_t glossy_rows = 0;  // their rows: 0 all (bands^2), kDirectionalRows for a directional lightmap's
};
// Those of `t`; its stored vertices are counted over its slots when they are
// one per vertex, and are all of its vertices otherwise.
HeaderValues header_of(const Transfer& t);
// What is wrong with the values, or "".
std::string header_problem(const HeaderValues& h);

// The arrays of a Transfer, numbered as their file sections (docs/FORMAT.md).
enum class TransferArray : std::uint32_t {
  Coeffs = 1, Direct = 2, AO = 3, BentNormals = 4, BounceEnergy = 5, Glossy = 7
};
inline constexpr EnumName<TransferArray> kTransferArrayNames[] = {
    {TransferArray::Coeffs, "coefficients"},   {TransferArray::Direct, "direct"},
    {TransferArray::AO, "ambient occlusion"},  {TransferArray::BentNormals, "bent normals"},
    {TransferArray::BounceEnergy, "bounce energy"},  {TransferArray::Glossy, "glossy matrices"},
};
constexpr const char* array_name(TransferArray a) { return enum_name(kTransferArrayNames, a).data(); }
// What is wrong with array `a` holding `count` scalars (bent normals: 3 per
// vertex) in a transfer of valid values `h`, or "". Every array but the
// coefficients may also be absent (not checked here); the glossy matrices
// are there exactly when h.glossy.
std::string array_problem(TransferArray a, std::uint64_t count, const HeaderValues& h);

// What is wrong with a subsurface record (TransferHeader::subsurface), or
// "": a material check_subsurface_material refuses ("the material: ..."), a
// length scale that is not finite and > 0. transfer_problem adds that a
// translucent transfer has 3 channels and no glossy matrices.
std::string subsurface_record_problem(const SubsurfaceRecord& r);

// transfer_problem(t) for the part of a compressed transfer that is not
// compressed (CompressedTransfer::transfer): everything but the stored rows,
// which must be empty (coefficients, direct part, glossy matrices).
std::string transfer_problem_without_rows(const Transfer& t);

// What is wrong with the scalar values of a wavelet transfer, or "".
std::string wavelet_header_problem(std::int64_t cube_res, double threshold, const glm::vec3& albedo,
                                   std::uint64_t vertices);

}  // namespace prt::detail
