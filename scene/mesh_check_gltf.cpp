// The structure check of glTF 2.0 files (.gltf, and .glb binary containers)
// before Assimp reads them; see mesh_check.h.
//
// GLB: the header's length and every chunk's length against the file's
// size, before anything is read. Then the JSON (nesting depth bounded:
// Assimp's parser recurses): every buffer's byteLength against the data
// that is really there (the BIN chunk, a data: URI, or the referenced file,
// which must be a regular file), every buffer view inside its buffer, every
// accessor (with its stride, and its sparse parts) inside its buffer view,
// and every triangle index below the vertex count of its primitive (Assimp
// drops faces with an out-of-range index, with only a log message). The node
// hierarchy must be a forest (Assimp recurses through it) of bounded depth.
//
// Then every property the specification defines on the objects a reader
// uses, against the schema: its JSON type, an array's length, a number's
// range, an enum's values, an index's target (materials, textures, samplers,
// images, cameras, skins, morph targets, animation samplers), the texture
// coordinate sets a material's textures name against the primitives that use
// it, the asset's version and minVersion, the extension lists, and the
// extensions that change what the data means (Draco data without its
// uncompressed fallback is refused; the scene reader refuses
// KHR_texture_transform on the base colour texture, the one it samples). Image files must be regular files (a FIFO or a directory is
// never opened). URIs are percent-decoded (RFC 3986), as the specification
// writes them.

#include "mesh_check.h"

#include <prt/error.h>
#include <prt/io.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>
#include <set>
#include <span>

namespace prt::detail {

namespace {

using json = nlohmann::json;

constexpr int kMaxJsonDepth = 64;  // glTF needs ~8; Assimp's JSON parser recurses
constexpr double kHuge = std::numeric_limits<double>::infinity();  // no bound
// A node's rotation is a unit quaternion; exporters write it in float (and
// fewer digits): 1e-3 refuses a quaternion that is not one (0 0 0 0, or
// an unnormalised axis) and no rounding.
constexpr double kUnitTolerance = 1e-3;
constexpr std::size_t kAnyLength = std::numeric_limits<std::size_t>::max();

std::uint32_t le32(const unsigned char* p) {
  return std::uint32_t(p[0]) | std::uint32_t(p[1]) << 8 | std::uint32_t(p[2]) << 16 | std::uint32_t(p[3]) << 24;
}

int base64_value(unsigned char c) {
  if (c >= 'A' && c <= 'Z') return c - 'A';
  if (c >= 'a' && c <= 'z') return c - 'a' + 26;
  if (c >= '0' && c <= '9') return c - '0' + 52;
  if (c == '+') return 62;
  if (c == '/') return 63;
  return -1;
}

// Decodes standard base64 (with or without '=' padding); nullopt when malformed.
std::optional<std::vector<unsigned char>> decode_base64(std::string_view s) {
  while (!s.empty() && s.back() == '=') s.remove_suffix(1);
  if (s.size() % 4 == 1) return std::nullopt;
  std::vector<unsigned char> out;
  out.reserve(s.size() / 4 * 3 + 2);
  std::uint32_t acc = 0;
  int bits = 0;
  for (unsigned char c : s) {
    const int v = base64_value(c);
    if (v < 0) return std::nullopt;
    acc = (acc << 6) | std::uint32_t(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out.push_back(static_cast<unsigned char>((acc >> bits) & 0xff));
    }
  }
  return out;
}

class GltfCheck {
 public:
  GltfCheck(const std::string& path, std::uint64_t size, bool binary) : path_(path), size_(size), binary_(binary) {}

  void run() {
    std::string text = binary_ ? read_glb() : read_whole();
    parse(text);
    text.clear();
    text.shrink_to_fit();
    check_asset();
    check_names();
    check_buffers();
    check_views();
    check_accessors();
    check_images();
    check_samplers();
    check_textures();
    check_materials();
    check_meshes();
    check_nodes();
    check_skins();
    check_animations();
    check_cameras();
  }

 private:
  [[noreturn]] void fail(const std::string& what) const { throw Error(path_ + ": " + what); }

  void read_at(std::uint64_t offset, void* dst, std::size_t n, const std::string& file) {
    std::ifstream& in = stream(file);
    in.clear();
    in.seekg(static_cast<std::streamoff>(offset));
    in.read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
    if (!in || in.gcount() != static_cast<std::streamsize>(n))
      throw Error(fmt::format("{}: cannot read {} bytes at byte {} (truncated?)", file, n, offset));
  }

  std::ifstream& stream(const std::string& file) {
    if (file != open_name_) {
      open_.close();
      open_.clear();
      open_.open(file, std::ios::binary);
      if (!open_) throw Error(file + ": cannot open: " + std::strerror(errno));
      open_name_ = file;
    }
    return open_;
  }

  std::string read_whole() {
    std::string text(static_cast<std::size_t>(size_), '\0');
    if (size_ > 0) read_at(0, text.data(), text.size(), path_);
    return text;
  }

  // The GLB container: 12-byte header, a JSON chunk, an optional BIN chunk.
  std::string read_glb() {
    unsigned char h[20];
    if (size_ < 12) fail(fmt::format("truncated: a GLB file starts with a 12-byte header; this one has {} bytes", size_));
    read_at(0, h, 12, path_);
    if (std::memcmp(h, "glTF", 4) != 0) fail("not a GLB file (it does not start with 'glTF')");
    const std::uint32_t version = le32(h + 4), length = le32(h + 8);
    if (version == 1) fail("a glTF 1.0 binary file; prt reads glTF 2.0");
    if (version != 2) fail(fmt::format("GLB version {}; prt reads version 2", version));
    if (length > size_) fail(fmt::format("truncated: its header declares {} bytes, the file has {}", length, size_));
    if (length < size_)
      fail(fmt::format("its header declares {} bytes, the file has {} (a GLB's length is the whole file's)", length, size_));
    if (size_ < 20) fail("truncated: no JSON chunk after the GLB header");
    read_at(12, h + 12, 8, path_);
    const std::uint32_t json_length = le32(h + 12);
    if (std::memcmp(h + 16, "JSON", 4) != 0) fail("the first GLB chunk is not JSON");
    if (json_length > size_ - 20)
      fail(fmt::format("GLB chunk 0 (JSON) declares {} bytes, but only {} follow its header in the file", json_length,
                       size_ - 20));
    std::string text(json_length, '\0');
    if (json_length > 0) read_at(20, text.data(), json_length, path_);
    // As Assimp reads it: the BIN chunk follows the JSON chunk padded to 4
    // bytes, when the header's length leaves room for a chunk header.
    const std::uint64_t next = 20 + ((std::uint64_t(json_length) + 3) & ~std::uint64_t(3));
    if (length >= next + 8) {
      unsigned char c[8];
      if (next + 8 > size_) fail("truncated: the file ends in the header of GLB chunk 1");
      read_at(next, c, 8, path_);
      if (std::memcmp(c + 4, "BIN\0", 4) != 0) fail("GLB chunk 1 is not a BIN chunk");
      bin_length_ = le32(c);
      bin_offset_ = next + 8;
      if (bin_length_ > size_ - bin_offset_)
        fail(fmt::format("GLB chunk 1 (BIN) declares {} bytes, but only {} follow its header in the file", bin_length_,
                         size_ - bin_offset_));
      has_bin_ = true;
    }
    return text;
  }

