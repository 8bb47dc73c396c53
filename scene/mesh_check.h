// Private to prt::scene: the structure checks load_mesh runs on a mesh file
// before Assimp reads it (scene/mesh_check.cpp, scene/mesh_check_gltf.cpp).
//
// Assimp trusts the counts, lengths and indices a file declares: it allocates
// what a header claims, reads past the end of short data, spins on a PLY
// header without end_header, asserts on an OFF file with fewer lines than it
// declares, and silently clamps or drops bad indices. Each check here reads
// the file front to back in bounded memory (a block and one line at a time;
// a glTF's JSON and the index data it checks are the exception: they are
// read whole, in proportion to the file), compares every declared count and
// length with the bytes that are really there before anything is allocated,
// parses every number and index the way the format defines them, and throws
// prt::Error naming the file, the line (text) or byte offset (binary) and
// what is wrong. A file that passes is one Assimp reads as declared.
#pragma once

#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace prt::detail {

// The mesh formats prt reads, told by the file's extension.
enum class MeshFormat { Obj, Ply, Off, Stl, Gltf, Glb };

// Throws prt::Error naming `path` unless its extension (any case) is .obj,
// .ply, .off, .stl, .gltf or .glb.
MeshFormat mesh_format(const std::string& path);

// How deep a glTF node hierarchy may nest (a root is at depth 0): Assimp
// and the scene reader walk it recursively. Real files nest a few dozen.
inline constexpr std::uint32_t kMaxNodeDepth = 256;

// The structure check of `format` for the file at `path` of `size` bytes.
void check_mesh_file(const std::string& path, MeshFormat format, std::uint64_t size);

void check_off(const std::string& path, std::uint64_t size);
void check_ply(const std::string& path, std::uint64_t size);
void check_obj(const std::string& path, std::uint64_t size);
void check_stl(const std::string& path, std::uint64_t size);
void check_gltf(const std::string& path, std::uint64_t size, bool binary);

// A relative URI reference's path with its percent escapes decoded (RFC
// 3986: "buffer%20data.bin" names "buffer data.bin"); false when a '%' is
// not followed by two hex digits or encodes a NUL byte.
bool percent_decode(std::string_view uri, std::string& out);

// Reads a file front to back through one block-sized buffer: text lines of
// bounded length, and raw bytes. Messages name the file and the line.
class FileScanner {
 public:
  FileScanner(const std::string& path, std::uint64_t size);

  // The next line, without its end ("\n" or "\r\n"); false at the end of the
  // file. Throws when a line is longer than `max_line` bytes or holds a NUL
  // or another control character (a tab is fine): not a text file.
  bool line(std::string_view& out, std::size_t max_line);
  std::uint64_t line_number() const { return line_no_; }  // of the line last returned, from 1
  std::uint64_t offset() const { return consumed_; }      // bytes consumed so far
  std::uint64_t remaining() const { return size_ > consumed_ ? size_ - consumed_ : 0; }

  // The next n bytes (n <= 64 KiB), or null when fewer remain (then nothing is consumed).
  const unsigned char* bytes(std::size_t n);
  // Skips n bytes; false (and at the end) when fewer remain.
  bool skip(std::uint64_t n);

  // "PATH: line N: what".
  [[noreturn]] void fail_line(const std::string& what) const;
  [[noreturn]] void fail(const std::string& what) const;  // "PATH: what"
  const std::string& path() const { return path_; }

 private:
  bool fill(std::size_t want);  // at least `want` bytes buffered, unless the file ends first

  std::string path_;
  std::uint64_t size_;
  std::ifstream in_;
  std::vector<char> buf_;
  std::size_t begin_ = 0, end_ = 0;  // buffered, unconsumed bytes
  std::uint64_t consumed_ = 0, line_no_ = 0;
  bool eof_ = false;
};

// Tokens separated by spaces and tabs.
std::vector<std::string_view> split_tokens(std::string_view line);

// Number syntax shared by the text formats (what their readers parse fully):
// a decimal real ("-1", "2.", ".5", "1e-7"; also nan and inf, which mesh
// validation then refuses with the vertex), and whole numbers.
bool is_real(std::string_view token);
bool parse_uint(std::string_view token, std::uint64_t& value);  // digits only
bool parse_int(std::string_view token, std::int64_t& value);    // optional sign, digits

// A token for a message: at most 40 characters, quoted.
std::string quote_token(std::string_view token);

}  // namespace prt::detail
