#include <prt/envmap.h>

#include <prt/error.h>
#include <prt/io.h>
#include <prt/names.h>

#include "image_io.h"

#include <fmt/format.h>

#include <tbb/parallel_for.h>


#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

namespace prt {

// ---- lat-long -----------------------------------------------------------

glm::dvec3 latlong_direction(double px, double py, int width, int height) {
  const double theta = M_PI * py / height, phi = 2.0 * M_PI * px / width;
  const double st = std::sin(theta);
  return {-st * std::sin(phi), std::cos(theta), st * std::cos(phi)};
}

void latlong_pixel(const glm::dvec3& d, int width, int height, double& px, double& py) {
  const double r = glm::length(d);
  const double theta = std::acos(std::clamp(d.y / r, -1.0, 1.0));
  double phi = std::atan2(-d.x, d.z);  // sin(phi) ~ -x, cos(phi) ~ z
  if (phi < 0) phi += 2.0 * M_PI;
  px = phi / (2.0 * M_PI) * width;
  if (px >= width) px -= width;
  py = theta / M_PI * height;
}

double latlong_pixel_solid_angle(int y, int width, int height) {
  const double t0 = M_PI * y / height, t1 = M_PI * (y + 1) / height;
  // cos t0 - cos t1 = 2 sin((t0+t1)/2) sin((t1-t0)/2): no cancellation near the poles.
  return 2.0 * std::sin(0.5 * (t0 + t1)) * std::sin(0.5 * (t1 - t0)) * 2.0 * M_PI / width;
}

// ---- cube maps ----------------------------------------------------------

std::string_view cube_face_name(int face) {
  static constexpr std::string_view names[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
  PRT_CHECK(face >= 0 && face < 6);
  return names[face];
}

glm::dvec3 cube_direction(int face, double s, double t) {
  switch (face) {
    case kPosX: return {1.0, -t, -s};
    case kNegX: return {-1.0, -t, s};
    case kPosY: return {s, 1.0, t};
    case kNegY: return {s, -1.0, -t};
    case kPosZ: return {s, -t, 1.0};
    case kNegZ: return {-s, -t, -1.0};
  }
  PRT_CHECK(face >= 0 && face < 6);
  return {};
}

glm::dvec3 cube_texel_direction(int face, int u, int v, int N) {
  return glm::normalize(cube_direction(face, 2.0 * (u + 0.5) / N - 1.0, 2.0 * (v + 0.5) / N - 1.0));
}

int cube_face_coords(const glm::dvec3& d, double& s, double& t) {
  const double ax = std::abs(d.x), ay = std::abs(d.y), az = std::abs(d.z);
  // Inverse of cube_direction: (sc, tc, major axis) per face, as in the GL spec.
  if (ax >= ay && ax >= az) {
    if (d.x > 0) { s = -d.z / ax; t = -d.y / ax; return kPosX; }
    s = d.z / ax; t = -d.y / ax; return kNegX;
  }
  if (ay >= az) {
    if (d.y > 0) { s = d.x / ay; t = d.z / ay; return kPosY; }
    s = d.x / ay; t = -d.z / ay; return kNegY;
  }
  if (d.z > 0) { s = d.x / az; t = -d.y / az; return kPosZ; }
  s = -d.x / az; t = -d.y / az; return kNegZ;
}

double cube_texel_solid_angle(int u, int v, int N) {
  auto area = [](double x, double y) { return std::atan2(x * y, std::sqrt(x * x + y * y + 1.0)); };
  const double x0 = 2.0 * u / N - 1.0, x1 = 2.0 * (u + 1) / N - 1.0;
  const double y0 = 2.0 * v / N - 1.0, y1 = 2.0 * (v + 1) / N - 1.0;
  return area(x0, y0) - area(x0, y1) - area(x1, y0) + area(x1, y1);
}

// ---- mappings -------------------------------------------------------------

namespace {
// The option names parse_mapping takes, and the words mapping_name describes a layout with.
constexpr EnumName<Mapping> kMappingOptions[] = {
    {Mapping::Auto, "auto"},     {Mapping::LatLong, "latlong"}, {Mapping::HCross, "hcross"},
    {Mapping::VCross, "vcross"}, {Mapping::Faces, "faces"},
};
constexpr EnumName<Mapping> kMappingNames[] = {
    {Mapping::Auto, "auto"},
    {Mapping::LatLong, "lat-long"},
    {Mapping::HCross, "horizontal cross"},
    {Mapping::VCross, "vertical cross"},
    {Mapping::Faces, "cube faces"},
};
}  // namespace

Mapping parse_mapping(std::string_view name) { return parse_enum(kMappingOptions, name, "mapping"); }

std::string_view mapping_name(Mapping m) { return enum_name(kMappingNames, m); }

void StatsAccumulator::Run::add(const float* rgb, std::size_t first, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    bool neg = false, bad = false;
    for (int c = 0; c < 3; ++c) {
      const float v = rgb[3 * i + c];
      if (!std::isfinite(v)) {
        bad = true;
        continue;
      }
      neg |= v < 0.0f;
      min = std::min(min, double(v));
      max = std::max(max, double(v));
      sum += v;
      ++finite;
    }
    negative += neg;
    if (bad) {
      if (nonfinite == 0) first_nonfinite = static_cast<long>(first + i);
      ++nonfinite;
    }
  }
}

void StatsAccumulator::Run::merge(const Run& later) {
  sum += later.sum;
  min = std::min(min, later.min);
  max = std::max(max, later.max);
  finite += later.finite;
  negative += later.negative;
  if (first_nonfinite < 0) first_nonfinite = later.first_nonfinite;
  nonfinite += later.nonfinite;
}

void StatsAccumulator::add(const float* rgb, std::size_t pixels) {
  constexpr std::size_t kRun = 65536;
  if (pixels == 0) return;
  const std::size_t begin = pixels_, end = pixels_ + pixels;
  const std::size_t r0 = begin / kRun, r1 = (end + kRun - 1) / kRun;
  std::vector<Run> runs(r1 - r0);
  runs[0] = open_;  // empty when the last piece ended a run
  tbb::parallel_for(r0, r1, [&](std::size_t r) {
    const std::size_t a = std::max(begin, r * kRun), b = std::min(end, (r + 1) * kRun);
    runs[r - r0].add(rgb + 3 * (a - begin), a, b - a);
  });
  open_ = Run{};
  for (std::size_t r = r0; r < r1; ++r) {
    if ((r + 1) * kRun <= end)
      done_.merge(runs[r - r0]);
    else
      open_ = runs[r - r0];
  }
  pixels_ = end;
}

MapStats StatsAccumulator::result() const {
  Run all = done_;
  all.merge(open_);
  MapStats s;
  s.pixels = pixels_;
  s.negative = all.negative;
  s.nonfinite = all.nonfinite;
  s.first_nonfinite = all.first_nonfinite;
  if (all.finite > 0) {
    s.min = all.min;
    s.max = all.max;
    s.mean = all.sum / double(all.finite);
  }
  return s;
}

MapStats compute_stats(const float* rgb, std::size_t pixels) {
  StatsAccumulator acc;
  acc.add(rgb, pixels);
  return acc.result();
}

namespace {

namespace fs = std::filesystem;

using detail::RawImage;

RawImage read_image_rgb(const std::string& path) { return detail::read_image_file(path); }

void copy_face(const RawImage& img, int x0, int y0, int N, bool rotate180, float* dst) {
  for (int v = 0; v < N; ++v)
    for (int u = 0; u < N; ++u) {
      const int su = rotate180 ? N - 1 - u : u, sv = rotate180 ? N - 1 - v : v;
      const float* s = &img.rgb[(std::size_t(y0 + sv) * img.width + (x0 + su)) * 3];
      std::copy(s, s + 3, dst + (std::size_t(v) * N + u) * 3);
    }
}

std::string shape_string(const RawImage& img) {
  return fmt::format("{}x{}", img.width, img.height);
}

}  // namespace

EnvMap make_latlong(int width, int height, std::vector<float> rgb, std::string source) {
  if (width <= 0 || height <= 0 || rgb.size() != std::size_t(width) * height * 3)
    throw Error(source + ": lat-long map needs width*height*3 values");
  EnvMap m;
  m.layout = Mapping::LatLong;
  m.width = width;
  m.height = height;
  m.rgb = std::move(rgb);
  m.source = std::move(source);
  m.source_layout = "lat-long";
  m.stats = compute_stats(m.rgb.data(), m.pixel_count());
  return m;
}

EnvMap make_cube(int size, std::vector<float> rgb, std::string source) {
  if (size <= 0 || rgb.size() != std::size_t(6) * size * size * 3)
    throw Error(source + ": cube map needs 6*size*size*3 values");
  EnvMap m;
  m.layout = Mapping::Faces;
  m.width = m.height = size;
  m.rgb = std::move(rgb);
  m.source = std::move(source);
  m.source_layout = "cube faces";
  m.stats = compute_stats(m.rgb.data(), m.pixel_count());
  return m;
}

Mapping mapping_of_shape(const std::string& path, int W, int H, Mapping mapping) {
  const std::string shape = fmt::format("{}x{}", W, H);
  switch (mapping) {
    case Mapping::Auto:
      if (W == 2 * H) return Mapping::LatLong;
      if (3 * W == 4 * H && W % 4 == 0) return Mapping::HCross;
      if (4 * W == 3 * H && W % 3 == 0) return Mapping::VCross;
      throw Error(path + ": cannot tell the mapping from a " + shape +
                  " image (expected 2:1 lat-long, 4:3 horizontal cross or 3:4 vertical cross; use --mapping)");
    case Mapping::LatLong:
      if (W != 2 * H) throw Error(path + ": a lat-long map must be twice as wide as high, this one is " + shape);
      return mapping;
    case Mapping::HCross:
    case Mapping::VCross: {
      const bool h = mapping == Mapping::HCross;
      const int N = h ? W / 4 : W / 3;
      if (N == 0 || (h ? (W != 4 * N || H != 3 * N) : (W != 3 * N || H != 4 * N)))
        throw Error(path + ": a " + std::string(mapping_name(mapping)) + " must be " + (h ? "4N x 3N" : "3N x 4N") +
                    " pixels, this one is " + shape);
      return mapping;
    }
    case Mapping::Faces:
      break;
  }
  throw Error(path + ": --mapping faces needs six face files (+X,-X,+Y,-Y,+Z,-Z)");
}

EnvMap load_envmap(const std::string& path, Mapping mapping) {
  RawImage img = read_image_rgb(path);
  const int W = img.width, H = img.height;
  mapping = mapping_of_shape(path, W, H, mapping);
  EnvMap m;
  if (mapping == Mapping::LatLong) {
    m = make_latlong(W, H, std::move(img.rgb), path);
  } else {
    const bool h = mapping == Mapping::HCross;
    const int N = h ? W / 4 : W / 3;
    // Face positions in the cross, in units of N: {column, row}.
    static constexpr int hpos[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}};
    static constexpr int vpos[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {1, 3}};
    std::vector<float> faces(std::size_t(6) * N * N * 3);
    for (int f = 0; f < 6; ++f) {
      const int* p = h ? hpos[f] : vpos[f];
      copy_face(img, p[0] * N, p[1] * N, N, !h && f == kNegZ, faces.data() + std::size_t(f) * N * N * 3);
    }
    m = make_cube(N, std::move(faces), path);
  }
  m.source_layout = std::string(mapping_name(mapping));
  m.source_channels = img.channels;
  return m;
}