  // Nesting depth first, by a SAX pass that builds nothing (nlohmann's
  // callback parser rescans a parent array at the end of every element:
  // quadratic, 5 minutes for 10^6 nodes), then the document.
  struct DepthSax : json::json_sax_t {
    int depth = 0;
    bool too_deep = false;
    std::string error;
    bool null() override { return true; }
    bool boolean(bool) override { return true; }
    bool number_integer(number_integer_t) override { return true; }
    bool number_unsigned(number_unsigned_t) override { return true; }
    bool number_float(number_float_t, const string_t&) override { return true; }
    bool string(string_t&) override { return true; }
    bool binary(binary_t&) override { return true; }
    bool key(string_t&) override { return true; }
    bool start_object(std::size_t) override { return deeper(); }
    bool start_array(std::size_t) override { return deeper(); }
    bool end_object() override { return --depth, true; }
    bool end_array() override { return --depth, true; }
    bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) override {
      error = e.what();
      return false;
    }
    bool deeper() {
      too_deep = ++depth > kMaxJsonDepth;
      return !too_deep;
    }
  };

  void parse(const std::string& text) {
    DepthSax sax;
    if (!json::sax_parse(text, &sax)) {
      if (sax.too_deep) fail(fmt::format("its JSON nests deeper than {} levels", kMaxJsonDepth));
      fail(fmt::format("not valid JSON: {}", sax.error));
    }
    try {
      doc_ = json::parse(text);
    } catch (const json::exception& e) {
      fail(fmt::format("not valid JSON: {}", e.what()));
    }
    if (!doc_.is_object()) fail("its JSON is not an object");
  }

  // An optional unsigned integer member (the default when absent).
  std::uint64_t uint_member(const json& obj, const char* key, std::uint64_t fallback, const std::string& what) const {
    const auto it = obj.find(key);
    if (it == obj.end()) return fallback;
    if (!it->is_number_unsigned() && !(it->is_number_integer() && it->get<std::int64_t>() >= 0))
      fail(fmt::format("{}: {} must be a whole number >= 0, got {}", what, key, it->dump().substr(0, 40)));
    return it->get<std::uint64_t>();
  }

  std::uint64_t required_uint(const json& obj, const char* key, const std::string& what) const {
    if (!obj.contains(key)) fail(fmt::format("{} has no {}", what, key));
    return uint_member(obj, key, 0, what);
  }

  // The array `key` of the root (empty when absent); its entries must be
  // objects. Checked once per key (index() calls it for every reference).
  const json& array(const char* key) {
    static const json empty = json::array();
    const auto it = doc_.find(key);
    if (it == doc_.end()) return empty;
    if (checked_arrays_.insert(key).second) {
      if (!it->is_array()) fail(fmt::format("'{}' is not an array", key));
      if (it->empty()) fail(fmt::format("'{}' is an empty array (glTF leaves an empty list out)", key));
      for (std::size_t i = 0; i < it->size(); ++i)
        if (!(*it)[i].is_object()) fail(fmt::format("{}[{}] is not an object", key, i));
    }
    return *it;
  }

  // An index into the root array `target`.
  std::uint64_t index(const json& obj, const char* key, const char* target, const std::string& what) {
    const std::uint64_t i = uint_member(obj, key, 0, what);
    if (i >= array(target).size())
      fail(fmt::format("{}: {} {} is out of range (the file has {} {})", what, key, i, array(target).size(), target));
    return i;
  }

  // ---- typed members: the schema's JSON types, lengths and ranges ----

  static std::string shown(const json& j) {
    std::string s = j.dump();
    return s.size() > 40 ? s.substr(0, 37) + "..." : s;
  }

  [[noreturn]] void wrong(const std::string& what, const char* key, const std::string& expected, const json& got) const {
    fail(fmt::format("{}: {} must be {}, got {}", what, key, expected, shown(got)));
  }

  static std::string range_text(const std::string& head, double lo, double hi) {
    if (lo == -kHuge && hi == kHuge) return head;
    if (hi == kHuge) return fmt::format("{} >= {}", head, lo);
    return fmt::format("{} in [{}, {}]", head, lo, hi);
  }

  // A finite number in [lo, hi] (`fallback` when absent).
  double number(const json& obj, const char* key, double fallback, const std::string& what, double lo = -kHuge,
                double hi = kHuge) const {
    const auto it = obj.find(key);
    if (it == obj.end()) return fallback;
    if (!it->is_number() || !std::isfinite(it->get<double>()) || it->get<double>() < lo || it->get<double>() > hi)
      wrong(what, key, range_text("a number", lo, hi), *it);
    return it->get<double>();
  }

  // Exactly n (or with kAnyLength, any number of) finite numbers in [lo,
  // hi]; empty when absent.
  std::vector<double> numbers(const json& obj, const char* key, std::size_t n, const std::string& what,
                              double lo = -kHuge, double hi = kHuge) const {
    const auto it = obj.find(key);
    if (it == obj.end()) return {};
    const std::string expected =
        range_text(n == kAnyLength ? std::string("an array of numbers") : fmt::format("an array of {} numbers", n), lo, hi);
    if (!it->is_array() || (n != kAnyLength && it->size() != n)) wrong(what, key, expected, *it);
    std::vector<double> out;
    for (const json& v : *it) {
      if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < lo || v.get<double>() > hi)
        wrong(what, key, expected, *it);
      out.push_back(v.get<double>());
    }
    return out;
  }

  // A member of JSON type `type` when present (number_unsigned: a whole
  // number >= 0); returns it, or null when absent.
  const json* typed(const json& obj, const char* key, json::value_t type, const std::string& what) const {
    const auto it = obj.find(key);
    if (it == obj.end()) return nullptr;
    const bool ok = type == json::value_t::number_unsigned ? it->is_number_unsigned() : it->type() == type;
    if (!ok) {
      const char* name = type == json::value_t::string    ? "a string"
                         : type == json::value_t::boolean ? "true or false"
                         : type == json::value_t::object  ? "an object"
                         : type == json::value_t::array   ? "an array"
                                                          : "a whole number >= 0";
      wrong(what, key, name, *it);
    }
    return &*it;
  }

  // A string member, when present, one of `allowed`.
  void string_enum(const json& obj, const char* key, std::initializer_list<const char*> allowed, const std::string& what,
                   bool required = false) const {
    const json* v = typed(obj, key, json::value_t::string, what);
    if (v == nullptr) {
      if (required) fail(fmt::format("{} has no {}", what, key));
      return;
    }
    std::string list;
    for (const char* a : allowed) {
      if (v->get<std::string>() == a) return;
      list += fmt::format("{}{}", list.empty() ? "" : ", ", a);
    }
    wrong(what, key, "one of " + list, *v);
  }

  // A whole-number member, when present, one of `allowed`.
  void uint_enum(const json& obj, const char* key, std::initializer_list<std::uint64_t> allowed,
                 const std::string& what) const {
    if (!obj.contains(key)) return;
    const std::uint64_t v = uint_member(obj, key, 0, what);
    std::string list;
    for (std::uint64_t a : allowed) {
      if (v == a) return;
      list += fmt::format("{}{}", list.empty() ? "" : ", ", a);
    }
    wrong(what, key, "one of " + list, obj[key]);
  }

