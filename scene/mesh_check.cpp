// Structure checks of mesh files before Assimp reads them: OFF, PLY, OBJ and
// STL here, glTF/GLB in mesh_check_gltf.cpp. See mesh_check.h; what each
// check refuses is listed in docs/HARD_CASES.md ("Malformed input").

#include "mesh_check.h"

#include <prt/error.h>
#include <prt/io.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>

namespace prt::detail {

namespace {

constexpr std::size_t kBlock = std::size_t(1) << 20;  // FileScanner's buffer
constexpr std::size_t kMaxBytes = std::size_t(1) << 16;  // the most FileScanner::bytes hands out at once
constexpr std::uint64_t kMaxCount = std::numeric_limits<std::uint32_t>::max();  // vertices, faces, elements

bool is_space(char c) { return c == ' ' || c == '\t'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

// The part of a line before a '#' comment.
std::string_view before_comment(std::string_view s) { return s.substr(0, s.find('#')); }

bool equals_lower(std::string_view s, std::string_view lower) {
  if (s.size() != lower.size()) return false;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(s[i])) != lower[i]) return false;
  return true;
}

// a * b + c, saturating (declared counts may be anything).
std::uint64_t mul_add(std::uint64_t a, std::uint64_t b, std::uint64_t c) {
  constexpr std::uint64_t max = std::numeric_limits<std::uint64_t>::max();
  if (b != 0 && a > (max - c) / b) return max;
  return a * b + c;
}

}  // namespace

// ---- shared pieces ----------------------------------------------------------------------

FileScanner::FileScanner(const std::string& path, std::uint64_t size)
    : path_(path), size_(size), in_(path, std::ios::binary), buf_(kBlock) {
  if (!in_) throw Error(path + ": cannot open: " + std::strerror(errno));
}

void FileScanner::fail_line(const std::string& what) const {
  throw Error(fmt::format("{}: line {}: {}", path_, line_no_, what));
}

void FileScanner::fail(const std::string& what) const { throw Error(path_ + ": " + what); }

bool FileScanner::fill(std::size_t want) {
  if (end_ - begin_ >= want) return true;
  if (begin_ > 0) {
    std::memmove(buf_.data(), buf_.data() + begin_, end_ - begin_);
    end_ -= begin_;
    begin_ = 0;
  }
  while (end_ < want && !eof_) {
    in_.read(buf_.data() + end_, static_cast<std::streamsize>(buf_.size() - end_));
    const std::streamsize got = in_.gcount();
    if (in_.bad()) fail(fmt::format("read error at byte {}: {}", consumed_ + (end_ - begin_), std::strerror(errno)));
    if (got > 0) end_ += static_cast<std::size_t>(got);
    if (!in_ || got <= 0) eof_ = true;
  }
  return end_ - begin_ >= want;
}

bool FileScanner::line(std::string_view& out, std::size_t max_line) {
  std::size_t scanned = 0, len = 0, take = 0;
  for (;;) {
    const char* b = buf_.data() + begin_;
    const std::size_t avail = end_ - begin_;
    if (const void* nl = std::memchr(b + scanned, '\n', avail - scanned)) {
      len = static_cast<std::size_t>(static_cast<const char*>(nl) - b);
      take = len + 1;
      break;
    }
    scanned = avail;
    if (avail > max_line + 1) {
      ++line_no_;
      fail_line(fmt::format("longer than {} characters (not a text file of this format?)", max_line));
    }
    if (!fill(avail + 1)) {  // the file ends
      if (avail == 0) return false;
      len = take = avail;  // the last line, without a line end
      break;
    }
  }
  ++line_no_;
  std::string_view s(buf_.data() + begin_, len);
  if (!s.empty() && s.back() == '\r') s.remove_suffix(1);
  if (s.size() > max_line)
    fail_line(fmt::format("longer than {} characters (not a text file of this format?)", max_line));
  for (char c : s) {
    const auto u = static_cast<unsigned char>(c);
    if ((u < 0x20 && c != '\t') || u == 0x7f)
      fail_line(fmt::format("holds the control character 0x{:02x} (not a text file of this format?)", u));
  }
  begin_ += take;
  consumed_ += take;
  out = s;
  return true;
}

const unsigned char* FileScanner::bytes(std::size_t n) {
  PRT_CHECK(n <= kMaxBytes);
  if (!fill(n)) return nullptr;
  const auto* p = reinterpret_cast<const unsigned char*>(buf_.data() + begin_);
  begin_ += n;
  consumed_ += n;
  return p;
}

bool FileScanner::skip(std::uint64_t n) {
  if (end_ - begin_ >= n) {
    begin_ += static_cast<std::size_t>(n);
    consumed_ += n;
    return true;
  }
  if (n > remaining()) return false;
  consumed_ += n;
  begin_ = end_ = 0;
  eof_ = false;
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(consumed_));
  if (!in_) fail(fmt::format("cannot seek to byte {}", consumed_));
  return true;
}

std::vector<std::string_view> split_tokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

