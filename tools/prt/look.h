// How render and view show a scene: shading mode, band truncation, SH
// windowing, exposure and tone map. The same options on both commands.
#pragma once

#include <prt/filter.h>
#include <prt/render.h>
#include <prt/transfer.h>

#include <CLI/CLI.hpp>

#include <string>
#include <vector>

namespace prt::cli {

struct LookArgs {
  std::string shading = "transfer", tone_map = "clamp", window = "none";
  double exposure = 0;
  int bands = 0;  // 0: all of the file's
};

// --shading, --bands, --window, --exposure, --tonemap.
void add_look_options(CLI::App* command, LookArgs& args);

struct Look {
  Shading shading = Shading::Transfer;
  int bands = 0;  // band limit, 1 .. transfer bands
  sh::Window window = sh::Window::None;
  Display display;
};

// Checks the options against the transfer (band count); throws prt::Error
// naming the option.
Look parse_look(const LookArgs& args, const Transfer& transfer);

// The lighting to upload: the first `bands` bands of `light` windowed (the
// window's width is bands + 1 for Hanning and Lanczos, so band bands-1 keeps
// a non-zero weight; auto picks the weakest non-negative Hanning window),
// higher bands zeroed. Windowing commutes with rotation, so this is done once
// per map or setting, not per frame.
std::vector<glm::dvec3> windowed_lighting(std::vector<glm::dvec3> light, int bands, sh::Window window);

// Writes a frame: EXR (and other float formats) keep linear values scaled by
// 2^exposure; 8-bit formats get the tone map, then sRGB encoding.
void write_frame(const std::string& path, Image image, const Display& display);

}  // namespace prt::cli
