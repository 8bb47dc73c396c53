// prt/envmap.h - environment maps: direction conventions, loading, statistics.
//
// Conventions (docs/CONVENTIONS.md, "Lat-long maps" and "Cube maps"):
// * Lat-long: pixel (x, y), row 0 at the top, is centred on
//   theta = pi (y + 0.5) / H, phi = 2 pi (x + 0.5) / W and looks along
//   d = (-sin(theta) sin(phi), cos(theta), sin(theta) cos(phi)):
//   the image centre looks toward -Z, its top toward +Y.
// * Cube maps: faces +X, -X, +Y, -Y, +Z, -Z (index 0..5) in OpenGL's
//   orientation, row 0 of each face at its top, so faces upload to
//   GL_TEXTURE_CUBE_MAP unchanged. Texel (u, v) of a face of size N has face
//   coordinates s = 2(u + 0.5)/N - 1, t = 2(v + 0.5)/N - 1 and direction
//     +X (1, -t, -s)   -X (-1, -t, s)   +Y (s, 1, t)
//     -Y (s, -1, -t)   +Z (s, -t, 1)    -Z (-s, -t, -1)   (then normalised).
//   Crosses (3N x 4N vertical, 4N x 3N horizontal):
//
//     horizontal 4:3         vertical 3:4
//         +Y                     +Y
//     -X  +Z  +X  -Z         -X  +Z  +X
//         -Y                     -Y
//                                -Z  (stored turned 180 degrees)
//
// Radiance is kept in the file's own linear units (no scaling, no clamping).
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

// ---- lat-long -----------------------------------------------------------
// Direction through the continuous pixel position (px, py) (pixel centres at
// +0.5). Unit length.
glm::dvec3 latlong_direction(double px, double py, int width, int height);
// Inverse: continuous pixel position of a direction (px in [0, W), py in [0, H]).
void latlong_pixel(const glm::dvec3& d, int width, int height, double& px, double& py);
// Exact solid angle of every pixel of row y: (cos th_top - cos th_bottom) 2pi / W.
double latlong_pixel_solid_angle(int y, int width, int height);

// ---- cube maps ----------------------------------------------------------
enum CubeFace : int { kPosX = 0, kNegX, kPosY, kNegY, kPosZ, kNegZ };
std::string_view cube_face_name(int face);  // "+X", ...
// Unnormalised direction of face coordinates (s, t) in [-1, 1]^2.
glm::dvec3 cube_direction(int face, double s, double t);
// Unit direction through the centre of texel (u, v) of a face of size N.
glm::dvec3 cube_texel_direction(int face, int u, int v, int N);
// Face and face coordinates (s, t) in [-1, 1] of a non-zero direction.
int cube_face_coords(const glm::dvec3& d, double& s, double& t);
// Exact solid angle of texel (u, v) of a face of size N, from its corners:
// sum of +-atan2(x y, sqrt(x^2 + y^2 + 1)). The six faces sum to 4 pi.
double cube_texel_solid_angle(int u, int v, int N);

// ---- maps ---------------------------------------------------------------
enum class Mapping { Auto, LatLong, HCross, VCross, Faces };
Mapping parse_mapping(std::string_view name);  // "auto", "latlong", "hcross", "vcross", "faces"
std::string_view mapping_name(Mapping m);

// Summary of a map's pixels: what `prt project` prints to stderr.
struct MapStats {
  double min = 0, max = 0, mean = 0;  // over every finite channel value
  std::size_t pixels = 0;
  std::size_t negative = 0;   // pixels with a channel < 0 (legal HDR data; reported, not clamped)
  std::size_t nonfinite = 0;  // pixels with a NaN or Inf channel
  long first_nonfinite = -1;  // index of the first such pixel, or -1
};

// An environment map in memory, RGB float, linear.
// LatLong: width x height pixels, row-major, row 0 at the top.
// Cube (layout == Faces): six faces of size x size in face order
// (+X, -X, +Y, -Y, +Z, -Z), each row-major with row 0 at the top.
struct EnvMap {
  Mapping layout = Mapping::LatLong;  // LatLong or Faces once loaded
  int width = 0, height = 0;          // a cube's face size is width == height
  std::vector<float> rgb;
  std::string source;                 // file name(s), for messages
  std::string source_layout;          // how the file stored it: "lat-long", "horizontal cross", ...
  int source_channels = 3;
  MapStats stats;

  bool is_cube() const { return layout == Mapping::Faces; }
  std::size_t pixel_count() const { return rgb.size() / 3; }
};

