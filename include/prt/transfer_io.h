// prt/transfer_io.h - transfer files: writing, reading with full validation,
// checking a transfer against the mesh it is used with.
//
// The file format (little-endian header, typed sections, XXH3-64 checksum)
// is specified in docs/FORMAT.md; the in-memory layout it stores is that of
// prt::Transfer (prt/transfer.h) for the SH basis, prt::WaveletTransfer
// (prt/wavelet_transfer.h) for the wavelet basis and prt::ZhTransfer
// (prt/zh_transfer.h) for the zonal-harmonic (local deformable) one. The bases
// share the header, the section framing, the checksum and the atomic write;
// the header's basis field says which one a file holds.
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/probes.h>
#include <prt/transfer.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

// The newest version of SH transfer files (docs/FORMAT.md); this prt reads
// it and every earlier one (version 1: every vertex stored). Each file is
// written in the oldest version that holds it: transfers (lightmaps too)
// with a light-bounce operator 10 when it has probe rows, else 9 when it
// has cluster rows, else 8; transfers (compressed or not) with interpolated
// vertices or texels 7, compressed transfers with a choice record 6, other
// lightmaps 5, other compressed transfers 4, glossy ones 3, the others 2.
// Wavelet transfers are written as version kWaveletFormatVersion.
// Transfers (compressed or not, and lightmaps) that record a subsurface
// material are written as version 11, whatever else they hold, and
// directional lightmaps as version 12.
inline constexpr std::uint32_t kTransferFormatVersion = 12;
inline constexpr std::uint32_t kCompressedFormatVersion = 4;
inline constexpr std::uint32_t kLightmapFormatVersion = 5;
inline constexpr std::uint32_t kChosenCompressionFormatVersion = 6;  // kind 12: what its size was chosen for
// Kind 13: the 'interpolated vertices' mask (Transfer::interpolated, adaptive
// sample points), written only when some vertex is interpolated.
inline constexpr std::uint32_t kInterpolatedFormatVersion = 7;
// Kinds 14-19: the light-bounce operator (Transfer::light_bounce,
// prt/light_bounce.h), written only when a transfer (or lightmap) has one;
// compressed files never hold it.
inline constexpr std::uint32_t kLightBounceFormatVersion = 8;
// Kinds 20-22: the operator's cluster rows (LightBounce::cluster_offsets,
// cluster_source, cluster_weight; prt::link_clusters), written only with an
// operator that has them (cluster_offsets not empty), all three or none.
inline constexpr std::uint32_t kLightBounceClustersFormatVersion = 9;
// Kinds 23-27: the operator's probe rows (LightBounce::probes: the grid and
// bands, the box, offsets, sources, weights), written only with an operator
// that has them (probes.offsets not empty), all five or none.
inline constexpr std::uint32_t kLightBounceProbesFormatVersion = 10;
// Kind 28: the subsurface material (TransferHeader::subsurface, a translucent
// transfer's SubsurfaceRecord, prt/subsurface.h) as one UTF-8 JSON object,
// written only when a transfer (compressed or not, or a lightmap) has one.
inline constexpr std::uint32_t kSubsurfaceFormatVersion = 11;
// No new kind: a lightmap whose header has the glossy flag, its 'glossy
// matrices' section (kind 7) holding each stored texel's directional rows
// (Transfer::glossy_rows = kDirectionalRows, prt/lightmap_directional.h).
// Before 12 a lightmap was never glossy.
inline constexpr std::uint32_t kDirectionalFormatVersion = 12;
inline constexpr std::uint32_t kWaveletFormatVersion = 1;
// Zonal-harmonic (local deformable) transfers have their own version line.
inline constexpr std::uint32_t kZhFormatVersion = 2;  // 2: the tangent rules (sections 28, 29)
// So do probe volumes (basis 3, sections 32-42), since they joined the format.
inline constexpr std::uint32_t kProbeFormatVersion = 1;
// The version write_transfer writes for a transfer without interpolated
// vertices: 3 with glossy matrices, 2 otherwise (so that a prt reading
// version 2 reads every file it could).
inline std::uint32_t transfer_format_version(bool glossy) { return glossy ? 3u : 2u; }
// The version write_transfer writes for `t`: kSubsurfaceFormatVersion (11)
// with a subsurface record (t.subsurface), else
// kLightBounceProbesFormatVersion (10) with a light-bounce operator that has probe rows
// (!Transfer::light_bounce.probes.empty()), else
// kLightBounceClustersFormatVersion (9) with one that has cluster rows
// (!Transfer::light_bounce.cluster_offsets.empty()), else
// kLightBounceFormatVersion (8) with any other operator
// (!Transfer::light_bounce.empty()), else
// kInterpolatedFormatVersion (7) when some vertex is interpolated
// (Transfer::interpolated_vertices() > 0), else transfer_format_version(t.glossy).
std::uint32_t transfer_format_version(const Transfer& t);