bool is_real(std::string_view t) {
  std::size_t i = 0;
  const std::size_t n = t.size();
  if (i < n && (t[i] == '+' || t[i] == '-')) ++i;
  const std::string_view word = t.substr(i);
  if (equals_lower(word, "nan") || equals_lower(word, "inf") || equals_lower(word, "infinity")) return true;
  std::size_t digits = 0;
  while (i < n && std::isdigit(static_cast<unsigned char>(t[i]))) ++i, ++digits;
  if (i < n && t[i] == '.') {
    ++i;
    while (i < n && std::isdigit(static_cast<unsigned char>(t[i]))) ++i, ++digits;
  }
  if (digits == 0) return false;
  if (i < n && (t[i] == 'e' || t[i] == 'E')) {
    ++i;
    if (i < n && (t[i] == '+' || t[i] == '-')) ++i;
    std::size_t exp = 0;
    while (i < n && std::isdigit(static_cast<unsigned char>(t[i]))) ++i, ++exp;
    if (exp == 0) return false;
  }
  return i == n;
}

bool parse_uint(std::string_view t, std::uint64_t& value) {
  if (t.empty() || !std::isdigit(static_cast<unsigned char>(t[0]))) return false;
  const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
  return ec == std::errc() && p == t.data() + t.size();
}

bool parse_int(std::string_view t, std::int64_t& value) {
  if (!t.empty() && t[0] == '+') t.remove_prefix(1);
  if (t.empty() || (t[0] == '-' && (t.size() == 1 || !std::isdigit(static_cast<unsigned char>(t[1]))))) return false;
  if (t[0] != '-' && !std::isdigit(static_cast<unsigned char>(t[0]))) return false;
  const auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
  return ec == std::errc() && p == t.data() + t.size();
}

std::string quote_token(std::string_view token) {
  if (token.size() > 40) return fmt::format("'{}...'", token.substr(0, 40));
  return fmt::format("'{}'", token);
}

MeshFormat mesh_format(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  if (ext == ".obj") return MeshFormat::Obj;
  if (ext == ".ply") return MeshFormat::Ply;
  if (ext == ".off") return MeshFormat::Off;
  if (ext == ".stl") return MeshFormat::Stl;
  if (ext == ".gltf") return MeshFormat::Gltf;
  if (ext == ".glb") return MeshFormat::Glb;
  throw Error(fmt::format("{}: unknown mesh format '{}' (prt reads .obj, .ply, .off, .stl, .gltf and .glb)", path,
                          ext.empty() ? std::string("no extension") : ext));
}

void check_mesh_file(const std::string& path, MeshFormat format, std::uint64_t size) {
  switch (format) {
    case MeshFormat::Off: return check_off(path, size);
    case MeshFormat::Ply: return check_ply(path, size);
    case MeshFormat::Obj: return check_obj(path, size);
    case MeshFormat::Stl: return check_stl(path, size);
    case MeshFormat::Gltf: return check_gltf(path, size, false);
    case MeshFormat::Glb: return check_gltf(path, size, true);
  }
}

// ---- OFF ------------------------------------------------------------------------------------
//
// Read the way Assimp's OFF reader reads it: the header is tokens across
// lines and '#' comments; then one vertex per line, then one face per line
// (empty lines skipped; a comment may end a line). Vertices must hold
// exactly the values the header's letters say (C: four colour values, N:
// three normal values, ...), faces 1 to 9 whole-number indices in range.