  // An array of distinct indices into the root array `target` (at least
  // one); empty when absent.
  std::vector<std::uint64_t> index_list(const json& obj, const char* key, const char* target, const std::string& what) {
    const auto it = obj.find(key);
    if (it == obj.end()) return {};
    if (!it->is_array() || it->empty()) wrong(what, key, fmt::format("a non-empty array of indices into {}", target), *it);
    const std::size_t n = array(target).size();
    std::vector<std::uint64_t> out;
    std::set<std::uint64_t> seen;
    for (const json& v : *it) {
      if (!v.is_number_unsigned() || v.get<std::uint64_t>() >= n)
        fail(fmt::format("{}: {} holds {}, which is not an index into {} (the file has {})", what, key, shown(v), target,
                         n));
      if (!seen.insert(v.get<std::uint64_t>()).second)
        fail(fmt::format("{}: {} holds {} twice", what, key, v.get<std::uint64_t>()));
      out.push_back(v.get<std::uint64_t>());
    }
    return out;
  }

  // Every entry of every root array: its name a string, its extensions an object.
  void check_names() {
    for (const char* key : {"accessors", "animations", "buffers", "bufferViews", "cameras", "images", "materials",
                            "meshes", "nodes", "samplers", "scenes", "skins", "textures"}) {
      const json& list = array(key);
      for (std::size_t i = 0; i < list.size(); ++i) {
        const std::string what = fmt::format("{}[{}]", key, i);
        typed(list[i], "name", json::value_t::string, what);
        typed(list[i], "extensions", json::value_t::object, what);
      }
    }
    typed(doc_, "extensions", json::value_t::object, "the file");
  }

  // "MAJOR.MINOR" (digits each); false when `v` is not of that form.
  static bool parse_version(const std::string& v, std::uint64_t& major, std::uint64_t& minor) {
    const std::size_t dot = v.find('.');
    if (dot == std::string::npos || dot == 0 || dot + 1 == v.size() || dot > 9 || v.size() - dot > 10) return false;
    return parse_uint(std::string_view(v).substr(0, dot), major) && parse_uint(std::string_view(v).substr(dot + 1), minor);
  }

  void check_asset() {
    const auto it = doc_.find("asset");
    if (it == doc_.end() || !it->is_object() || !it->contains("version") || !(*it)["version"].is_string())
      fail("has no asset.version (not a glTF file?)");
    const std::string v = (*it)["version"].get<std::string>();
    std::uint64_t major = 0, minor = 0;
    if (v.rfind("1", 0) == 0 && (v.size() == 1 || v[1] == '.'))
      fail(fmt::format("glTF {}; prt reads glTF 2.0", v.substr(0, 20)));
    if (!parse_version(v, major, minor) || major != 2)
      fail(fmt::format("glTF version '{}'; prt reads glTF 2.0 (asset.version is MAJOR.MINOR)", v.substr(0, 20)));
    if (const json* mv = typed(*it, "minVersion", json::value_t::string, "asset")) {
      std::uint64_t min_major = 0, min_minor = 0;
      const std::string m = mv->get<std::string>();
      if (!parse_version(m, min_major, min_minor)) wrong("asset", "minVersion", "MAJOR.MINOR", *mv);
      if (min_major != 2 || min_minor != 0)
        fail(fmt::format("asset.minVersion is {}: the file needs a glTF {} reader; prt reads glTF 2.0", m.substr(0, 20),
                         m.substr(0, 20)));
    }
    typed(*it, "generator", json::value_t::string, "asset");
    typed(*it, "copyright", json::value_t::string, "asset");
    std::set<std::string> used;
    for (const char* key : {"extensionsUsed", "extensionsRequired"}) {
      const auto list = doc_.find(key);
      if (list == doc_.end()) continue;
      if (!list->is_array() || list->empty()) wrong("the file", key, "a non-empty array of extension names", *list);
      std::set<std::string> seen;
      for (const json& e : *list) {
        if (!e.is_string()) wrong("the file", key, "an array of extension names", *list);
        const std::string name = e.get<std::string>();
        if (!seen.insert(name).second) fail(fmt::format("{} names {} twice", key, quote_token(name)));
        if (std::string_view(key) == "extensionsUsed") {
          used.insert(name);
          continue;
        }
        if (!used.count(name))
          fail(fmt::format("extensionsRequired names {}, which extensionsUsed does not", quote_token(name)));
        // What prt reads without these is still what the file means: material
        // models it does not use, texture formats it reports where a material
        // needs them, lights (the sky is what prt bakes), and
        // KHR_texture_transform, which the scene reader refuses where it
        // would move the albedo.
        const bool harmless = (name.rfind("KHR_materials_", 0) == 0 && name != "KHR_materials_pbrSpecularGlossiness") ||
                              name == "KHR_texture_transform" || name == "KHR_lights_punctual" ||
                              name == "KHR_texture_basisu" || name == "EXT_texture_webp";
        if (!harmless) fail(fmt::format("requires the extension {}, which prt cannot read", name.substr(0, 60)));
      }
    }
  }

  struct Buffer {
    std::uint64_t length = 0;
    enum { Bin, Data, File } source = Bin;
    std::string file;                     // File
    std::vector<unsigned char> data;      // Data (decoded on first use)
    std::string uri;                      // Data
    bool decoded = false;
  };

  // A relative URI reference as a file path: percent escapes decoded
  // (RFC 3986: "buffer%20data.bin" names "buffer data.bin"). Absolute URIs
  // (a scheme, or a leading '/') are not files next to the glTF.
  std::string uri_path(const std::string& uri, const std::string& what) const {
    const std::size_t colon = uri.find(':'), slash = uri.find('/');
    if (!uri.empty() && uri[0] == '/') fail(fmt::format("{}: uri {} is an absolute path; glTF's are relative to the file", what, quote_token(uri)));
    if (colon != std::string::npos && (slash == std::string::npos || colon < slash))
      fail(fmt::format("{}: uri {} is not a file next to the glTF (prt reads relative paths and data: URIs)", what,
                       quote_token(uri)));
    std::string out;
    if (!percent_decode(uri, out))
      fail(fmt::format("{}: uri {} has a '%' that is not followed by two hex digits, or encodes a NUL byte", what,
                       quote_token(uri)));
    return out;
  }

  std::string directory() const {
    std::string dir = std::filesystem::path(path_).parent_path().string();
    if (!dir.empty() && dir.back() != '/') dir += '/';
    return dir;
  }