// Writes `t` to `path` through write_atomically: a failure (or the process
// being killed) leaves any existing file untouched and no temporary behind.
// Throws prt::Error "PATH: cannot write this transfer: PROBLEM" before writing
// anything if `t` is inconsistent (transfer_problem, prt/transfer.h: such a
// file could not be read back), and naming the file if the write fails.
void write_transfer(const std::string& path, const Transfer& t);

// The subsurface record (kind 28, docs/FORMAT.md "Subsurface material") as
// the file stores it: one JSON object with the keys name, sigma_a, sigma_s
// (arrays of 3 numbers, 1/mm; sigma_s the reduced coefficient), eta and
// length_scale (mm per mesh unit), every double written so that it reads
// back bit for bit. Throws prt::Error when the name is not valid UTF-8. And
// back: parse_subsurface_record throws prt::Error naming the problem (not a
// JSON object, a key missing or of the wrong type, a material
// check_subsurface_material refuses, a length scale that is not finite and
// > 0); other keys are ignored.
std::string subsurface_record_json(const SubsurfaceRecord& r);
SubsurfaceRecord parse_subsurface_record(std::string_view json);
// "subsurface, marble: sigma_a 0.0021, 0.0041, 0.0071 /mm; sigma_s' 2.19,
// 2.62, 3 /mm; eta 1.5; 25 mm a unit" (no name: "subsurface: sigma_a ..."):
// prt info's material line.
std::string describe_subsurface_record(const SubsurfaceRecord& r);

// Reads a transfer file. Validates everything before returning: signature,
// version, size (truncation), checksum, header values, section table, and
// the data (transfer_problem). Throws prt::Error "PATH: problem" otherwise,
// and for a compressed file (read_compressed_transfer reads those).
Transfer read_transfer(const std::string& path);

// A multi-line human-readable summary (bands, channels, mode, bounces,
// samples, albedo, vertices, mesh hash, sections and sizes, bytes per vertex,
// ambient-occlusion range). Ends with a newline.
std::string describe_transfer(const Transfer& t);

// ---- what a file holds (prt info, tests) ------------------------------------
struct TransferSection {
  std::uint32_t kind = 0;           // docs/FORMAT.md: 1 coefficients ... 13 interpolated vertices, 14-27 light bounce,
                                    // 28 subsurface material
  const char* name = "";            // "coefficients", "direct", "ambient occlusion", ...
  std::uint32_t element_bytes = 0;  // 1 (u8) to 8 (f64, u64); 2 for the f16 light-bounce weights
  std::uint64_t count = 0;          // elements (scalars)
  std::uint64_t bytes = 0;          // count * element_bytes, without padding
  bool per_vertex = false;          // true: bytes / vertices bytes per vertex
  const char* type = "f32";         // element type: "f32", "f64", "u64", "u32", "i16", "u8", "u16" or "f16"
};

// The sections write_transfer stores for `t`, in file order (empty arrays
// other than the coefficients are left out).
std::vector<TransferSection> transfer_sections(const Transfer& t);
// Bytes per vertex over all per-vertex sections (the coefficients averaged
// over all vertices, analytic ones included).
std::uint64_t transfer_bytes_per_vertex(const Transfer& t);
// How many bytes smaller the file is than the same transfer with every
// vertex stored (the analytic vertices' rows, less the mask section).
std::uint64_t analytic_bytes_saved(const Transfer& t);
// Exact size in bytes of the file write_transfer writes for `t`.
std::uint64_t transfer_file_size(const Transfer& t);