void check_off(const std::string& path, std::uint64_t size) {
  constexpr std::size_t kHeaderLine = 1 << 16;
  constexpr std::size_t kBodyLine = 4000;  // Assimp's OFF reader copies each line into 4096 bytes
  FileScanner s(path, size);

  // The header's tokens, one at a time, and whether each ended its line.
  std::vector<std::string> pending;
  std::size_t next = 0;
  auto token = [&](const char* expected, bool& last_on_line) {
    while (next == pending.size()) {
      std::string_view line;
      if (!s.line(line, kHeaderLine))
        s.fail(fmt::format("the file ends in its header (expected {})", expected));
      pending.clear();
      next = 0;
      for (std::string_view t : split_tokens(before_comment(line))) pending.emplace_back(t);
    }
    last_on_line = next + 1 == pending.size();
    return pending[next++];
  };
  bool last = false;
  const std::string magic = token("OFF", last);
  std::string_view m = magic;
  bool texcoords = false, colors = false, normals = false, homogeneous = false, dimension = false;
  if (m.substr(0, 2) == "ST") texcoords = true, m.remove_prefix(2);
  if (m.substr(0, 1) == "C") colors = true, m.remove_prefix(1);
  if (m.substr(0, 1) == "N") normals = true, m.remove_prefix(1);
  if (m.substr(0, 1) == "4") homogeneous = true, m.remove_prefix(1);
  if (m.substr(0, 1) == "n") dimension = true, m.remove_prefix(1);
  if (m != "OFF")
    s.fail_line(fmt::format("not an OFF file: it starts with {}, not OFF (or COFF, NOFF, STOFF, 4OFF, nOFF ...)",
                            quote_token(magic)));
  std::uint64_t dims = 3;
  if (dimension) {
    const std::string d = token("the dimension", last);
    if (!parse_uint(d, dims) || dims < 1 || dims > 3)
      s.fail_line(fmt::format("the dimension {} is not 1, 2 or 3", quote_token(d)));
  }
  std::uint64_t counts[3] = {0, 0, 0};
  const char* names[3] = {"vertex count", "face count", "edge count"};
  for (int k = 0; k < 3; ++k) {
    const std::string t = token(names[k], last);
    if (!parse_uint(t, counts[k]))
      s.fail_line(fmt::format("expected the {} (a whole number), got {}", names[k], quote_token(t)));
  }
  if (!last)
    s.fail_line("the counts (vertices, faces, edges) must end their line; more follows them (a count missing?)");
  const std::uint64_t nv = counts[0], nf = counts[1];
  if (nv > kMaxCount || nf > kMaxCount)
    s.fail_line(fmt::format("declares {} vertices and {} faces; prt reads at most {} of each", nv, nf, kMaxCount));
  if (nv == 0 || nf == 0) return;  // Assimp refuses these itself ("no valid vertices", "no valid faces")

  // Before reading further: do the declared counts fit in what follows? A
  // vertex line takes at least two bytes per number, a face line four.
  // (Assimp's reader takes colours as four values, RGBA: with fewer it
  // fails at the line's end.)
  const std::uint64_t per_vertex = dims + (homogeneous ? 1 : 0) + (normals ? 3 : 0) + (colors ? 4 : 0) +
                                   (texcoords ? 2 : 0);
  const std::uint64_t need = mul_add(nf, 4, mul_add(nv, 2 * (per_vertex - (colors ? 4 : 0)), 0));
  if (need > s.remaining() + 1)
    s.fail(fmt::format("declares {} vertices and {} faces, which take at least {} bytes, but only {} bytes follow "
                       "its header",
                       nv, nf, need, s.remaining()));

  std::string_view line;
  auto blank_or_comment = [](std::string_view l) { return trim(before_comment(l)).empty(); };
  for (std::uint64_t v = 0; v < nv; ++v) {
    bool more = s.line(line, kBodyLine);
    // Before the first vertex, blank and comment lines belong to the header;
    // between vertices only empty lines are skipped.
    while (more && (v == 0 ? blank_or_comment(line) : line.empty())) more = s.line(line, kBodyLine);
    if (!more)
      s.fail(fmt::format("the file ends after {} of the {} vertices its header declares", v, nv));
    const auto tokens = split_tokens(before_comment(line));
    if (tokens.empty()) s.fail_line(fmt::format("expected vertex {}, found a blank or comment line", v));
    if (tokens.size() != per_vertex)
      s.fail_line(fmt::format("vertex {} has {} values, expected {}{}", v, tokens.size(), per_vertex,
                              tokens.size() > per_vertex ? " (does the header declare more vertices than the file has?)"
                              : colors                   ? " (a COFF colour is four values, RGBA)"
                                                         : ""));
    for (std::string_view t : tokens)
      if (!is_real(t)) s.fail_line(fmt::format("vertex {}: {} is not a number", v, quote_token(t)));
  }
  for (std::uint64_t f = 0; f < nf; ++f) {
    bool more = s.line(line, kBodyLine);
    while (more && line.empty()) more = s.line(line, kBodyLine);
    if (!more) s.fail(fmt::format("the file ends after {} of the {} faces its header declares", f, nf));
    // Assimp's reader skips such a line but loses a face for it.
    if (blank_or_comment(line))
      s.fail_line(fmt::format("a blank or comment line where face {} should be (the OFF reader loses a face for each)",
                              f));
    const auto tokens = split_tokens(before_comment(line));
    std::uint64_t k = 0;
    if (!parse_uint(tokens[0], k))
      s.fail_line(fmt::format("face {}: {} is not a vertex count (a whole number)", f, quote_token(tokens[0])));
    if (k == 0) s.fail_line(fmt::format("face {} has no vertices", f));
    if (k > 9) s.fail_line(fmt::format("face {} has {} vertices; the OFF reader takes faces of up to 9", f, k));
    if (tokens.size() < k + 1)
      s.fail_line(fmt::format("face {} has {} vertices but lists {}", f, k, tokens.size() - 1));
    for (std::uint64_t j = 1; j <= k; ++j) {
      std::int64_t index = 0;
      if (!parse_int(tokens[j], index))
        s.fail_line(fmt::format("face {} uses vertex {}, which is not a vertex index (a whole number)", f,
                                quote_token(tokens[j])));
      if (index < 0 || std::uint64_t(index) >= nv)
        s.fail_line(fmt::format("face {} uses vertex {}, out of range (the file has {} vertices)", f, index, nv));
    }
  }
}

// ---- PLY ------------------------------------------------------------------------------------

namespace {

enum class PlyType { Char, UChar, Short, UShort, Int, UInt, Float, Double };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float;       // the value type; for a list, its items'
  PlyType count_type = PlyType::UChar;  // lists only
  bool list = false;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> props;
  std::uint64_t line = 0;
};

std::optional<PlyType> ply_type(std::string_view t) {
  static constexpr std::array<std::pair<std::string_view, PlyType>, 16> names = {{
      {"char", PlyType::Char},     {"int8", PlyType::Char},      {"uchar", PlyType::UChar},
      {"uint8", PlyType::UChar},   {"short", PlyType::Short},    {"int16", PlyType::Short},
      {"ushort", PlyType::UShort}, {"uint16", PlyType::UShort},  {"int", PlyType::Int},
      {"int32", PlyType::Int},     {"uint", PlyType::UInt},      {"uint32", PlyType::UInt},
      {"float", PlyType::Float},   {"float32", PlyType::Float},  {"double", PlyType::Double},
      {"float64", PlyType::Double},
  }};
  for (const auto& [name, type] : names)
    if (t == name) return type;
  return std::nullopt;
}

