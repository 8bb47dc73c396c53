// --material subsurface's options, which prt precompute and prt reference
// share (docs/SUBSURFACE.md): the material by name (Jensen 2001's table) or
// by its coefficients, its relative index and the length scale.
#pragma once

#include <prt/subsurface.h>

#include <CLI/CLI.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace prt::cli {

// D3DX's samples' fLengthScale: 25 mm a mesh unit.
inline constexpr double kDefaultLengthScale = 25.0;

struct SubsurfaceArgs {
  std::string sss;               // --sss NAME
  std::string sigma_a, sigma_s;  // --sigma-a, --sigma-s r,g,b in 1/mm
  double eta = 0;                // --eta; 0: the preset's (1.3 for coefficients alone)
  double length_scale = kDefaultLengthScale;
  std::vector<const CLI::Option*> options;  // all of them: refused without --material subsurface
};

void add_subsurface_options(CLI::App* command, SubsurfaceArgs& a);

// With material "subsurface", the record the options give: --sss's preset
// (--eta, --sigma-a, --sigma-s override its values), or --sigma-a and
// --sigma-s together (eta 1.3 unless --eta). Throws UsageError naming the
// option: neither a preset nor both coefficients, an unknown preset (the
// names listed), a material check_subsurface_material refuses. With any
// other material: nullopt, and a UsageError when one of these options was
// given ("--sss needs --material subsurface").
std::optional<SubsurfaceRecord> subsurface_record(const SubsurfaceArgs& a, std::string_view material);

// "marble (sigma_a 0.0021, 0.0041, 0.0071 /mm; sigma_s' 2.19, 2.62, 3 /mm;
// eta 1.5; 25 mm a unit)": the record in a line, for summaries.
std::string describe_subsurface(const SubsurfaceRecord& r);

}  // namespace prt::cli
