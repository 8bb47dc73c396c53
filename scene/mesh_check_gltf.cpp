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
// hierarchy must be a forest (Assimp recurses through it).

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

namespace prt::detail {

namespace {

using json = nlohmann::json;

constexpr int kMaxJsonDepth = 64;  // glTF needs ~8; Assimp's JSON parser recurses

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
    check_buffers();
    check_views();
    check_accessors();
    check_meshes();
    check_nodes();
    check_skins();
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

  void parse(const std::string& text) {
    try {
      const json::parser_callback_t depth = [this](int d, json::parse_event_t, json&) {
        if (d > kMaxJsonDepth) fail(fmt::format("its JSON nests deeper than {} levels", kMaxJsonDepth));
        return true;
      };
      doc_ = json::parse(text, depth);
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

  // The array `key` of the root (empty when absent); its entries must be objects.
  const json& array(const char* key) const {
    static const json empty = json::array();
    const auto it = doc_.find(key);
    if (it == doc_.end()) return empty;
    if (!it->is_array()) fail(fmt::format("'{}' is not an array", key));
    for (std::size_t i = 0; i < it->size(); ++i)
      if (!(*it)[i].is_object()) fail(fmt::format("{}[{}] is not an object", key, i));
    return *it;
  }

  // An index into the root array `target`.
  std::uint64_t index(const json& obj, const char* key, const char* target, const std::string& what) const {
    const std::uint64_t i = uint_member(obj, key, 0, what);
    if (i >= array(target).size())
      fail(fmt::format("{}: {} {} is out of range (the file has {} {})", what, key, i, array(target).size(), target));
    return i;
  }

  void check_asset() {
    const auto it = doc_.find("asset");
    if (it == doc_.end() || !it->is_object() || !it->contains("version") || !(*it)["version"].is_string())
      fail("has no asset.version (not a glTF file?)");
    const std::string v = (*it)["version"].get<std::string>();
    if (v.rfind("1", 0) == 0) fail(fmt::format("glTF {}; prt reads glTF 2.0", v));
    if (v.rfind("2", 0) != 0) fail(fmt::format("glTF version '{}'; prt reads glTF 2.0", v.substr(0, 20)));
    if (const auto req = doc_.find("extensionsRequired"); req != doc_.end() && req->is_array())
      for (const json& e : *req) {
        const std::string name = e.is_string() ? e.get<std::string>() : e.dump();
        const bool harmless = name.rfind("KHR_materials_", 0) == 0 || name == "KHR_texture_transform" ||
                              name == "KHR_lights_punctual" || name == "KHR_texture_basisu" ||
                              name == "EXT_texture_webp";
        if (!harmless) fail(fmt::format("requires the extension {}, which prt cannot read", name.substr(0, 60)));
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
          // Where Assimp looks: the glTF file's directory + the URI, as written.
          std::string dir = std::filesystem::path(path_).parent_path().string();
          if (!dir.empty() && dir.back() != '/') dir += '/';
          buf.source = Buffer::File;
          buf.file = dir + u;
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
      if (view.stride != 0 && (view.stride < 4 || view.stride > 252))
        fail(fmt::format("{}: byteStride {} is outside 4..252", what, view.stride));
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
  };

  // Throws unless `count` elements of `elem` bytes, `stride` apart, from
  // `offset` fit in buffer view `view`.
  void check_fits(std::uint64_t view, std::uint64_t offset, std::uint64_t count, std::uint64_t elem,
                  std::uint64_t stride, const std::string& what) const {
    const View& v = views_[view];
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
      acc.offset = uint_member(a, "byteOffset", 0, what);
      if (a.contains("bufferView")) {
        acc.view = index(a, "bufferView", "bufferViews", what);
        check_fits(*acc.view, acc.offset, acc.count, csize * acc.components, views_[*acc.view].stride, what);
      }
      if (const auto sp = a.find("sparse"); sp != a.end()) {
        if (!sp->is_object()) fail(what + ": sparse is not an object");
        acc.sparse = true;
        const std::uint64_t n = required_uint(*sp, "count", what + " sparse");
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

  void check_meshes() {
    const json& meshes = array("meshes");
    for (std::size_t m = 0; m < meshes.size(); ++m) {
      const auto prims = meshes[m].find("primitives");
      if (prims == meshes[m].end() || !prims->is_array()) fail(fmt::format("mesh {} has no primitives", m));
      for (std::size_t p = 0; p < prims->size(); ++p) {
        const json& prim = (*prims)[p];
        const std::string what = fmt::format("mesh {} primitive {}", m, p);
        if (!prim.is_object()) fail(what + " is not an object");
        const auto attrs = prim.find("attributes");
        if (attrs == prim.end() || !attrs->is_object() || !attrs->contains("POSITION"))
          fail(what + " has no POSITION attribute");
        for (const auto& [name, value] : attrs->items()) {
          if (!value.is_number_unsigned() || value.get<std::uint64_t>() >= accessors_.size())
            fail(fmt::format("{}: attribute {} names no accessor (the file has {})", what, name, accessors_.size()));
        }
        const Accessor& pos = accessors_[(*attrs)["POSITION"].get<std::uint64_t>()];
        if (pos.type != "VEC3" || pos.component_type != 5126)
          fail(fmt::format("{}: POSITION is {} of componentType {}, not float VEC3", what, pos.type,
                           pos.component_type));
        if (attrs->contains("NORMAL")) {
          const Accessor& n = accessors_[(*attrs)["NORMAL"].get<std::uint64_t>()];
          if (n.type != "VEC3" || n.component_type != 5126 || n.count != pos.count)
            fail(fmt::format("{}: NORMAL is not float VEC3 with one per position", what));
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
      }
    }
  }

  void check_nodes() {
    const json& nodes = array("nodes");
    const std::size_t n = nodes.size();
    std::vector<std::int64_t> parent(n, -1);
    for (std::size_t i = 0; i < n; ++i) {
      const std::string what = fmt::format("node {}", i);
      if (nodes[i].contains("mesh")) index(nodes[i], "mesh", "meshes", what);
      const auto ch = nodes[i].find("children");
      if (ch == nodes[i].end()) continue;
      if (!ch->is_array()) fail(what + ": children is not an array");
      for (const json& c : *ch) {
        if (!c.is_number_unsigned() || c.get<std::uint64_t>() >= n)
          fail(fmt::format("{}: child {} is out of range (the file has {} nodes)", what, c.dump().substr(0, 20), n));
        const std::size_t k = c.get<std::size_t>();
        if (parent[k] >= 0 || k == i)
          fail(fmt::format("node {} has more than one parent, or is its own (the node hierarchy must be a tree)", k));
        parent[k] = std::int64_t(i);
      }
    }
    // Every node reachable from a root; any other is on a cycle.
    std::vector<char> seen(n, 0);
    std::vector<std::size_t> todo;
    for (std::size_t i = 0; i < n; ++i)
      if (parent[i] < 0) todo.push_back(i);
    while (!todo.empty()) {
      const std::size_t i = todo.back();
      todo.pop_back();
      seen[i] = 1;
      if (const auto ch = nodes[i].find("children"); ch != nodes[i].end())
        for (const json& c : *ch) todo.push_back(c.get<std::size_t>());
    }
    for (std::size_t i = 0; i < n; ++i)
      if (!seen[i]) fail(fmt::format("node {} is its own ancestor (a cycle in the node hierarchy)", i));
    const json& scenes = array("scenes");
    for (std::size_t s = 0; s < scenes.size(); ++s)
      if (const auto sn = scenes[s].find("nodes"); sn != scenes[s].end()) {
        if (!sn->is_array()) fail(fmt::format("scene {}: nodes is not an array", s));
        for (const json& c : *sn)
          if (!c.is_number_unsigned() || c.get<std::uint64_t>() >= n)
            fail(fmt::format("scene {}: node {} is out of range (the file has {} nodes)", s, c.dump().substr(0, 20), n));
      }
    if (doc_.contains("scene")) index(doc_, "scene", "scenes", "the default scene");
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
  std::ifstream open_;
  std::string open_name_;
};

}  // namespace

void check_gltf(const std::string& path, std::uint64_t size, bool binary) { GltfCheck(path, size, binary).run(); }

}  // namespace prt::detail