EnvMap load_cube_faces(const std::array<std::string, 6>& paths) {
  int N = 0;
  std::vector<float> faces;
  int channels = 3;
  for (int f = 0; f < 6; ++f) {
    RawImage img = read_image_rgb(paths[f]);
    if (img.width != img.height)
      throw Error(paths[f] + ": cube face " + std::string(cube_face_name(f)) + " must be square, this one is " +
                  shape_string(img));
    if (f == 0) {
      N = img.width;
      faces.resize(std::size_t(6) * N * N * 3);
      channels = img.channels;
    } else if (img.width != N) {
      throw Error(paths[f] + ": cube face " + std::string(cube_face_name(f)) + " is " + shape_string(img) +
                  " but " + paths[0] + " is " + fmt::format("{}x{}", N, N));
    }
    std::copy(img.rgb.begin(), img.rgb.end(), faces.begin() + std::size_t(f) * N * N * 3);
  }
  EnvMap m = make_cube(N, std::move(faces), paths[0] + " (+5 faces)");
  m.source_channels = channels;
  return m;
}

void require_finite(const EnvMap& map) {
  if (map.stats.nonfinite == 0) return;
  std::string s = fmt::format("{}: {} pixel(s) are NaN or infinite", map.source, map.stats.nonfinite);
  const long i = map.stats.first_nonfinite;
  if (map.is_cube()) {
    const long n = long(map.width) * map.width;
    s += fmt::format(" (first: face {}, x {}, y {})", cube_face_name(int(i / n)), (i % n) % map.width,
                     (i % n) / map.width);
  } else {
    s += fmt::format(" (first at x {}, y {})", i % map.width, i / map.width);
  }
  s += "; fix the map (e.g. oiiotool --fixnan black) before projecting";
  throw Error(s);
}