  void check_buffers() {
    const json& buffers = array("buffers");
    for (std::size_t i = 0; i < buffers.size(); ++i) {
      const json& b = buffers[i];
      const std::string what = fmt::format("buffer {}", i);
      Buffer buf;
      buf.length = required_uint(b, "byteLength", what);
      const auto uri = b.find("uri");
      if (uri == b.end()) {
        if (i != 0 || !has_bin_)
          fail(fmt::format("{} has no uri{}", what, binary_ ? " and is not the GLB's BIN chunk" : ""));
        if (buf.length > bin_length_)
          fail(fmt::format("{} declares {} bytes, but the BIN chunk holds {}", what, buf.length, bin_length_));
      } else {
        if (!uri->is_string()) fail(what + ": uri is not a string");
        const std::string u = uri->get<std::string>();
        if (u.rfind("data:", 0) == 0) {
          const std::size_t comma = u.find(',');
          if (comma == std::string::npos) fail(fmt::format("{}: malformed data URI (no ',')", what));
          const std::string_view head(u.data(), comma), body(u.data() + comma + 1, u.size() - comma - 1);
          buf.source = Buffer::Data;
          std::uint64_t have = body.size();
          if (head.size() >= 7 && head.substr(head.size() - 7) == ";base64") {
            auto d = decode_base64(body);
            if (!d) fail(fmt::format("{}: its data URI is not valid base64", what));
            have = d->size();
            buf.data = std::move(*d);
          } else {
            buf.data.assign(body.begin(), body.end());
          }
          buf.decoded = true;
          if (buf.length != have)
            fail(fmt::format("{} declares {} bytes, but its data URI holds {}", what, buf.length, have));
        } else {
          // The glTF file's directory + the URI's path, percent-decoded.
          const std::string dir = directory();
          buf.source = Buffer::File;
          buf.file = dir + uri_path(u, what);
          std::uint64_t have = 0;
          try {
            have = check_input_file(buf.file, "a glTF buffer");
          } catch (const Error& e) {
            fail(fmt::format("{}: {}", what, e.what()));
          }
          if (buf.length > have)
            fail(fmt::format("{} declares {} bytes, but {} has {}", what, buf.length, buf.file, have));
        }
      }
      buffers_.push_back(std::move(buf));
    }
  }

  struct View {
    std::uint64_t buffer = 0, offset = 0, length = 0, stride = 0;
  };

  void check_views() {
    const json& views = array("bufferViews");
    for (std::size_t i = 0; i < views.size(); ++i) {
      const json& v = views[i];
      const std::string what = fmt::format("bufferView {}", i);
      View view;
      if (!v.contains("buffer")) fail(what + " has no buffer");
      view.buffer = index(v, "buffer", "buffers", what);
      view.offset = uint_member(v, "byteOffset", 0, what);
      view.length = required_uint(v, "byteLength", what);
      view.stride = uint_member(v, "byteStride", 0, what);
      if (v.contains("byteStride") && (view.stride < 4 || view.stride > 252 || view.stride % 4 != 0))
        fail(fmt::format("{}: byteStride {} is not a multiple of 4 from 4 to 252", what, view.stride));
      uint_enum(v, "target", {34962, 34963}, what);
      const std::uint64_t have = buffers_[view.buffer].length;
      if (view.offset > have || view.length > have - view.offset)
        fail(fmt::format("{} (offset {}, {} bytes) does not fit in buffer {} ({} bytes)", what, view.offset, view.length,
                         view.buffer, have));
      views_.push_back(view);
    }
  }

  static std::uint64_t component_size(std::uint64_t type) {
    switch (type) {
      case 5120:
      case 5121: return 1;
      case 5122:
      case 5123: return 2;
      case 5125:
      case 5126: return 4;
      default: return 0;
    }
  }

  static std::uint64_t components(const std::string& type) {
    static constexpr std::array<std::pair<const char*, int>, 7> types = {
        {{"SCALAR", 1}, {"VEC2", 2}, {"VEC3", 3}, {"VEC4", 4}, {"MAT2", 4}, {"MAT3", 9}, {"MAT4", 16}}};
    for (const auto& [name, n] : types)
      if (type == name) return std::uint64_t(n);
    return 0;
  }

  struct Accessor {
    std::uint64_t count = 0, component_type = 0, components = 0;
    std::optional<std::uint64_t> view;
    std::uint64_t offset = 0;
    std::string type;
    bool sparse = false;
    bool normalized = false;
  };

  // Throws unless `count` elements of `elem` bytes, `stride` apart, from
  // `offset` fit in buffer view `view`.
  void check_fits(std::uint64_t view, std::uint64_t offset, std::uint64_t count, std::uint64_t elem,
                  std::uint64_t stride, const std::string& what) const {
    const View& v = views_[view];
    if (stride != 0 && stride < elem)
      fail(fmt::format("{}: its elements of {} bytes are longer than bufferView {}'s byteStride {}", what, elem, view,
                       stride));
    const std::uint64_t step = stride ? stride : elem;
    // The last element ends at offset + (count - 1) * step + elem (in 128
    // bits: every term comes from the file).
    __extension__ typedef unsigned __int128 u128;
    const u128 end = count == 0 ? u128(offset) : u128(offset) + u128(count - 1) * step + elem;
    if (end > v.length)
      fail(fmt::format("{} ({} elements of {} bytes from byte {}) does not fit in bufferView {} ({} bytes)", what, count,
                       elem, offset, view, v.length));
  }

  void check_accessors() {
    const json& accessors = array("accessors");
    for (std::size_t i = 0; i < accessors.size(); ++i) {
      const json& a = accessors[i];
      const std::string what = fmt::format("accessor {}", i);
      Accessor acc;
      acc.count = required_uint(a, "count", what);
      acc.component_type = required_uint(a, "componentType", what);
      const std::uint64_t csize = component_size(acc.component_type);
      if (csize == 0) fail(fmt::format("{}: unknown componentType {}", what, acc.component_type));
      if (!a.contains("type") || !a["type"].is_string()) fail(what + " has no type");
      acc.type = a["type"].get<std::string>();
      acc.components = components(acc.type);
      if (acc.components == 0) fail(fmt::format("{}: unknown type {}", what, quote_token(acc.type)));
      if (acc.count > std::numeric_limits<std::uint32_t>::max())
        fail(fmt::format("{}: count {} is more than prt reads", what, acc.count));
      if (acc.count == 0) fail(what + ": count is 0 (glTF's accessors hold at least one element)");
      if (const json* n = typed(a, "normalized", json::value_t::boolean, what)) acc.normalized = n->get<bool>();
      if (acc.normalized && (acc.component_type == 5126 || acc.component_type == 5125))
        fail(fmt::format("{}: normalized is true for componentType {} (only 8- and 16-bit integers are normalized)", what,
                         acc.component_type));
      numbers(a, "min", acc.components, what);
      numbers(a, "max", acc.components, what);
      acc.offset = uint_member(a, "byteOffset", 0, what);
      if (a.contains("byteOffset") && !a.contains("bufferView")) fail(what + " has a byteOffset but no bufferView");
      if (a.contains("bufferView")) {
        acc.view = index(a, "bufferView", "bufferViews", what);
        check_fits(*acc.view, acc.offset, acc.count, csize * acc.components, views_[*acc.view].stride, what);
      }
      if (const auto sp = a.find("sparse"); sp != a.end()) {
        if (!sp->is_object()) fail(what + ": sparse is not an object");
        acc.sparse = true;
        const std::uint64_t n = required_uint(*sp, "count", what + " sparse");
        if (n == 0) fail(what + ": sparse count is 0 (a sparse accessor replaces at least one element)");
        if (n > acc.count) fail(fmt::format("{}: sparse count {} exceeds count {}", what, n, acc.count));
        for (const char* part : {"indices", "values"}) {
          const auto p = sp->find(part);
          if (p == sp->end() || !p->is_object()) fail(fmt::format("{}: sparse has no {}", what, part));
          const std::string pw = fmt::format("{} sparse {}", what, part);
          if (!p->contains("bufferView")) fail(pw + " has no bufferView");
          const std::uint64_t view = index(*p, "bufferView", "bufferViews", pw);
          std::uint64_t elem = csize * acc.components;
          if (std::string(part) == "indices") {
            const std::uint64_t ct = required_uint(*p, "componentType", pw);
            if (ct != 5121 && ct != 5123 && ct != 5125) fail(fmt::format("{}: componentType {} is not unsigned", pw, ct));
            elem = component_size(ct);
          }
          check_fits(view, uint_member(*p, "byteOffset", 0, pw), n, elem, 0, pw);
        }
      }
      accessors_.push_back(std::move(acc));
    }
  }

