// The scene of a lightmap (lightmap_inputs.h).
#include "lightmap_inputs.h"

#include "progress_bar.h"

#include <prt/envmap.h>
#include <prt/unwrap.h>

#include <fmt/core.h>

#include <algorithm>
#include <cctype>

#include <cstddef>
#include <filesystem>

namespace prt::cli {

namespace {

// --pages: "auto" (0) or 1 to kMaxLightmapPages (the option's check took it).
int pages_value(const std::string& text) { return text == "auto" ? 0 : std::stoi(text); }

// Texels [first, first + count) of a stacked image of `per_texel` values a texel.
template <class T>
std::vector<T> page_values(const std::vector<T>& all, std::size_t first, std::size_t count, std::size_t per_texel) {
  return std::vector<T>(all.begin() + std::ptrdiff_t(per_texel * first),
                        all.begin() + std::ptrdiff_t(per_texel * (first + count)));
}

// `path`'s extension in lower case (".exr").
std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

}  // namespace

SceneToBake load_scene_to_bake(const std::string& path, const MeshOptions& options, const LightmapUvArgs& uv, int width,
                               int height, bool quiet) {
  const bool auto_uv = uv.lightmap_uv == "auto";
  int pages = pages_value(uv.pages);
  if (uv.texel_opt->count() > 0 && !(auto_uv && pages == 0))
    throw UsageError("--texel-size is the density of --lightmap-uv auto --pages auto: how many pages the charts take");
  SceneToBake out;
  out.atlas.width = width;
  if (!auto_uv) {
    if (uv.padding_opt->count() > 0) throw UsageError("--uv-padding applies to --lightmap-uv auto only");
    out.scene = prt::load_scene(path, options);
    out.atlas.uv_set = out.scene.lightmap_uv_set(uv.uv_opt->count() > 0 ? uv.uv : -1);
    if (pages == 0) pages = lightmap_pages_used(out.scene, out.atlas.uv_set);
  } else {
    if (uv.uv_opt->count() > 0) throw UsageError("--uv picks a UV set of SCENE; --lightmap-uv auto makes its own");
    prt::Scene scene = load_scene_or_mesh(path, options);
    if (pages == 0) {  // the pages the density takes; then the charts fill them (what consumers make again)
      if (uv.texel_opt->count() == 0)
        throw UsageError("--pages auto with --lightmap-uv auto takes --texel-size S: the density that decides how many "
                         "pages the charts take");
      UnwrapOptions o = lightmap_unwrap_options(width, height, uv.padding, 0);
      o.texel_size = uv.texel_size;
      AtlasStats first;
      unwrap_scene(scene, o, &first);
      pages = first.pages;
    }
    AtlasStats s;
    out.scene = unwrap_scene(scene, lightmap_unwrap_options(width, height, uv.padding, pages), &s);
    out.atlas.uv_set = int(out.scene.uv_sets.size()) - 1;
    out.atlas.unwrap_padding = uv.padding;
    if (!quiet)
      fmt::print(stderr, "lightmap UVs made by prt (--lightmap-uv auto): {} charts{}, texel {:.4g} scene units, {:.1f}% "
                         "of the atlas covered, largest stretch {:.3f}, {:.2f} s\n",
                 s.charts, pages > 1 ? fmt::format(" on {} pages", pages) : "", s.texel_size, 100.0 * s.use,
                 s.max_stretch, s.seconds);
  }
  out.atlas.pages = pages;
  out.atlas.height = height * pages;
  out.scene = stack_lightmap_pages(std::move(out.scene), out.atlas.uv_set, pages);
  return out;
}

std::string page_path(const std::string& path, int page, int pages) {
  if (pages == 1) return path;
  const std::string tile = std::to_string(1001 + page);
  if (const std::size_t at = path.find("<UDIM>"); at != std::string::npos)
    return path.substr(0, at) + tile + path.substr(at + 6);
  const std::filesystem::path p(path);
  return (p.parent_path() / (p.stem().string() + "." + tile + p.extension().string())).string();
}

void write_lightmap_pages(Outputs& out, const std::string& path, const LightmapLayout& layout, RgbaImage image) {
  const int pages = layout.pages, rows = layout.page_height();
  if (pages == 1) {
    out.write([&] { write_exr_rgba(path, image); });
    return;
  }
  const std::size_t per_page = std::size_t(image.width) * std::size_t(rows);
  for (int p = 0; p < pages; ++p) {
    RgbaImage page;
    page.width = image.width;
    page.height = rows;
    const std::size_t first = std::size_t(p) * per_page;
    page.rgba = page_values(image.rgba, first, per_page, 4);
    if (!image.std_error.empty()) page.std_error = page_values(image.std_error, first, per_page, 3);
    out.write([&] { write_exr_rgba(page_path(path, p, pages), page); });
  }
}

LightmapEncoding lightmap_output_encoding(const std::string& path, const std::string& name) {
  const std::string ext = lower_extension(path);
  if (ext != ".exr" && ext != ".png" && ext != ".ktx2")
    throw UsageError("--output: " + path + ": a relit lightmap is written as .exr (float or half), .ktx2 (half or "
                     "astc-hdr) or .png (--encoding rgbm or rgbd)");
  if (name.empty()) {
    if (ext == ".png")
      throw UsageError("--output: " + path + ": a PNG lightmap needs --encoding rgbm or rgbd (8-bit HDR encodings; "
                       "docs/LIGHTMAPS.md \"Encodings for engines\")");
    return ext == ".exr" ? LightmapEncoding::Float : LightmapEncoding::Half;
  }
  const LightmapEncoding e = for_option("--encoding", [&] { return parse_lightmap_encoding(name); });
  const bool fits = ext == ".png"   ? e == LightmapEncoding::Rgbm || e == LightmapEncoding::Rgbd
                    : ext == ".exr" ? e == LightmapEncoding::Float || e == LightmapEncoding::Half
                                    : e == LightmapEncoding::Half || e == LightmapEncoding::AstcHdr;
  if (!fits && e == LightmapEncoding::AstcHdr)
    throw UsageError(fmt::format("--encoding astc-hdr: {} cannot hold it: ASTC HDR blocks are written as KTX2 only "
                                 "(-o lm.ktx2; VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK)", path));
  if (!fits)
    throw UsageError(fmt::format("--encoding {}: {} cannot hold it: rgbm and rgbd are written as 8-bit PNG (.png), "
                                 "float as EXR (.exr), half as EXR or KTX2 (.exr, .ktx2), astc-hdr as KTX2 (.ktx2)",
                                 name, path));
  return e;
}

namespace {

// write_encoded_lightmap_pages for ASTC HDR: one KTX2 per page (a page is
// compressed alone, so no block straddles two pages), each decoded back
// with astcenc for the error.
EncodedPages write_astc_pages(Outputs& out, const std::string& path, const LightmapLayout& layout,
                              const RgbaImage& image) {
  const int pages = layout.pages;
  const std::size_t per_page = std::size_t(image.width) * std::size_t(layout.page_height());
  EncodedPages done;
  RgbaImage decoded = image;
  std::vector<AstcImage> encoded;
  for (int p = 0; p < pages; ++p) {
    RgbaImage page;
    page.width = image.width;
    page.height = layout.page_height();
    page.rgba = page_values(image.rgba, std::size_t(p) * per_page, per_page, 4);
    EncodeReport report;
    encoded.push_back(encode_astc_hdr(page, &report));
    done.report.clamped_texels += report.clamped_texels;
    done.report.largest = p == 0 ? report.largest : std::max(done.report.largest, report.largest);
    const RgbaImage back = decode_astc_hdr(encoded.back());
    std::copy(back.rgba.begin(), back.rgba.end(), decoded.rgba.begin() + std::ptrdiff_t(4 * per_page * std::size_t(p)));
  }
  done.error = encoding_error(image, decoded);
  for (int p = 0; p < pages; ++p)
    out.write([&] { write_ktx2_astc(page_path(path, p, pages), encoded[std::size_t(p)]); });
  return done;
}

}  // namespace

EncodedPages write_encoded_lightmap_pages(Outputs& out, const std::string& path, const LightmapLayout& layout,
                                          RgbaImage image, LightmapEncoding encoding) {
  EncodedPages done;
  if (encoding == LightmapEncoding::Float) {
    write_lightmap_pages(out, path, layout, std::move(image));
    return done;
  }
  if (encoding == LightmapEncoding::AstcHdr) return write_astc_pages(out, path, layout, image);
  const int W = image.width, rows = layout.page_height(), pages = layout.pages;
  const std::size_t per_page = std::size_t(W) * std::size_t(rows);
  const bool ktx2 = lower_extension(path) == ".ktx2";
  if (encoding == LightmapEncoding::Half) {
    const std::vector<std::uint16_t> halves = encode_half(image, &done.report);
    done.error = encoding_error(image, decode_half(image.width, image.height, halves));
    for (int p = 0; p < pages; ++p) {
      const std::vector<std::uint16_t> page = page_values(halves, std::size_t(p) * per_page, per_page, 4);
      const std::string file = page_path(path, p, pages);
      out.write([&] { ktx2 ? write_ktx2_half(file, W, rows, page) : write_exr_half(file, W, rows, page); });
    }
    return done;
  }
  const bool rgbm = encoding == LightmapEncoding::Rgbm;
  const Rgba8Image bytes = rgbm ? encode_rgbm(image, &done.report) : encode_rgbd(image, &done.report);
  done.error = encoding_error(image, rgbm ? decode_rgbm(bytes) : decode_rgbd(bytes));
  for (int p = 0; p < pages; ++p) {
    Rgba8Image page{W, rows, page_values(bytes.rgba, std::size_t(p) * per_page, per_page, 4)};
    out.write([&] { write_png_rgba8(page_path(path, p, pages), page); });
  }
  return done;
}

prt::Scene load_lightmap_scene(const std::string& path, const LightmapLayout& layout) {
  return lightmap_scene(layout.unwrap_padding >= 0 ? load_scene_or_mesh(path) : prt::load_scene(path), layout);
}

}  // namespace prt::cli
