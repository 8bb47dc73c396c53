// Vertex CSV files: see prt/vertex_csv.h.
#include <prt/vertex_csv.h>

#include <prt/error.h>
#include <prt/io.h>
#include <prt/mesh.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <string_view>

namespace prt {

namespace {

constexpr std::string_view kHeader = "vertex,r,g,b";
constexpr std::string_view kHeaderSe = "vertex,r,g,b,se_r,se_g,se_b";
constexpr std::string_view kPointHeader = "point,r,g,b";
constexpr std::string_view kPointHeaderSe = "point,r,g,b,se_r,se_g,se_b";

// %.9g: nine significant digits, so every float reads back exactly.
void append_value(std::string& s, float v) { fmt::format_to(std::back_inserter(s), "{:.9g}", double(v)); }

[[noreturn]] void fail(const std::string& path, std::size_t line, const std::string& what) {
  throw Error(fmt::format("{}:{}: {}", path, line, what));
}

// The whole of a text file (not a FIFO or /dev/zero: check_input_file).
std::string read_text(const std::string& path, std::string_view kind) {
  check_input_file(path, kind);
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open for reading");
  std::string text{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  if (f.bad()) throw Error(path + ": read error");
  return text;
}

// Calls f(line number from 1, line without its CR LF) for each line; a
// blank line is allowed only at the end (then the loop stops). Returns the
// number of lines read.
template <typename F>
std::size_t for_each_line(const std::string& path, const std::string& text, F&& f) {
  std::size_t pos = 0, line_no = 0;
  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty() && line_no > 1) {
      if (text.find_first_not_of("\r\n", pos) == std::string::npos) break;
      fail(path, line_no, "blank line");
    }
    f(line_no, line);
  }
  return line_no;
}

}  // namespace

void write_vertex_csv(const std::string& path, const std::vector<glm::vec3>& rgb,
                      const std::vector<glm::vec3>* std_error, CsvKey key) {
  const bool points = key == CsvKey::Point;
  if (std_error) PRT_CHECK_OP(std_error->size(), ==, rgb.size());
  // Every value is checked before anything is written (a device such as
  // /dev/stdout is written in place).
  for (std::size_t v = 0; v < rgb.size(); ++v)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(rgb[v][c]) || (std_error && !std::isfinite((*std_error)[v][c])))
        throw Error(fmt::format("{}: refusing to write a non-finite value at {} {}", path, points ? "point" : "vertex", v));
  // Streamed a block of lines at a time: the text (about 45 bytes per
  // vertex) is never held whole.
  constexpr std::size_t kFlushBytes = std::size_t(1) << 20;
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw Error(path + ": cannot open for writing: " + std::strerror(errno));
    std::string text;
    text.reserve(kFlushBytes + 256);
    text.append(points ? (std_error ? kPointHeaderSe : kPointHeader) : (std_error ? kHeaderSe : kHeader)).push_back('\n');
    for (std::size_t v = 0; v < rgb.size(); ++v) {
      fmt::format_to(std::back_inserter(text), "{}", v);
      for (int c = 0; c < 3; ++c) {
        text.push_back(',');
        append_value(text, rgb[v][c]);
      }
      if (std_error)
        for (int c = 0; c < 3; ++c) {
          text.push_back(',');
          append_value(text, (*std_error)[v][c]);
        }
      text.push_back('\n');
      if (text.size() >= kFlushBytes) {
        f.write(text.data(), std::streamsize(text.size()));
        text.clear();
      }
    }
    f.write(text.data(), std::streamsize(text.size()));
    f.close();
    if (!f) throw Error(path + ": write failed: " + std::strerror(errno));
  });
}