  // Images: a URI (data: or a file next to the glTF) or a buffer view with
  // its MIME type. A file that exists must be a regular file (tinygltf reads
  // it whole: a FIFO blocks, a directory's size is garbage); a missing one
  // is reported by the scene reader when a material needs it (a mesh load
  // never reads images).
  void check_images() {
    const json& images = array("images");
    for (std::size_t i = 0; i < images.size(); ++i) {
      const json& im = images[i];
      const std::string what = fmt::format("image {}", i);
      const json* uri = typed(im, "uri", json::value_t::string, what);
      if (im.contains("bufferView")) {
        index(im, "bufferView", "bufferViews", what);
        if (uri) fail(what + " has both a uri and a bufferView");
        string_enum(im, "mimeType", {"image/jpeg", "image/png"}, what, true);
      } else {
        string_enum(im, "mimeType", {"image/jpeg", "image/png"}, what);
        if (!uri) fail(what + " has neither a uri nor a bufferView");
      }
      if (!uri || uri->get<std::string>().rfind("data:", 0) == 0) continue;
      const std::string file = directory() + uri_path(uri->get<std::string>(), what);
      std::error_code ec;
      if (std::filesystem::status(file, ec).type() == std::filesystem::file_type::not_found) continue;
      try {
        check_input_file(file, "a glTF image");
      } catch (const Error& e) {
        fail(fmt::format("{}: {}", what, e.what()));
      }
    }
  }

  void check_samplers() {
    const json& samplers = array("samplers");
    for (std::size_t i = 0; i < samplers.size(); ++i) {
      const std::string what = fmt::format("sampler {}", i);
      uint_enum(samplers[i], "magFilter", {9728, 9729}, what);
      uint_enum(samplers[i], "minFilter", {9728, 9729, 9984, 9985, 9986, 9987}, what);
      uint_enum(samplers[i], "wrapS", {33071, 33648, 10497}, what);
      uint_enum(samplers[i], "wrapT", {33071, 33648, 10497}, what);
    }
  }

  void check_textures() {
    const json& textures = array("textures");
    for (std::size_t i = 0; i < textures.size(); ++i) {
      const json& t = textures[i];
      const std::string what = fmt::format("texture {}", i);
      if (t.contains("sampler")) index(t, "sampler", "samplers", what);
      if (t.contains("source")) index(t, "source", "images", what);
      if (const json* ext = typed(t, "extensions", json::value_t::object, what))
        for (const char* name : {"KHR_texture_basisu", "EXT_texture_webp"})
          if (const json* e = typed(*ext, name, json::value_t::object, what))
            if (e->contains("source")) index(*e, "source", "images", what + " " + name);
    }
  }

  // A textureInfo: its texture, its texCoord (KHR_texture_transform's
  // overrides it) and the transform's numbers. Returns the UV set it reads.
  std::uint64_t texture_info(const json& parent, const char* key, const std::string& owner) {
    const json* info = typed(parent, key, json::value_t::object, owner);
    if (info == nullptr) return 0;
    const std::string what = owner + " " + key;
    if (!info->contains("index")) fail(what + " has no index");
    index(*info, "index", "textures", what);
    std::uint64_t set = uint_member(*info, "texCoord", 0, what);
    if (const json* ext = typed(*info, "extensions", json::value_t::object, what))
      if (const json* tt = typed(*ext, "KHR_texture_transform", json::value_t::object, what)) {
        const std::string w = what + " KHR_texture_transform";
        numbers(*tt, "offset", 2, w);
        number(*tt, "rotation", 0, w);
        numbers(*tt, "scale", 2, w);
        set = uint_member(*tt, "texCoord", set, w);
      }
    if (set > 64) fail(fmt::format("{}: texCoord {} is more than any primitive has", what, set));
    return set;
  }

  // Materials: their factors and textures; what each needs of a primitive
  // (the highest TEXCOORD_n its textures read) for check_meshes.
  void check_materials() {
    const json& materials = array("materials");
    for (std::size_t i = 0; i < materials.size(); ++i) {
      const json& m = materials[i];
      const std::string what = fmt::format("material {}", i);
      NeededSet need;
      const auto use = [&](const json& parent, const char* key, const std::string& owner) {
        if (!parent.contains(key)) return;
        const std::uint64_t set = texture_info(parent, key, owner);
        if (!need.needed || set > need.set) need = {set, owner + " " + key, true};
      };
      if (const json* pbr = typed(m, "pbrMetallicRoughness", json::value_t::object, what)) {
        const std::string w = what + " pbrMetallicRoughness";
        numbers(*pbr, "baseColorFactor", 4, w, 0, 1);
        number(*pbr, "metallicFactor", 1, w, 0, 1);
        number(*pbr, "roughnessFactor", 1, w, 0, 1);
        use(*pbr, "baseColorTexture", w);
        use(*pbr, "metallicRoughnessTexture", w);
      }
      use(m, "normalTexture", what);
      use(m, "occlusionTexture", what);
      use(m, "emissiveTexture", what);
      if (const json* t = typed(m, "normalTexture", json::value_t::object, what)) number(*t, "scale", 1, what + " normalTexture");
      if (const json* t = typed(m, "occlusionTexture", json::value_t::object, what))
        number(*t, "strength", 1, what + " occlusionTexture", 0, 1);
      numbers(m, "emissiveFactor", 3, what, 0, 1);
      string_enum(m, "alphaMode", {"OPAQUE", "MASK", "BLEND"}, what);
      number(m, "alphaCutoff", 0.5, what, 0);
      typed(m, "doubleSided", json::value_t::boolean, what);
      material_needs_.push_back(need);
    }
  }

  // The bytes [offset, offset + n) of buffer b.
  std::vector<unsigned char> buffer_bytes(std::uint64_t b, std::uint64_t offset, std::uint64_t n) {
    Buffer& buf = buffers_[b];
    PRT_CHECK(offset <= buf.length && n <= buf.length - offset);
    std::vector<unsigned char> out(static_cast<std::size_t>(n));
    if (n == 0) return out;
    switch (buf.source) {
      case Buffer::Bin: read_at(bin_offset_ + offset, out.data(), out.size(), path_); break;
      case Buffer::File: read_at(offset, out.data(), out.size(), buf.file); break;
      case Buffer::Data: std::memcpy(out.data(), buf.data.data() + offset, out.size()); break;
    }
    return out;
  }