std::size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::Char:
    case PlyType::UChar: return 1;
    case PlyType::Short:
    case PlyType::UShort: return 2;
    case PlyType::Int:
    case PlyType::UInt:
    case PlyType::Float: return 4;
    case PlyType::Double: return 8;
  }
  return 0;
}

bool ply_integer(PlyType t) { return t != PlyType::Float && t != PlyType::Double; }

const char* ply_name(PlyType t) {
  switch (t) {
    case PlyType::Char: return "char";
    case PlyType::UChar: return "uchar";
    case PlyType::Short: return "short";
    case PlyType::UShort: return "ushort";
    case PlyType::Int: return "int";
    case PlyType::UInt: return "uint";
    case PlyType::Float: return "float";
    case PlyType::Double: return "double";
  }
  return "?";
}

// The range of an integer type.
std::pair<std::int64_t, std::int64_t> ply_range(PlyType t) {
  switch (t) {
    case PlyType::Char: return {-128, 127};
    case PlyType::UChar: return {0, 255};
    case PlyType::Short: return {-32768, 32767};
    case PlyType::UShort: return {0, 65535};
    case PlyType::Int: return {std::numeric_limits<std::int32_t>::min(), std::numeric_limits<std::int32_t>::max()};
    default: return {0, std::numeric_limits<std::uint32_t>::max()};
  }
}

// An ASCII value of type t: its integer value (for integer types) or nullopt when malformed.
bool ply_ascii_value(std::string_view tok, PlyType t, std::int64_t& value) {
  if (!ply_integer(t)) return is_real(tok);
  const auto [lo, hi] = ply_range(t);
  if (lo == 0) {
    std::uint64_t u = 0;
    if (!parse_uint(tok, u) || u > std::uint64_t(hi)) return false;
    value = std::int64_t(u);
    return true;
  }
  return parse_int(tok, value) && value >= lo && value <= hi;
}

std::int64_t ply_binary_int(const unsigned char* p, PlyType t, bool big_endian) {
  unsigned char b[4] = {0, 0, 0, 0};
  const std::size_t n = ply_size(t);
  for (std::size_t i = 0; i < n; ++i) b[i] = big_endian ? p[n - 1 - i] : p[i];
  const std::uint32_t u = std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 |
                          std::uint32_t(b[3]) << 24;
  switch (t) {
    case PlyType::Char: return std::int8_t(u);
    case PlyType::UChar: return std::uint8_t(u);
    case PlyType::Short: return std::int16_t(u);
    case PlyType::UShort: return std::uint16_t(u);
    case PlyType::Int: return std::int32_t(u);
    default: return u;
  }
}

// Whether property p of element e lists vertex indices (faces and triangle strips).
bool is_index_list(const PlyElement& e, const PlyProperty& p) {
  return (e.name == "face" || e.name == "tristrips") && p.list &&
         (p.name == "vertex_indices" || p.name == "vertex_index");
}

constexpr std::size_t kPlyHeaderLine = 1 << 16;  // the longest header line read
constexpr std::size_t kPlyDataLine = 1 << 16;    // the longest ASCII data line read

// What a PLY header declares.
struct PlyHeader {
  bool ascii = false, big_endian = false;
  std::vector<PlyElement> elements;
};

