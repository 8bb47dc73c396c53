// prt/transfer_io.h - transfer files: writing, reading with full validation,
// checking a transfer against the mesh it is used with.
//
// The file format (little-endian header, typed sections, XXH3-64 checksum)
// is specified in docs/FORMAT.md; the in-memory layout it stores is that of
// prt::Transfer (prt/transfer.h).
#pragma once

#include <prt/mesh.h>
#include <prt/transfer.h>

#include <cstdint>
#include <string>
#include <vector>

namespace prt {

// The one version this prt writes and reads (docs/FORMAT.md).
inline constexpr std::uint32_t kTransferFormatVersion = 1;

// Writes `t` to `path` through write_atomically: a failure (or the process
// being killed) leaves any existing file untouched and no temporary behind.
// Throws prt::Error naming the file if `t` is inconsistent (array sizes that
// do not match bands/channels/vertices, NaN or infinite values: such a file
// could not be read back) or the write fails.
void write_transfer(const std::string& path, const Transfer& t);

// Reads a transfer file. Validates everything before returning: signature,
// version, size (truncation), checksum, header values, section table, and
// that every value is finite. Throws prt::Error "PATH: problem" otherwise.
Transfer read_transfer(const std::string& path);

// Throws prt::Error unless `t` was computed for `mesh` (same vertex count and
// Mesh::hash()); `transfer_path` names the transfer in the message.
void check_matches(const Transfer& t, const Mesh& mesh, const std::string& transfer_path);

// A multi-line human-readable summary (bands, channels, mode, bounces,
// samples, albedo, vertices, mesh hash, sections and sizes, bytes per vertex,
// ambient-occlusion range). Ends with a newline.
std::string describe_transfer(const Transfer& t);

// ---- what a file holds (prt info, tests) ------------------------------------
struct TransferSection {
  std::uint32_t kind = 0;           // docs/FORMAT.md: 1 coefficients ... 5 bounce energy
  const char* name = "";            // "coefficients", "direct", "ambient occlusion", ...
  std::uint32_t element_bytes = 0;  // 4 (f32) or 8 (f64)
  std::uint64_t count = 0;          // elements (scalars)
  std::uint64_t bytes = 0;          // count * element_bytes, without padding
  bool per_vertex = false;          // true: bytes / vertices bytes per vertex
};

// The sections write_transfer stores for `t`, in file order (empty arrays
// other than the coefficients are left out).
std::vector<TransferSection> transfer_sections(const Transfer& t);
// Bytes per vertex over all per-vertex sections.
std::uint64_t transfer_bytes_per_vertex(const Transfer& t);
// Exact size in bytes of the file write_transfer writes for `t`.
std::uint64_t transfer_file_size(const Transfer& t);

}  // namespace prt