  // Throws unless every index of accessor `a` (its base values and sparse
  // replacements) is below `vertices`. `joints`: the accessor is a
  // primitive's JOINTS_0 (unsigned VEC4s, each component a joint of its
  // skin, `vertices` then the skin's joint count).
  void check_indices(std::uint64_t a, std::uint64_t vertices, const std::string& what, bool joints = false) {
    const Accessor& acc = accessors_[a];
    if (acc.type != (joints ? "VEC4" : "SCALAR") ||
        (acc.component_type != 5121 && acc.component_type != 5123 && (joints || acc.component_type != 5125)))
      fail(fmt::format("{}: its {} (accessor {}) are not unsigned integer {}", what, joints ? "JOINTS_0" : "indices", a,
                       joints ? "VEC4s (8 or 16 bits)" : "scalars"));
    const std::uint64_t csize = component_size(acc.component_type), comps = joints ? 4 : 1;
    auto scan = [&](const std::vector<unsigned char>& d, std::uint64_t step, std::uint64_t count) {
      for (std::uint64_t i = 0; i < count; ++i)
        for (std::uint64_t c = 0; c < comps; ++c) {
          const unsigned char* p = d.data() + i * step + c * csize;
          const std::uint64_t v = csize == 1 ? p[0] : csize == 2 ? std::uint64_t(p[0] | p[1] << 8) : le32(p);
          if (v < vertices) continue;
          if (joints)
            fail(fmt::format("{} uses joint {} (vertex {} of accessor {}), out of range (its skin has {} joints)", what,
                             v, i, a, vertices));
          fail(fmt::format("{} uses vertex {} (index {} of accessor {}), out of range (its POSITION has {} vertices)",
                           what, v, i, a, vertices));
        }
    };
    const std::uint64_t elem = comps * csize;
    if (acc.view) {
      const View& v = views_[*acc.view];
      const std::uint64_t step = v.stride ? v.stride : elem;
      const std::uint64_t bytes = acc.count == 0 ? 0 : (acc.count - 1) * step + elem;
      scan(buffer_bytes(v.buffer, v.offset + acc.offset, bytes), step, acc.count);
    }
    if (acc.sparse) {
      const json& values = doc_["accessors"][a]["sparse"]["values"];
      const View& v = views_[values["bufferView"].get<std::uint64_t>()];
      const std::uint64_t n = doc_["accessors"][a]["sparse"]["count"].get<std::uint64_t>();
      scan(buffer_bytes(v.buffer, v.offset + uint_member(values, "byteOffset", 0, what), n * elem), elem, n);
    }
  }

  // Skins, which Assimp reads with the mesh: each a list of joint nodes and
  // their inverse bind matrices, float MAT4s, one per joint at least. glTF
  // lets the matrices be left out (identity), but Assimp 5.2 then follows a
  // null pointer, and reads past the array when there are fewer than joints:
  // both are refused here with what to do. A node's skin must exist, and
  // its mesh's JOINTS_0 name joints of that skin.
  void check_skins() {
    const json& skins = array("skins");
    const std::size_t nodes = array("nodes").size();
    std::vector<std::uint64_t> joints(skins.size());
    for (std::size_t s = 0; s < skins.size(); ++s) {
      const std::string what = fmt::format("skin {}", s);
      const auto j = skins[s].find("joints");
      if (j == skins[s].end() || !j->is_array() || j->empty()) fail(what + " has no joints");
      for (const json& n : *j)
        if (!n.is_number_unsigned() || n.get<std::uint64_t>() >= nodes)
          fail(fmt::format("{}: joint {} is not a node (the file has {} nodes)", what, n.dump().substr(0, 20), nodes));
      index_list(skins[s], "joints", "nodes", what);
      if (skins[s].contains("skeleton")) index(skins[s], "skeleton", "nodes", what);
      joints[s] = j->size();
      if (!skins[s].contains("inverseBindMatrices"))
        fail(what + " has no inverseBindMatrices: prt's glTF reader (Assimp) needs them; export the skin with its "
                    "inverse bind matrices (Blender's glTF exporter writes them)");
      const Accessor& m = accessors_[index(skins[s], "inverseBindMatrices", "accessors", what)];
      if (m.type != "MAT4" || m.component_type != 5126 || m.count < joints[s])
        fail(fmt::format("{}: inverseBindMatrices must be float MAT4, one per joint ({}); it is {} of componentType "
                         "{}, {} of them", what, joints[s], m.type, m.component_type, m.count));
    }
    const json& node_list = array("nodes");
    const json& meshes = array("meshes");
    for (std::size_t i = 0; i < node_list.size(); ++i) {
      if (!node_list[i].contains("skin")) continue;
      const std::string what = fmt::format("node {}", i);
      const std::uint64_t s = index(node_list[i], "skin", "skins", what);
      if (!node_list[i].contains("mesh")) continue;
      const json& prims = meshes[node_list[i]["mesh"].get<std::size_t>()]["primitives"];
      for (std::size_t p = 0; p < prims.size(); ++p)
        if (const auto attrs = prims[p].find("attributes"); attrs->contains("JOINTS_0"))
          check_indices((*attrs)["JOINTS_0"].get<std::uint64_t>(), joints[s],
                        fmt::format("{} (skin {}) mesh primitive {}", what, s, p), true);
    }
  }

  // The accessor an attribute names, of one of `types` and component types
  // `components` (0 ends the list), `count` elements.
  const Accessor& attribute(const json& attrs, const std::string& name, std::initializer_list<const char*> types,
                            std::initializer_list<std::uint64_t> components, bool normalized_ints,
                            const std::string& what) {
    const std::uint64_t a = attrs[name].get<std::uint64_t>();
    const Accessor& acc = accessors_[a];
    bool type_ok = false, comp_ok = false;
    for (const char* t : types) type_ok |= acc.type == t;
    for (std::uint64_t c : components) comp_ok |= acc.component_type == c;
    if (comp_ok && normalized_ints && acc.component_type != 5126 && !acc.normalized) comp_ok = false;
    if (!type_ok || !comp_ok) {
      std::string list;
      for (const char* t : types) list += fmt::format("{}{}", list.empty() ? "" : " or ", t);
      fail(fmt::format("{}: {} (accessor {}) is {} of componentType {}{}; glTF allows {} of {}", what, name, a, acc.type,
                       acc.component_type, acc.normalized ? " (normalized)" : "", list,
                       normalized_ints ? "floats or normalized unsigned bytes or shorts" : "floats"));
    }
    return acc;
  }

  void check_meshes() {
    const json& meshes = array("meshes");
    for (std::size_t m = 0; m < meshes.size(); ++m) {
      const auto prims = meshes[m].find("primitives");
      if (prims == meshes[m].end() || !prims->is_array() || prims->empty()) fail(fmt::format("mesh {} has no primitives", m));
      std::optional<std::size_t> targets;
      for (std::size_t p = 0; p < prims->size(); ++p) {
        const std::string what = fmt::format("mesh {} primitive {}", m, p);
        const std::size_t t = check_primitive((*prims)[p], what);
        if (targets && *targets != t)
          fail(fmt::format("{} has {} morph targets, primitive 0 has {} (every primitive of a mesh has as many)", what, t,
                           *targets));
        targets = t;
      }
      const std::vector<double> weights = numbers(meshes[m], "weights", kAnyLength, fmt::format("mesh {}", m));
      if (meshes[m].contains("weights") && (weights.size() != *targets || weights.empty()))
        fail(fmt::format("mesh {}: weights has {} entries for {} morph targets", m, weights.size(), *targets));
      mesh_targets_.push_back(*targets);
    }
  }