std::string describe(const EnvMap& m) {
  std::string s = m.source + ": ";
  if (m.is_cube())
    s += fmt::format("cube map, faces {}x{} (from {})", m.width, m.width, m.source_layout);
  else
    s += fmt::format("{}x{} lat-long", m.width, m.height);
  s += fmt::format(", {} channel{}, min {:g}, max {:g}, mean {:g}, {} negative, {} non-finite pixels", m.source_channels,
                   m.source_channels == 1 ? "" : "s", m.stats.min, m.stats.max, m.stats.mean, m.stats.negative,
                   m.stats.nonfinite);
  return s;
}

namespace {
std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}
}  // namespace

std::string image_output_type_problem(const std::string& path) {
  // What write_image writes: EXR itself, the rest through OpenImageIO's
  // writers (which have none for PFM, only a reader).
  static const char* known[] = {".exr", ".hdr", ".tif", ".tiff", ".png", ".jpg", ".jpeg", ".bmp", ".tga"};
  const std::string ext = lower_extension(path);
  if (std::find_if(std::begin(known), std::end(known), [&](const char* k) { return ext == k; }) == std::end(known))
    return path + ": unknown image type '" + ext + "' (use .exr for linear HDR, or .hdr, .tif, .png, .jpg, .bmp, .tga)";
  return {};
}