// The header, from the "ply" line to end_header, each line checked.
PlyHeader read_ply_header(FileScanner& s) {
  std::string_view line;
  if (!s.line(line, kPlyHeaderLine) || !equals_lower(trim(line), "ply"))
    s.fail("not a PLY file (its first line is not 'ply')");
  if (!s.line(line, kPlyHeaderLine)) s.fail("the file ends in its header (expected 'format ...')");
  auto tokens = split_tokens(line);
  PlyHeader h;
  if (tokens.size() != 3 || tokens[0] != "format" || tokens[2] != "1.0" ||
      !(tokens[1] == "ascii" || tokens[1] == "binary_little_endian" || tokens[1] == "binary_big_endian"))
    s.fail_line(fmt::format("expected 'format ascii 1.0', 'format binary_little_endian 1.0' or 'format "
                            "binary_big_endian 1.0', got {}",
                            quote_token(line)));
  h.ascii = tokens[1] == "ascii";
  h.big_endian = tokens[1] == "binary_big_endian";
  std::vector<PlyElement>& elements = h.elements;
  for (;;) {
    if (!s.line(line, kPlyHeaderLine)) s.fail("has no end_header: the file ends in its header");
    tokens = split_tokens(line);
    if (tokens.empty()) s.fail_line("a blank line in the header");
    const std::string_view key = tokens[0];
    if (key == "end_header") {
      if (tokens.size() != 1) s.fail_line("end_header followed by more on its line");
      break;
    }
    if (key == "comment") continue;
    if (key == "obj_info") {
      if (!elements.empty()) s.fail_line("obj_info among an element's properties (it goes before the elements)");
      continue;
    }
    if (key == "element") {
      std::uint64_t count = 0;
      if (tokens.size() != 3 || !parse_uint(tokens[2], count))
        s.fail_line(fmt::format("expected 'element NAME COUNT', got {}", quote_token(line)));
      if (count > kMaxCount) s.fail_line(fmt::format("element {} declares {} entries; prt reads at most {}", tokens[1],
                                                     count, kMaxCount));
      for (const PlyElement& e : elements)
        if (e.name == tokens[1]) s.fail_line(fmt::format("element {} declared twice", e.name));
      elements.push_back({std::string(tokens[1]), count, {}, s.line_number()});
      continue;
    }
    if (key == "property") {
      if (elements.empty()) s.fail_line("a property before any element");
      PlyProperty p;
      if (tokens.size() >= 2 && tokens[1] == "list") {
        if (tokens.size() != 5) s.fail_line(fmt::format("expected 'property list COUNT_TYPE TYPE NAME', got {}",
                                                        quote_token(line)));
        const auto ct = ply_type(tokens[2]), it = ply_type(tokens[3]);
        if (!ct || !it) s.fail_line(fmt::format("unknown property type {} (expected char, uchar, short, ushort, int, "
                                                "uint, float, double or int8 ... float64)",
                                                quote_token(!ct ? tokens[2] : tokens[3])));
        if (!ply_integer(*ct)) s.fail_line(fmt::format("a list's count type must be an integer type, not {}", tokens[2]));
        p.list = true;
        p.count_type = *ct;
        p.type = *it;
        p.name = tokens[4];
      } else {
        if (tokens.size() != 3) s.fail_line(fmt::format("expected 'property TYPE NAME', got {}", quote_token(line)));
        const auto t = ply_type(tokens[1]);
        if (!t) s.fail_line(fmt::format("unknown property type {} (expected char, uchar, short, ushort, int, uint, "
                                        "float, double or int8 ... float64)",
                                        quote_token(tokens[1])));
        p.type = *t;
        p.name = tokens[2];
      }
      PlyElement& e = elements.back();
      if (is_index_list(e, p) && !ply_integer(p.type))
        s.fail_line(fmt::format("{}'s {} must be a list of integers, not of {}", e.name, p.name, ply_name(p.type)));
      e.props.push_back(std::move(p));
      continue;
    }
    s.fail_line(fmt::format("unknown header line {} (expected element, property, comment or end_header)",
                            quote_token(line)));
  }
  return h;
}

// What the header declares: every element with entries has properties,
// faces and strips a vertex index list, a vertex element with x, y and z, and
// data that fits in the rest of the file. Returns the vertex count.
std::uint64_t check_ply_declared(FileScanner& s, const PlyHeader& h) {
  const std::vector<PlyElement>& elements = h.elements;
  const bool ascii = h.ascii;
  const PlyElement* vertex = nullptr;
  for (const PlyElement& e : elements) {
    if (e.count > 0 && e.props.empty())
      s.fail(fmt::format("element {} (line {}) declares {} entries but no properties", e.name, e.line, e.count));
    if (e.name == "vertex") vertex = &e;
    if (e.name == "face" || e.name == "tristrips") {
      const bool has = std::any_of(e.props.begin(), e.props.end(), [&](const PlyProperty& p) { return is_index_list(e, p); });
      if (!has) s.fail(fmt::format("element {} (line {}) has no vertex_indices list", e.name, e.line));
    }
  }
  if (!vertex) s.fail("has no vertex element");
  for (const char* axis : {"x", "y", "z"})
    if (std::none_of(vertex->props.begin(), vertex->props.end(),
                     [&](const PlyProperty& p) { return !p.list && p.name == axis; }))
      s.fail(fmt::format("element vertex (line {}) has no property {}", vertex->line, axis));
  const std::uint64_t nv = vertex->count;

  // Before reading the data: does what the header declares fit in the file?
  // Binary: every fixed-size property and every list's count; ASCII: at
  // least two characters (a digit and a separator) per value.
  std::uint64_t need = 0;
  for (const PlyElement& e : elements) {
    std::uint64_t per = 0;
    for (const PlyProperty& p : e.props) per += ascii ? 2 : ply_size(p.list ? p.count_type : p.type);
    need = mul_add(e.count, per, need);
  }
  if (need > s.remaining() + (ascii ? 1 : 0)) {
    std::string list;
    for (std::size_t k = 0; k < elements.size(); ++k)
      list += fmt::format("{}{} {}", k == 0 ? "" : k + 1 == elements.size() ? " and " : ", ", elements[k].count,
                          elements[k].name);
    s.fail(fmt::format("the header declares {} entries, which take at least {} bytes, but only {} bytes follow it",
                       list, need, s.remaining()));
  }
  return nv;
}

// The message for entry i of element e naming vertex `index`, out of range of
// the file's `nv`; whether an index is in range (a strip may hold -1, its restart).
std::string ply_index_error(const PlyElement& e, std::uint64_t i, std::int64_t index, std::uint64_t nv) {
  return fmt::format("{} {} uses vertex {}, out of range (the file has {} vertices)", e.name, i, index, nv);
}

