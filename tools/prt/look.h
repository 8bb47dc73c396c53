// How render and view show a scene: shading mode, band truncation, SH
// windowing, exposure and tone map. The same options on both commands.
#pragma once

#include <prt/envmap.h>
#include <prt/filter.h>
#include <prt/render.h>
#include <prt/transfer.h>
#include <prt/wavelet.h>

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace prt::cli {

struct LookArgs {
  std::string shading = "transfer", tone_map = "clamp", window = "none", selection = "area";
  std::string exposure = "auto";  // stops, or auto (frame_exposure of the first frame)
  int bands = 0;    // 0: all of the file's
  int terms = 100;  // wavelet lighting terms K
  CLI::Option *shading_option = nullptr, *bands_option = nullptr, *window_option = nullptr, *terms_option = nullptr,
              *selection_option = nullptr;
};

// --shading, --bands, --window (SH), --terms, --selection (wavelet),
// --exposure, --tonemap.
void add_look_options(CLI::App* command, LookArgs& args);

struct Look {
  Shading shading = Shading::Transfer;
  int bands = 0;  // band limit, 1 .. transfer bands
  sh::Window window = sh::Window::None;
  int terms = 100;
  wavelet::Selection selection = wavelet::Selection::AreaWeighted;
  Display display;
  bool auto_exposure = false;  // --exposure auto (the default): display.exposure is set by the command from its first frame
};

// Checks the options against what was loaded: an SH transfer of `sh_bands`
// bands (0: none) and/or a wavelet transfer (`wavelet`); SH-only options
// given without an SH transfer, and wavelet-only ones without a wavelet
// transfer, are refused. Throws prt::Error naming the option. Without
// --shading, a `glossy` transfer shows Shading::Glossy (the renderer's
// default for it), others Shading::Transfer.
Look parse_look(const LookArgs& args, int sh_bands, bool wavelet, bool glossy = false);

// The lighting to upload: the first `bands` bands of `light` windowed (the
// window's width is bands + 1 for Hanning and Lanczos, so band bands-1 keeps
// a non-zero weight; auto picks the weakest non-negative Hanning window),
// higher bands zeroed. Windowing commutes with rotation, so this is done once
// per map or setting, not per frame.
std::vector<glm::dvec3> windowed_lighting(std::vector<glm::dvec3> light, int bands, sh::Window window);

// --camera "ex,ey,ez,tx,ty,tz,ux,uy,uz": nine finite numbers, the eye not at
// the target, up not parallel to the view direction (the renderer's rule).
CLI::Validator camera_value();
// Sets eye, target and up from a --camera value; throws UsageError naming
// --camera (camera_value() has checked it while parsing).
void parse_camera(const std::string& text, Camera& camera);

// Writes a frame: EXR (and other float formats) keep linear values scaled by
// 2^exposure; 8-bit formats get the tone map, then sRGB encoding. With
// `alpha` (Renderer::coverage, one per pixel): an RGBA EXR (the caller has
// checked the extension).
void write_frame(const std::string& path, Image image, const Display& display,
                 const std::vector<float>* alpha = nullptr);

}  // namespace prt::cli