void check_image_output(const std::string& path) {
  if (const std::string problem = image_output_type_problem(path); !problem.empty()) throw Error(problem);
  check_writable(path);
}

void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb) {
  PRT_CHECK_OP(rgb.size(), ==, std::size_t(width) * height * 3);
  const std::string ext = lower_extension(path);
  const bool floating = ext == ".exr" || ext == ".hdr" || ext == ".tif" || ext == ".tiff" || ext == ".pfm";
  write_atomically(path, [&](const std::string& tmp) { detail::write_image_file(tmp, path, width, height, rgb, floating); });
}

void write_exr_rgba(const std::string& path, const RgbaImage& image) {
  if (lower_extension(path) != ".exr") throw Error(path + ": an RGBA image is written as EXR (.exr)");
  PRT_CHECK_OP(image.rgba.size(), ==, std::size_t(image.width) * image.height * 4);
  PRT_CHECK(image.std_error.empty() || image.std_error.size() == std::size_t(image.width) * image.height * 3);
  write_atomically(path, [&](const std::string& tmp) {
    detail::write_exr_rgba(tmp, path, image.width, image.height, image.rgba, image.std_error);
  });
}

RgbaImage read_exr_rgba(const std::string& path) {
  check_input_file(path, "an EXR image");
  if (lower_extension(path) != ".exr") throw Error(path + ": expected an EXR image (.exr)");
  detail::RgbaImage raw = detail::read_exr_rgba(path);
  RgbaImage out;
  out.width = raw.width;
  out.height = raw.height;
  out.has_alpha = raw.has_alpha;
  out.rgba = std::move(raw.rgba);
  out.std_error = std::move(raw.std_error);
  return out;
}

}  // namespace prt