bool ply_index_ok(const PlyElement& e, std::int64_t index, std::uint64_t nv) {
  return index < std::int64_t(nv) && index >= (e.name == "tristrips" ? -1 : 0);
}

// The ASCII data: one line per entry, every value of its property's type,
// indices naming vertices of the `nv` the file has.
void check_ply_ascii(FileScanner& s, const PlyHeader& h, std::uint64_t nv) {
  std::string_view line;
  std::vector<std::string_view> tokens;
  for (const PlyElement& e : h.elements) {
    for (std::uint64_t i = 0; i < e.count; ++i) {
      if (!s.line(line, kPlyDataLine))
        s.fail(fmt::format("the file ends after {} of the {} {} entries its header declares", i, e.count, e.name));
      tokens = split_tokens(line);
      if (tokens.empty()) s.fail_line(fmt::format("a blank line where {} {} should be", e.name, i));
      std::size_t pos = 0;
      const auto short_line = [&] {
        s.fail_line(fmt::format("{} {} has {} values, fewer than its properties take", e.name, i, tokens.size()));
      };
      for (const PlyProperty& p : e.props) {
        std::int64_t value = 0;
        if (!p.list) {
          if (pos >= tokens.size()) short_line();
          if (!ply_ascii_value(tokens[pos], p.type, value))
            s.fail_line(fmt::format("{} {}: {} {} is not a {}", e.name, i, p.name, quote_token(tokens[pos]),
                                    ply_name(p.type)));
          ++pos;
          continue;
        }
        if (pos >= tokens.size()) short_line();
        std::int64_t n = 0;
        if (!ply_ascii_value(tokens[pos], p.count_type, n) || n < 0)
          s.fail_line(fmt::format("{} {}: the count of {} {} is not a {} >= 0", e.name, i, p.name, quote_token(tokens[pos]),
                                  ply_name(p.count_type)));
        ++pos;
        if (n == 0 && is_index_list(e, p)) s.fail_line(fmt::format("{} {} has no vertices", e.name, i));
        if (tokens.size() - pos < std::uint64_t(n))
          s.fail_line(fmt::format("{} {}: {} has {} entries but lists {}", e.name, i, p.name, n, tokens.size() - pos));
        const bool indices = is_index_list(e, p);
        for (std::int64_t j = 0; j < n; ++j, ++pos) {
          if (!ply_ascii_value(tokens[pos], p.type, value))
            s.fail_line(fmt::format("{} {}: {} entry {} {} is not a {}", e.name, i, p.name, j, quote_token(tokens[pos]),
                                    ply_name(p.type)));
          if (indices && !ply_index_ok(e, value, nv)) s.fail_line(ply_index_error(e, i, value, nv));
        }
      }
      if (pos != tokens.size())
        s.fail_line(fmt::format("{} {} has {} values, more than its properties take ({}){}", e.name, i, tokens.size(),
                                pos,
                                e.name == "vertex" ? " (does the header declare more vertices than the file has?)"
                                                   : ""));
    }
  }
}

// The binary data (file size `size`): walk it, reading only the list counts
// and the indices.
void check_ply_binary(FileScanner& s, const PlyHeader& h, std::uint64_t nv, std::uint64_t size) {
  const bool big_endian = h.big_endian;
  const auto truncated = [&](const PlyElement& e, std::uint64_t i) {
    s.fail(fmt::format("truncated: the data ends in {} {} of the {} its header declares (at byte {} of {})", e.name, i,
                       e.count, s.offset(), size));
  };
  for (const PlyElement& e : h.elements) {
    const bool fixed = std::none_of(e.props.begin(), e.props.end(), [](const PlyProperty& p) { return p.list; });
    if (fixed) {
      std::uint64_t per = 0;
      for (const PlyProperty& p : e.props) per += ply_size(p.type);
      if (!s.skip(e.count * per)) truncated(e, s.remaining() / per);
      continue;
    }
    for (std::uint64_t i = 0; i < e.count; ++i) {
      for (const PlyProperty& p : e.props) {
        if (!p.list) {
          if (!s.skip(ply_size(p.type))) truncated(e, i);
          continue;
        }
        const unsigned char* c = s.bytes(ply_size(p.count_type));
        if (!c) truncated(e, i);
        const std::int64_t n = ply_binary_int(c, p.count_type, big_endian);
        if (n < 0) s.fail(fmt::format("{} {}: {} has a count of {} (byte {})", e.name, i, p.name, n, s.offset()));
        // Assimp's triangulation asserts on a face without indices (it takes the process down).
        if (n == 0 && is_index_list(e, p)) s.fail(fmt::format("{} {} has no vertices (byte {})", e.name, i, s.offset()));
        const std::size_t item = ply_size(p.type);
        if (std::uint64_t(n) * item > s.remaining()) truncated(e, i);
        if (!is_index_list(e, p)) {
          if (!s.skip(std::uint64_t(n) * item)) truncated(e, i);
          continue;
        }
        for (std::int64_t done = 0; done < n;) {
          const std::int64_t chunk = std::min<std::int64_t>(n - done, std::int64_t(kMaxBytes / item));
          const unsigned char* d = s.bytes(std::size_t(chunk) * item);
          if (!d) truncated(e, i);
          for (std::int64_t j = 0; j < chunk; ++j) {
            const std::int64_t index = ply_binary_int(d + j * item, p.type, big_endian);
            if (!ply_index_ok(e, index, nv))
              s.fail(fmt::format("{} (byte {})", ply_index_error(e, i, index, nv), s.offset()));
          }
          done += chunk;
        }
      }
    }
  }
}

}  // namespace