// ---- compressed transfers (version 4, flag bit 2; docs/FORMAT.md "Compressed transfer") ----
// Writes `c` (prt/compressed_transfer.h) through write_atomically; throws
// prt::Error "PATH: cannot write this compressed transfer: PROBLEM" before
// writing anything if compressed_transfer_problem(c) finds it inconsistent,
// or if c.transfer has a light-bounce operator (compression does not keep
// one yet: the file would silently lose it).
// 16-bit weights are stored as their codes (weight_code), and read back as
// the same floats: the round trip is bit-exact.
void write_compressed_transfer(const std::string& path, const CompressedTransfer& c);
// Reads one with read_transfer's checks and compressed_transfer_problem's;
// throws prt::Error "PATH: problem", also for an uncompressed file.
CompressedTransfer read_compressed_transfer(const std::string& path);
// The sections write_compressed_transfer stores, in file order, and the
// file's exact size.
std::vector<TransferSection> transfer_sections(const CompressedTransfer& c);
// The version write_compressed_transfer writes for `c`: 11 with a
// subsurface record (c.transfer.subsurface: compression keeps it), else 7
// when some vertex is interpolated (c.transfer.interpolated: compression
// keeps the mask), else 6 with a choice record, 4 without.
std::uint32_t transfer_format_version(const CompressedTransfer& c);
std::uint64_t transfer_file_size(const CompressedTransfer& c);
// check_matches of its uncompressed part.
inline void check_matches(const CompressedTransfer& c, const Mesh& mesh, const std::string& transfer_path);
// describe_transfer of the uncompressed part, then per signal its clusters,
// vectors, weight and index widths, bytes and ratio to the rows it replaces.
std::string describe_transfer(const CompressedTransfer& c);

// Throws prt::Error unless `t` was computed for `mesh` (same vertex count and
// Mesh::hash(); the mesh has vertex colours when t's albedo is them; and when
// t has analytic vertices, the same shading_hash: those are shaded from the
// mesh's normals and colours); `transfer_path` names the transfer in the
// message. Every command that pairs a transfer with a mesh (relight, render,
// view) and the renderer call it, so they refuse alike.
void check_matches(const Transfer& t, const Mesh& mesh, const std::string& transfer_path);

inline void check_matches(const CompressedTransfer& c, const Mesh& mesh, const std::string& transfer_path) {
  check_matches(c.transfer, mesh, transfer_path);
}

// What a file holds: prt/transfer_file.h (read_transfer_file returns any
// kind; nothing else asks a file what it is).

// ---- wavelet transfers (basis 1; docs/FORMAT.md, "Wavelet transfer") -------------
// Writes `t` through write_atomically. Throws prt::Error naming the file,
// before writing anything, if transfer_problem(t) (prt/wavelet_transfer.h)
// finds it inconsistent: column offsets not monotone or not ending at the
// entry count, vertex indices out of range or unsorted within a column, array
// sizes, non-finite scales, albedo outside [0, 1], bad cube resolution or
// threshold.
void write_wavelet_transfer(const std::string& path, const WaveletTransfer& t);

// Reads a wavelet transfer file, validating signature, version, size,
// checksum, header, section table and every value as above;
// WaveletTransfer::vertex_kept is recomputed from the columns. Throws
// prt::Error "PATH: problem"; on an SH file the message says so and points to
// read_transfer / prt precompute --basis wavelet. read_transfer likewise
// refuses a wavelet file, naming the basis.
WaveletTransfer read_wavelet_transfer(const std::string& path);

// Throws prt::Error unless `t` was computed for `mesh` (same vertex count and
// Mesh::hash()); `what` (the transfer's path) names it in the message.
void check_matches(const WaveletTransfer& t, const Mesh& mesh, const std::string& what);

// One line (ending in a newline): cube resolution, threshold, quantisation,
// vertices, kept fraction, bytes per vertex, albedo, mesh hash, file size.
std::string describe_transfer(const WaveletTransfer& t);

// The sections write_wavelet_transfer stores for `t`, in file order, and the
// exact size of the file. Bytes per vertex: WaveletTransfer::bytes() / vertices.
std::vector<TransferSection> transfer_sections(const WaveletTransfer& t);
std::uint64_t transfer_file_size(const WaveletTransfer& t);