  // One primitive; returns its number of morph targets.
  std::size_t check_primitive(const json& prim, const std::string& what) {
    if (!prim.is_object()) fail(what + " is not an object");
    const auto attrs = prim.find("attributes");
    if (attrs == prim.end() || !attrs->is_object() || !attrs->contains("POSITION")) fail(what + " has no POSITION attribute");
    for (const auto& [name, value] : attrs->items()) {
      if (!value.is_number_unsigned() || value.get<std::uint64_t>() >= accessors_.size())
        fail(fmt::format("{}: attribute {} names no accessor (the file has {})", what, name, accessors_.size()));
    }
    const Accessor& pos = accessors_[(*attrs)["POSITION"].get<std::uint64_t>()];
    if (pos.type != "VEC3" || pos.component_type != 5126)
      fail(fmt::format("{}: POSITION is {} of componentType {}, not float VEC3", what, pos.type, pos.component_type));
    if (attrs->contains("NORMAL")) {
      const Accessor& n = accessors_[(*attrs)["NORMAL"].get<std::uint64_t>()];
      if (n.type != "VEC3" || n.component_type != 5126 || n.count != pos.count)
        fail(fmt::format("{}: NORMAL is not float VEC3 with one per position", what));
    }
    if (attrs->contains("TANGENT")) attribute(*attrs, "TANGENT", {"VEC4"}, {5126}, false, what);
    // Every attribute has one element per vertex; sets numbered from 0 without gaps.
    std::uint64_t uv_sets = 0;
    for (const auto& [name, value] : attrs->items()) {
      if (accessors_[value.get<std::uint64_t>()].count != pos.count)
        fail(fmt::format("{}: {} has {} elements, POSITION {} (every attribute has one per vertex)", what, name,
                         accessors_[value.get<std::uint64_t>()].count, pos.count));
      for (const char* prefix : {"TEXCOORD_", "COLOR_", "JOINTS_", "WEIGHTS_"}) {
        const std::string_view n(name);
        std::uint64_t k = 0;
        if (n.rfind(prefix, 0) != 0) continue;
        if (!parse_uint(n.substr(std::strlen(prefix)), k) || (k > 0 && !attrs->contains(fmt::format("{}{}", prefix, k - 1))))
          fail(fmt::format("{}: attribute {} without {}{} (glTF numbers each kind's sets from 0 without gaps)", what, name,
                           prefix, k == 0 ? 0 : k - 1));
        if (std::string_view(prefix) == "TEXCOORD_") {
          attribute(*attrs, name, {"VEC2"}, {5126, 5121, 5123}, true, what);
          uv_sets = std::max(uv_sets, k + 1);
        } else if (std::string_view(prefix) == "COLOR_") {
          attribute(*attrs, name, {"VEC3", "VEC4"}, {5126, 5121, 5123}, true, what);
        }
      }
    }
    const std::uint64_t mode = uint_member(prim, "mode", 4, what);
    if (mode > 6) fail(fmt::format("{}: unknown mode {}", what, mode));
    std::uint64_t count = pos.count;
    if (prim.contains("indices")) {
      const std::uint64_t a = index(prim, "indices", "accessors", what);
      check_indices(a, pos.count, what);
      count = accessors_[a].count;
    }
    if (mode == 4 && count % 3 != 0)
      fail(fmt::format("{}: {} {} is not a multiple of 3 (triangles)", what, count,
                       prim.contains("indices") ? "indices" : "vertices"));
    if (prim.contains("material")) {
      const std::uint64_t mi = index(prim, "material", "materials", what);
      const NeededSet& need = material_needs_[mi];
      if (need.needed && need.set >= uv_sets)
        fail(fmt::format("{}: its material {} reads {} at TEXCOORD_{}, which the primitive does not have ({} UV sets)", what,
                         mi, need.texture, need.set, uv_sets));
    }
    check_draco(prim, what);
    const json* targets = typed(prim, "targets", json::value_t::array, what);
    if (targets == nullptr) return 0;
    if (targets->empty()) fail(what + ": targets is an empty array");
    for (std::size_t t = 0; t < targets->size(); ++t) {
      const json& target = (*targets)[t];
      const std::string tw = fmt::format("{} morph target {}", what, t);
      if (!target.is_object() || target.empty()) fail(tw + " is not an object of attributes");
      for (const auto& [name, value] : target.items()) {
        if (!value.is_number_unsigned() || value.get<std::uint64_t>() >= accessors_.size())
          fail(fmt::format("{}: attribute {} names no accessor (the file has {})", tw, name, accessors_.size()));
        const Accessor& a = accessors_[value.get<std::uint64_t>()];
        if (a.count != pos.count)
          fail(fmt::format("{}: {} has {} elements, POSITION {}", tw, name, a.count, pos.count));
        if ((name == "POSITION" || name == "NORMAL") && (a.type != "VEC3" || a.component_type != 5126))
          fail(fmt::format("{}: {} is not float VEC3", tw, name));
      }
    }
    return targets->size();
  }

  // KHR_draco_mesh_compression: a primitive may carry only the compressed
  // data, its accessors without buffer views (read as zeros): prt does not
  // decode Draco, so only a primitive with the uncompressed fallback is read.
  void check_draco(const json& prim, const std::string& what) {
    const json* ext = typed(prim, "extensions", json::value_t::object, what);
    if (ext == nullptr || !ext->contains("KHR_draco_mesh_compression")) return;
    for (const auto& [name, value] : prim["attributes"].items())
      if (!accessors_[value.get<std::uint64_t>()].view)
        fail(fmt::format("{}: {} is KHR_draco_mesh_compression data only (no buffer view), which prt cannot decode; "
                         "export without Draco compression",
                         what, name));
  }

  // A node's own properties: indices, and its transform as the schema
  // types it (a matrix of 16 numbers or translation 3, rotation a unit
  // quaternion of 4, scale 3; not both).
  void check_node(const json& node, std::size_t i) {
    const std::string what = fmt::format("node {}", i);
    if (node.contains("mesh")) index(node, "mesh", "meshes", what);
    if (node.contains("camera")) index(node, "camera", "cameras", what);
    if (node.contains("skin")) {
      index(node, "skin", "skins", what);
      if (!node.contains("mesh")) fail(what + " has a skin but no mesh");
    }
    const std::vector<double> matrix = numbers(node, "matrix", 16, what);
    numbers(node, "translation", 3, what);
    numbers(node, "scale", 3, what);
    const std::vector<double> q = numbers(node, "rotation", 4, what, -1, 1);
    if (!q.empty()) {
      const double len = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (std::abs(len - 1) > kUnitTolerance)
        fail(fmt::format("{}: rotation is not a unit quaternion (length {:.6g})", what, len));
    }
    if (!matrix.empty() && (node.contains("translation") || node.contains("rotation") || node.contains("scale")))
      fail(what + " has both a matrix and translation, rotation or scale (glTF allows one or the other)");
    if (node.contains("weights")) {
      const std::vector<double> w = numbers(node, "weights", kAnyLength, what);
      const std::size_t targets = node.contains("mesh") ? mesh_targets_[node["mesh"].get<std::size_t>()] : 0;
      if (w.size() != targets || targets == 0)
        fail(fmt::format("{}: weights has {} entries, its mesh {} morph targets", what, w.size(), targets));
    }
  }