std::vector<glm::vec3> read_vertex_csv(const std::string& path, std::vector<glm::vec3>* std_error, CsvKey* key) {
  const std::string text = read_text(path, "a vertex CSV file");
  std::vector<glm::vec3> rgb;
  if (std_error) std_error->clear();
  bool with_se = false;
  std::string_view what = "vertex";
  const std::size_t lines = for_each_line(path, text, [&](std::size_t line_no, std::string_view line) {
    if (line_no == 1) {
      if (line == kPointHeader || line == kPointHeaderSe) what = "point";
      if (key) *key = what == "point" ? CsvKey::Point : CsvKey::Vertex;
      if (line == kHeaderSe || line == kPointHeaderSe)
        with_se = true;
      else if (line != kHeader && line != kPointHeader)
        fail(path, 1,
             "expected the header '" + std::string(kHeader) + "' or '" + std::string(kHeaderSe) + "', got '" +
                 std::string(line.substr(0, 80)) + "'");
      return;
    }
    const int columns = with_se ? 7 : 4;
    double values[7];
    std::size_t field = 0, start = 0;
    for (int col = 0; col < columns; ++col) {
      const std::size_t comma = line.find(',', start);
      const bool last = col + 1 == columns;
      if (!last && comma == std::string_view::npos)
        fail(path, line_no, fmt::format("expected {} comma-separated fields, got {}", columns, col + 1));
      if (last && comma != std::string_view::npos)
        fail(path, line_no, fmt::format("expected {} comma-separated fields, got more", columns));
      const std::string_view tok = line.substr(start, last ? std::string_view::npos : comma - start);
      start = comma + 1;
      field = std::size_t(col);
      if (col == 0) {
        std::size_t index = 0;
        const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), index);
        if (ec != std::errc() || p != tok.data() + tok.size() || tok.empty())
          fail(path, line_no, fmt::format("{} index '{}' is not a whole number", what, tok.substr(0, 40)));
        if (index != rgb.size())
          fail(path, line_no, fmt::format("expected {} {}, got {}", what, rgb.size(), index));
        continue;
      }
      double x = 0;
      const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), x);
      if (ec != std::errc() || p != tok.data() + tok.size() || tok.empty())
        fail(path, line_no, fmt::format("field {} '{}' is not a number", field + 1, tok.substr(0, 40)));
      if (!std::isfinite(x) || !std::isfinite(float(x)))
        fail(path, line_no, fmt::format("field {} '{}' is not finite (in float)", field + 1, tok.substr(0, 40)));
      values[col] = x;
    }
    rgb.emplace_back(float(values[1]), float(values[2]), float(values[3]));
    if (with_se && std_error) std_error->emplace_back(float(values[4]), float(values[5]), float(values[6]));
  });
  if (lines == 0) throw Error(path + ": empty file (expected the header '" + std::string(kHeader) + "')");
  if (rgb.empty()) throw Error(fmt::format("{}: no {} lines after the header", path, what));
  return rgb;
}

QueryPoints read_points_csv(const std::string& path) {
  const std::string text = read_text(path, "a points CSV file");
  constexpr std::string_view kPoints = "x,y,z,nx,ny,nz";
  QueryPoints q;
  const std::size_t lines = for_each_line(path, text, [&](std::size_t line_no, std::string_view line) {
    if (line_no == 1) {
      if (line != kPoints) fail(path, 1, fmt::format("expected the header '{}', got '{}'", kPoints, line.substr(0, 80)));
      return;
    }
    double v[6];
    std::size_t start = 0;
    for (int col = 0; col < 6; ++col) {
      const std::size_t comma = line.find(',', start);
      const bool last = col == 5;
      if ((!last && comma == std::string_view::npos) || (last && comma != std::string_view::npos))
        fail(path, line_no, "expected 6 comma-separated numbers: x,y,z,nx,ny,nz");
      const std::string_view tok = line.substr(start, last ? std::string_view::npos : comma - start);
      start = comma + 1;
      const auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), v[col]);
      if (ec != std::errc() || p != tok.data() + tok.size() || tok.empty() || !std::isfinite(v[col]))
        fail(path, line_no, fmt::format("field {} '{}' is not a finite number", col + 1, tok.substr(0, 40)));
    }
    // Within the mesh readers' kMaxCoordinate: the points are ray origins
    // (Embree traces in float, and aborts on origins past 1.8e18).
    if (std::max({std::abs(v[0]), std::abs(v[1]), std::abs(v[2])}) > kMaxCoordinate)
      fail(path, line_no,
           fmt::format("point {} ({:g}, {:g}, {:g}) has a coordinate beyond prt's limit of {:g} (|x|, |y|, |z| <= {:g} "
                       "in scene units, as for a mesh's vertices: float ray tracing breaks down past it)",
                       q.positions.size(), v[0], v[1], v[2], kMaxCoordinate, kMaxCoordinate));
    // The normal's direction: scaled by its largest component first, so
    // that neither 1e200 (whose length overflows) nor 1e-200 (whose squares
    // underflow) loses it.
    const double big = std::max({std::abs(v[3]), std::abs(v[4]), std::abs(v[5])});
    if (!(big > 0)) fail(path, line_no, "the normal (nx,ny,nz) is zero");
    const glm::dvec3 n = glm::dvec3(v[3], v[4], v[5]) / big;
    q.positions.emplace_back(v[0], v[1], v[2]);
    q.normals.push_back(n / std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z));
  });
  if (lines == 0) throw Error(path + ": empty file (expected the header 'x,y,z,nx,ny,nz')");
  if (q.positions.empty()) throw Error(path + ": no points after the header");
  return q;
}

}  // namespace prt