void check_ply(const std::string& path, std::uint64_t size) {
  FileScanner s(path, size);
  const PlyHeader h = read_ply_header(s);
  const std::uint64_t nv = check_ply_declared(s, h);
  if (h.ascii) {
    check_ply_ascii(s, h, nv);
    return;
  }
  check_ply_binary(s, h, nv, size);
}

// ---- OBJ ------------------------------------------------------------------------------------
//
// Line by line, a line ending in a backslash joined to the next (as Assimp joins
// them). Vertices must have 3, 4 (homogeneous) or 6 (with a colour) numbers:
// Assimp skips other vertex lines without a word, which shifts every index
// after them. Face, line and point references must be whole numbers, not 0,
// naming vertices, texture coordinates and normals that exist (a negative
// reference counts back from the last one defined so far); Assimp drops
// normals and texture coordinates whose index is out of range. A material
// library Assimp would open must be a regular file.

namespace {

// Refuses a non-regular file at `p` when something is there (Assimp opens it;
// a missing one it skips with a log message).
void check_referenced_file(const std::string& obj, std::uint64_t line, const std::string& p) {
  std::error_code ec;
  const auto st = std::filesystem::symlink_status(p, ec);
  if (ec || st.type() == std::filesystem::file_type::not_found) return;
  try {
    check_input_file(p, "a material library");
  } catch (const Error& e) {
    throw Error(fmt::format("{}: line {}: its material library {}", obj, line, e.what()));
  }
}

}  // namespace

void check_obj(const std::string& path, std::uint64_t size) {
  constexpr std::size_t kLine = std::size_t(1) << 19;
  FileScanner s(path, size);
  const std::string dir = std::filesystem::path(path).parent_path().string();
  const char* kinds[3] = {"vertex", "texture coordinate", "normal"};
  const char* plural[3] = {"vertices", "texture coordinates", "normals"};
  std::uint64_t count[3] = {0, 0, 0};  // v, vt, vn defined so far
  std::uint64_t max_ref[3] = {0, 0, 0}, max_line[3] = {0, 0, 0};  // the largest positive reference, and its line
  std::string joined;
  std::string_view piece;
  bool checked_fallback = false;
  while (s.line(piece, kLine)) {
    // Joined continuation lines.
    std::string_view line = piece;
    if (!piece.empty() && piece.back() == '\\') {
      joined.assign(piece.substr(0, piece.size() - 1));
      while (s.line(piece, kLine)) {
        const bool more = !piece.empty() && piece.back() == '\\';
        joined.append(more ? piece.substr(0, piece.size() - 1) : piece);
        if (joined.size() > kLine) s.fail_line(fmt::format("a continued line longer than {} characters", kLine));
        if (!more) break;
      }
      line = joined;
    }
    const auto tokens = split_tokens(before_comment(line));
    if (tokens.empty()) continue;
    const std::string_view key = tokens[0];
    const std::size_t n = tokens.size() - 1;
    auto numbers = [&](const char* what) {
      for (std::size_t k = 1; k < tokens.size(); ++k)
        if (!is_real(tokens[k])) s.fail_line(fmt::format("{}: {} is not a number", what, quote_token(tokens[k])));
    };
    if (key == "v") {
      if (n != 3 && n != 4 && n != 6)
        s.fail_line(fmt::format("vertex {} has {} numbers, expected 3 (x y z), 4 (x y z w) or 6 (x y z r g b)",
                                count[0] + 1, n));
      numbers("vertex");
      ++count[0];
    } else if (key == "vt") {
      if (n != 2 && n != 3) s.fail_line(fmt::format("texture coordinate {} has {} numbers, expected 2 or 3", count[1] + 1, n));
      numbers("texture coordinate");
      ++count[1];
    } else if (key == "vn") {
      if (n != 3) s.fail_line(fmt::format("normal {} has {} numbers, expected 3", count[2] + 1, n));
      numbers("normal");
      ++count[2];
    } else if (key == "f" || key == "l" || key == "p") {
      const char* what = key == "f" ? "face" : key == "l" ? "line" : "point";
      if (n == 0) s.fail_line(fmt::format("a {} without vertices", what));
      for (std::size_t k = 1; k < tokens.size(); ++k) {
        const std::string_view ref = tokens[k];
        // v, v/t, v//n, v/t/n
        std::string_view part[3];
        std::size_t parts = 0, start = 0;
        for (std::size_t i = 0; i <= ref.size(); ++i)
          if (i == ref.size() || ref[i] == '/') {
            if (parts == 3) s.fail_line(fmt::format("{} vertex {} has more than three parts", what, quote_token(ref)));
            part[parts++] = ref.substr(start, i - start);
            start = i + 1;
          }
        for (std::size_t j = 0; j < parts; ++j) {
          if (j > 0 && part[j].empty()) continue;  // v//n
          std::int64_t idx = 0;
          if (!parse_int(part[j], idx) || idx == 0)
            s.fail_line(fmt::format("{} uses {} {}, which is not a {} reference (a whole number, not 0)", what,
                                    kinds[j], quote_token(part[j]), kinds[j]));
          if (idx < 0 && std::uint64_t(-idx) > count[j])
            s.fail_line(fmt::format("{} uses {} {}, out of range ({} {} defined so far)", what, kinds[j], idx,
                                    count[j], plural[j]));
          if (idx > 0 && std::uint64_t(idx) > max_ref[j]) max_ref[j] = std::uint64_t(idx), max_line[j] = s.line_number();
        }
      }
    } else if (key == "mtllib") {
      // The rest of the line, as Assimp takes it: in the OBJ's directory,
      // else the OBJ's own name with .mtl.
      std::string_view name = trim(line.substr(line.find("mtllib") + 6));
      if (!name.empty())
        check_referenced_file(path, s.line_number(), dir.empty() ? std::string(name) : dir + "/" + std::string(name));
      if (!checked_fallback) {
        check_referenced_file(path, s.line_number(), path.substr(0, path.size() - 3) + "mtl");
        checked_fallback = true;
      }
    } else if ((key[0] == 'f' || key[0] == 'l' || key[0] == 'p') && key.size() > 1) {
      // Assimp reads any statement starting with f, l or p as a face, line or point.
      s.fail_line(fmt::format("unsupported OBJ statement {}", quote_token(key)));
    }
  }
  for (int j = 0; j < 3; ++j)
    if (max_ref[j] > count[j])
      throw Error(fmt::format("{}: line {}: uses {} {}, out of range (the file has {} {})", path, max_line[j], kinds[j],
                              max_ref[j], count[j], plural[j]));
}