  void check_nodes() {
    const json& nodes = array("nodes");
    const std::size_t n = nodes.size();
    std::vector<std::int64_t> parent(n, -1);
    for (std::size_t i = 0; i < n; ++i) {
      check_node(nodes[i], i);
      const auto ch = nodes[i].find("children");
      if (ch == nodes[i].end()) continue;
      if (!ch->is_array() || ch->empty()) wrong(fmt::format("node {}", i), "children", "a non-empty array of node indices", *ch);
      for (const json& c : *ch) {
        if (!c.is_number_unsigned() || c.get<std::uint64_t>() >= n)
          fail(fmt::format("node {}: children holds {}, which is not a node (the file has {} nodes)", i, shown(c), n));
        const std::size_t k = c.get<std::size_t>();
        if (parent[k] >= 0 || k == i)
          fail(fmt::format("node {} has more than one parent, or is its own (the node hierarchy must be a tree)", k));
        parent[k] = std::int64_t(i);
      }
    }
    // Every node reachable from a root, at most kMaxNodeDepth below it;
    // any node not reached is on a cycle.
    std::vector<std::uint32_t> depth(n, 0);
    std::vector<char> seen(n, 0);
    std::vector<std::size_t> todo;
    for (std::size_t i = 0; i < n; ++i)
      if (parent[i] < 0) todo.push_back(i);
    while (!todo.empty()) {
      const std::size_t i = todo.back();
      todo.pop_back();
      seen[i] = 1;
      if (depth[i] > kMaxNodeDepth)
        fail(fmt::format("the node hierarchy is deeper than {} levels (node {}); prt reads at most {}", kMaxNodeDepth, i,
                         kMaxNodeDepth));
      if (const auto ch = nodes[i].find("children"); ch != nodes[i].end())
        for (const json& c : *ch) {
          depth[c.get<std::size_t>()] = depth[i] + 1;
          todo.push_back(c.get<std::size_t>());
        }
    }
    for (std::size_t i = 0; i < n; ++i)
      if (!seen[i]) fail(fmt::format("node {} is its own ancestor (a cycle in the node hierarchy)", i));
    const json& scenes = array("scenes");
    for (std::size_t s = 0; s < scenes.size(); ++s) {
      const std::string what = fmt::format("scene {}", s);
      if (scenes[s].contains("nodes") && !scenes[s]["nodes"].is_array()) fail(what + ": nodes is not an array");
      for (std::uint64_t root : index_list(scenes[s], "nodes", "nodes", what))
        if (parent[root] >= 0)
          fail(fmt::format("{}: node {} is a child of node {}, so it cannot be a root of the scene (nodes form strict "
                           "trees)",
                           what, root, parent[root]));
    }
    if (doc_.contains("scene")) index(doc_, "scene", "scenes", "the default scene");
  }

  void check_animations() {
    const json& animations = array("animations");
    for (std::size_t i = 0; i < animations.size(); ++i) {
      const json& an = animations[i];
      const std::string what = fmt::format("animation {}", i);
      const json* samplers = typed(an, "samplers", json::value_t::array, what);
      const json* channels = typed(an, "channels", json::value_t::array, what);
      if (!samplers || samplers->empty() || !channels || channels->empty()) fail(what + " has no channels or samplers");
      for (std::size_t k = 0; k < samplers->size(); ++k) {
        const json& s = (*samplers)[k];
        const std::string w = fmt::format("{} sampler {}", what, k);
        if (!s.is_object() || !s.contains("input") || !s.contains("output")) fail(w + " has no input or output");
        const Accessor& input = accessors_[index(s, "input", "accessors", w)];
        const Accessor& output = accessors_[index(s, "output", "accessors", w)];
        string_enum(s, "interpolation", {"LINEAR", "STEP", "CUBICSPLINE"}, w);
        if (input.type != "SCALAR" || input.component_type != 5126)
          fail(fmt::format("{}: its input (key frame times) is {} of componentType {}, not float SCALAR", w, input.type,
                           input.component_type));
        // One output per key frame (three for CUBICSPLINE: in-tangent, value,
        // out-tangent), times the morph targets for weights.
        const std::uint64_t per = s.value("interpolation", "LINEAR") == "CUBICSPLINE" ? 3 : 1;
        if (output.count % (per * input.count) != 0)
          fail(fmt::format("{}: {} outputs for {} key frames (a multiple of {})", w, output.count, input.count,
                           per * input.count));
      }
      for (std::size_t k = 0; k < channels->size(); ++k) {
        const json& c = (*channels)[k];
        const std::string w = fmt::format("{} channel {}", what, k);
        if (!c.is_object() || !c.contains("sampler")) fail(w + " has no sampler");
        if (uint_member(c, "sampler", 0, w) >= samplers->size())
          fail(fmt::format("{}: sampler {} is out of range (the animation has {})", w, c["sampler"].get<std::uint64_t>(),
                           samplers->size()));
        const json* target = typed(c, "target", json::value_t::object, w);
        if (target == nullptr) fail(w + " has no target");
        if (target->contains("node")) index(*target, "node", "nodes", w + " target");
        string_enum(*target, "path", {"translation", "rotation", "scale", "weights"}, w + " target", true);
      }
    }
  }

  void check_cameras() {
    const json& cameras = array("cameras");
    for (std::size_t i = 0; i < cameras.size(); ++i) {
      const json& c = cameras[i];
      const std::string what = fmt::format("camera {}", i);
      string_enum(c, "type", {"perspective", "orthographic"}, what, true);
      const char* type = c["type"].get<std::string>() == "perspective" ? "perspective" : "orthographic";
      const json* p = typed(c, type, json::value_t::object, what);
      if (p == nullptr) fail(fmt::format("{} has no {} object", what, type));
      const std::string w = what + " " + type;
      static constexpr std::array<const char*, 2> perspective = {"yfov", "znear"};
      static constexpr std::array<const char*, 4> orthographic = {"xmag", "ymag", "zfar", "znear"};
      const std::span<const char* const> required =
          std::string_view(type) == "perspective" ? std::span<const char* const>(perspective) : orthographic;
      for (const char* key : required)
        if (!p->contains(key)) fail(fmt::format("{} has no {}", w, key));
      number(*p, "yfov", 1, w, std::numeric_limits<double>::min());
      number(*p, "aspectRatio", 1, w, std::numeric_limits<double>::min());
      number(*p, "znear", 1, w, std::string_view(type) == "perspective" ? std::numeric_limits<double>::min() : 0.0);
      number(*p, "zfar", 1, w, std::numeric_limits<double>::min());
      number(*p, "xmag", 1, w);
      number(*p, "ymag", 1, w);
    }
  }

  std::string path_;
  std::uint64_t size_;
  bool binary_;
  bool has_bin_ = false;
  std::uint64_t bin_offset_ = 0, bin_length_ = 0;
  json doc_;
  std::vector<Buffer> buffers_;
  std::vector<View> views_;
  std::vector<Accessor> accessors_;
  struct NeededSet {  // the highest UV set a material's textures read
    std::uint64_t set = 0;
    std::string texture;  // which, for messages
    bool needed = false;
  };
  std::vector<NeededSet> material_needs_;
  std::vector<std::size_t> mesh_targets_;  // morph targets per mesh
  std::set<std::string> checked_arrays_;
  std::ifstream open_;
  std::string open_name_;
};

}  // namespace

void check_gltf(const std::string& path, std::uint64_t size, bool binary) { GltfCheck(path, size, binary).run(); }

bool percent_decode(std::string_view uri, std::string& out) {
  const auto hex = [](char c) {
    return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1;
  };
  out.clear();
  for (std::size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] != '%') {
      out += uri[i];
      continue;
    }
    if (i + 2 >= uri.size() || hex(uri[i + 1]) < 0 || hex(uri[i + 2]) < 0) return false;
    const char c = char(hex(uri[i + 1]) * 16 + hex(uri[i + 2]));
    if (c == '\0') return false;
    out += c;
    i += 2;
  }
  return true;
}

}  // namespace prt::detail