// Loads a map with OpenImageIO (EXR, HDR, PNG, JPEG, TIFF, ... as linear
// floats; 8-bit sRGB files are converted to linear). 1 channel is grey,
// 2 is grey + alpha, 3 or more: the first three are RGB. `Auto` picks the
// mapping from the shape: 2:1 lat-long, 4:3 horizontal cross, 3:4 vertical
// cross. Throws prt::Error naming the file on a missing, unreadable,
// truncated or non-image file and on a shape that does not fit the mapping.
// Non-finite pixels are counted in stats, not rejected here (see require_finite).
EnvMap load_envmap(const std::string& path, Mapping mapping = Mapping::Auto);
// Six face files in the order +X, -X, +Y, -Y, +Z, -Z; square, same size.
EnvMap load_cube_faces(const std::array<std::string, 6>& paths);

// Builds maps from pixels already in memory (for tests and callers that
// generate lighting). Computes stats.
EnvMap make_latlong(int width, int height, std::vector<float> rgb, std::string source = "<memory>");
EnvMap make_cube(int size, std::vector<float> rgb, std::string source = "<memory>");

MapStats compute_stats(const float* rgb, std::size_t pixels);

// compute_stats over pixels fed in order in pieces of any size (a map read in
// blocks of rows): result() is bit-identical to compute_stats of the whole.
// The sum behind the mean runs in double over fixed runs of 65536 pixels
// (counted from the first pixel, whatever the pieces), in parallel, and the
// runs are added in order.
class StatsAccumulator {
 public:
  void add(const float* rgb, std::size_t pixels);
  MapStats result() const;

 private:
  struct Run {
    double sum = 0.0;
    double min = std::numeric_limits<double>::infinity(), max = -std::numeric_limits<double>::infinity();
    std::size_t finite = 0, negative = 0, nonfinite = 0;
    long first_nonfinite = -1;
    void add(const float* rgb, std::size_t first, std::size_t count);  // pixels first .. first + count - 1
    void merge(const Run& later);
  };
  Run done_;  // the completed runs, in order
  Run open_;  // the run the last piece ended in
  std::size_t pixels_ = 0;
};

// The mapping of a width x height image file: `requested`, or for Auto the
// one its shape says (2:1 lat-long, 4:3 horizontal cross, 3:4 vertical
// cross). Throws prt::Error naming `path` and its size when the shape fits
// none of them or not the requested one, and for Faces (six files, not one).
// The check load_envmap makes before it keeps any pixel.
Mapping mapping_of_shape(const std::string& path, int width, int height, Mapping requested);

// Throws prt::Error naming the map when it has NaN or Inf pixels.
void require_finite(const EnvMap& map);

// One line: "forest.exr: 1024x512 lat-long, 3 channels, min ..., max ..., mean ...,
// 12 negative, 0 non-finite pixels".
std::string describe(const EnvMap& map);

// Writes an RGB float image (EXR keeps floats; 8-bit formats get sRGB
// encoding). Written to a temporary file beside `path` and renamed
// (write_atomically), so a failure never leaves a half-written file: EXR
// through OpenEXR, the rest encoded by the OpenImageIO plugin into memory and
// written with every write, fsync and close checked (a full disk is
// "PATH: write failed: No space left on device"). Throws prt::Error.
void write_image(const std::string& path, int width, int height, const std::vector<float>& rgb);

// An RGBA float image, rows from the top (lightmaps: A = 1 where a triangle
// covers the texel).
struct RgbaImage {
  int width = 0, height = 0;
  bool has_alpha = false;   // read: the file had an A channel (else A = 1)
  std::vector<float> rgba;  // width * height * 4
  // Optional standard errors of RGB (prt reference --lightmap), width *
  // height * 3, stored as the channels se.R, se.G, se.B; empty: none.
  std::vector<float> std_error;
};
// Writes a 4-channel float EXR (R, G, B, A), atomically as write_image.
// Throws prt::Error naming `path` unless it ends in .exr, or if the write fails.
void write_exr_rgba(const std::string& path, const RgbaImage& image);
// Reads an EXR's R, G, B and A (A = 1 when it has none) as floats. Throws
// prt::Error naming `path` for a missing, unreadable or non-EXR file.
RgbaImage read_exr_rgba(const std::string& path);

// Throws prt::Error naming `path` unless write_image can write it: a known
// image extension (.exr, .hdr, .tif, .tiff, .png, .jpg, .jpeg, .bmp, .tga)
// in a writable directory.
void check_image_output(const std::string& path);
// The first half of check_image_output: "" when the extension is one
// write_image writes, else the message ("PATH: unknown image type '.xyz' ...").
std::string image_output_type_problem(const std::string& path);

}  // namespace prt