// ---- STL ------------------------------------------------------------------------------------
//
// Binary when the size is exactly 84 + 50 x the triangle count in its header
// (as Assimp decides); else ASCII, starting with "solid": facets of exactly
// three vertices, every number parsed.

void check_stl(const std::string& path, std::uint64_t size) {
  FileScanner s(path, size);
  if (size >= 84) {
    s.skip(80);
    const unsigned char* c = s.bytes(4);
    const std::uint64_t n = std::uint64_t(c[0]) | std::uint64_t(c[1]) << 8 | std::uint64_t(c[2]) << 16 |
                            std::uint64_t(c[3]) << 24;
    if (84 + 50 * n == size) return;  // binary: 50 bytes per triangle, floats (checked as vertices)
    FileScanner t(path, size);
    const unsigned char* head = t.bytes(84);
    std::size_t i = 0;
    while (i < 79 && std::isspace(head[i])) ++i;
    if (std::memcmp(head + i, "solid", 5) != 0)
      s.fail(fmt::format("neither a binary STL (84 + 50 bytes x the {} triangles its header declares = {} bytes; the "
                         "file has {}) nor an ASCII STL (which starts with 'solid')",
                         n, 84 + 50 * n, size));
  }
  FileScanner t(path, size);
  std::string_view line;
  enum { Outside, Solid, Facet, Loop } state = Outside;
  int vertices = 0;
  std::uint64_t facets = 0;
  while (t.line(line, 1 << 16)) {
    const auto tokens = split_tokens(line);
    if (tokens.empty()) continue;
    const std::string_view key = tokens[0];
    auto expect = [&](bool ok, const char* wanted) {
      if (!ok) t.fail_line(fmt::format("expected {}, got {}", wanted, quote_token(trim(line))));
    };
    auto numbers = [&](std::size_t from) {
      for (std::size_t k = from; k < tokens.size(); ++k)
        if (!is_real(tokens[k])) t.fail_line(fmt::format("{} is not a number", quote_token(tokens[k])));
    };
    switch (state) {
      case Outside:
        expect(key == "solid", "'solid'");
        state = Solid;
        break;
      case Solid:
        if (key == "endsolid") {
          state = Outside;
          break;
        }
        expect(key == "facet" && tokens.size() == 5 && tokens[1] == "normal", "'facet normal nx ny nz' or 'endsolid'");
        numbers(2);
        state = Facet;
        break;
      case Facet:
        if (key == "endfacet") {
          expect(vertices == 3, "'outer loop' (a facet without its three vertices)");
          state = Solid;
          ++facets;
          vertices = 0;
          break;
        }
        expect(key == "outer" && tokens.size() == 2 && tokens[1] == "loop" && vertices == 0, "'outer loop'");
        state = Loop;
        break;
      case Loop:
        if (key == "endloop") {
          if (vertices != 3) t.fail_line(fmt::format("facet {} has {} vertices, not 3", facets, vertices));
          state = Facet;
          break;
        }
        expect(key == "vertex" && tokens.size() == 4, "'vertex x y z' or 'endloop'");
        numbers(1);
        if (++vertices > 3) t.fail_line(fmt::format("facet {} has more than 3 vertices", facets));
        break;
    }
  }
  if (state != Outside)
    t.fail(fmt::format("truncated: the file ends inside {} (after {} facets)",
                       state == Solid ? "a solid" : state == Facet ? "a facet" : "a facet's loop", facets));
}

}  // namespace prt::detail