// ---- zonal-harmonic transfers (basis 2; docs/FORMAT.md, "Zonal-harmonic transfer") ----
// Local deformable PRT (prt/zh_transfer.h): per stored vertex, its lobes' axes in
// its rest frame and channels x lobes x bands coefficients; analytic vertices
// store nothing (an analytic-vertex mask, as the SH file's). Written as
// version kZhFormatVersion through write_atomically; throws prt::Error "PATH:
// cannot write this zonal-harmonic transfer: PROBLEM" before writing anything
// if zh_transfer_problem(t) finds it inconsistent. The round trip is
// bit-exact (slots come back empty when no vertex is analytic).
void write_zh_transfer(const std::string& path, const ZhTransfer& t);
// Reads one, validating signature, version, size, checksum, header, section
// table and every value (zh_transfer_problem). Throws prt::Error "PATH:
// problem"; on an SH or wavelet file the message says so and names their
// readers, as read_transfer and read_wavelet_transfer do on a ZH file.
ZhTransfer read_zh_transfer(const std::string& path);
// The sections write_zh_transfer stores for `t`, in file order, and the
// exact size of the file.
std::vector<TransferSection> transfer_sections(const ZhTransfer& t);
std::uint64_t transfer_file_size(const ZhTransfer& t);
// A multi-line summary (lobes, bands, channels, mode, bounces, samples,
// albedo, vertices and analytic ones, fit error, bytes per vertex, mesh and
// topology hashes, file size). Ends with a newline.
std::string describe_transfer(const ZhTransfer& t);
// Throws prt::Error unless `t` was computed for `mesh` as its rest pose (same
// vertex count and Mesh::hash(); vertex colours when t's albedo is them);
// `what` names the transfer. A deformed pose is checked by check_pose
// (prt/zh_transfer.h) instead: its positions, and so its hash, differ.
void check_matches(const ZhTransfer& t, const Mesh& mesh, const std::string& what);

// ---- lightmap transfers (version 5, flag bit 3; docs/FORMAT.md, "Lightmap transfer") ----
// An SH transfer whose rows are a lightmap's covered texels, with two more
// sections: the layout (width, height, UV set, scene hash) and the covered
// texels' indices; and, when some texel was interpolated from traced ones
// (Transfer::interpolated: prt precompute --lightmap --adaptive), the
// 'interpolated vertices' mask over the texels (version 7); and, computed
// with --light-bounce, the light-bounce operator over the texels (version
// 8; 9 when it has cluster rows, 10 when it has probe rows). Written
// through write_atomically; throws prt::Error "PATH: cannot write this
// lightmap: PROBLEM" (lightmap_problem; also for glossy matrices, which a
// lightmap file does not hold) before writing anything.
void write_lightmap_transfer(const std::string& path, const LightmapTransfer& t);
// The version write_lightmap_transfer writes for `t`:
// kSubsurfaceFormatVersion (11) with a subsurface record
// (t.transfer.subsurface), else kLightBounceProbesFormatVersion (10) with a light-bounce operator that has
// probe rows, kLightBounceClustersFormatVersion (9) with one that has
// cluster rows, kLightBounceFormatVersion (8) with any other (one row per
// covered texel), else kInterpolatedFormatVersion (7) when some texel is
// interpolated, else kLightmapFormatVersion (5).
std::uint32_t transfer_format_version(const LightmapTransfer& t);
// Reads one with read_transfer's checks plus the layout's (lightmap_problem);
// throws prt::Error "PATH: problem", also for a per-vertex file (and
// read_transfer refuses a lightmap, naming it).
LightmapTransfer read_lightmap_transfer(const std::string& path);
// A wavelet lightmap (prt precompute --lightmap --basis wavelet): a wavelet
// transfer file whose "vertices" are covered texels, with flag bit 3 and the
// layout and covered texels as sections 21 and 22 (docs/FORMAT.md).
void write_wavelet_lightmap(const std::string& path, const WaveletLightmap& t);
WaveletLightmap read_wavelet_lightmap(const std::string& path);
std::vector<TransferSection> transfer_sections(const LightmapTransfer& t);
std::uint64_t transfer_file_size(const LightmapTransfer& t);
std::vector<TransferSection> transfer_sections(const WaveletLightmap& t);
std::uint64_t transfer_file_size(const WaveletLightmap& t);
// The grid, each probe's state and position, then the stored probes'
// visibility, depth and bounce arrays (docs/FORMAT.md, "Probe volume").
std::vector<TransferSection> transfer_sections(const ProbeTransfer& t);
std::uint64_t transfer_file_size(const ProbeTransfer& t);
// Its grid, probe states, cube and sizes (prt info).
std::string describe_transfer(const ProbeTransfer& t);
// The atlas and texels, then describe_transfer of the wavelet rows.
std::string describe_transfer(const WaveletLightmap& t);
// The atlas, covered and analytic texels and bytes per covered texel, then
// describe_transfer of the rows.
std::string describe_transfer(const LightmapTransfer& t);

}  // namespace prt
