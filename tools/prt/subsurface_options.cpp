#include "subsurface_options.h"

#include "options.h"
#include "shared_options.h"

#include <prt/error.h>

#include <fmt/format.h>

namespace prt::cli {

void add_subsurface_options(CLI::App* s, SubsurfaceArgs& a) {
  a.options = {
      add_shared(s, SharedOption::Sss, a.sss,
                 "With --material subsurface: a measured material of Jensen et al. 2001 by D3DX's name; --sigma-a, "
                 "--sigma-s, --eta override its values"),
      add_shared(s, SharedOption::SigmaA, a.sigma_a,
                 "With --material subsurface: the absorption coefficient sigma_a per channel"),
      add_shared(s, SharedOption::SigmaS, a.sigma_s,
                 "With --material subsurface: the reduced scattering coefficient sigma_s' = sigma_s (1 - g) per "
                 "channel"),
      add_shared(s, SharedOption::Eta, a.eta,
                 "With --material subsurface: the relative index of refraction (default the preset's; 1.3 with "
                 "--sigma-a/--sigma-s)"),
      add_shared(s, SharedOption::LengthScale, a.length_scale,
                 "With --material subsurface: millimetres per mesh unit (D3DX's fLengthScale; its samples used 25)")
          ->capture_default_str(),
  };
}

namespace {

glm::dvec3 coefficients(const std::string& text, const char* option) {
  double v[3];
  parse_triple(text, option, v);
  return {v[0], v[1], v[2]};
}

}  // namespace

std::optional<SubsurfaceRecord> subsurface_record(const SubsurfaceArgs& a, std::string_view material) {
  if (material != "subsurface") {
    for (const CLI::Option* o : a.options)
      if (o->count() > 0) throw UsageError(o->get_name() + " needs --material subsurface");
    return std::nullopt;
  }
  SubsurfaceRecord r;
  r.length_scale = a.length_scale;
  if (!a.sss.empty()) {
    const std::optional<SubsurfaceMaterial> m = subsurface_preset(a.sss);
    if (!m)
      throw UsageError(fmt::format("--sss: no measured material '{}' (one of {})", a.sss, subsurface_preset_names()));
    r.material = *m;
  } else if (a.sigma_a.empty() || a.sigma_s.empty()) {
    throw UsageError("--material subsurface needs --sss NAME (" + subsurface_preset_names() +
                     ") or both --sigma-a and --sigma-s r,g,b (1/mm)");
  }
  if (!a.sigma_a.empty()) r.material.sigma_a = coefficients(a.sigma_a, "--sigma-a");
  if (!a.sigma_s.empty()) r.material.sigma_s = coefficients(a.sigma_s, "--sigma-s");
  if (a.eta > 0) r.material.eta = a.eta;
  if (!a.sss.empty() && (!a.sigma_a.empty() || !a.sigma_s.empty() || a.eta > 0))
    r.material.name += " (modified)";
  for_option("--material subsurface", [&] { check_subsurface_material(r.material, "the material"); });
  return r;
}

std::string describe_subsurface(const SubsurfaceRecord& r) {
  const SubsurfaceMaterial& m = r.material;
  return fmt::format("{}sigma_a {:g}, {:g}, {:g} /mm; sigma_s' {:g}, {:g}, {:g} /mm; eta {:g}; {:g} mm a unit",
                     m.name.empty() ? "" : m.name + ": ", m.sigma_a.x, m.sigma_a.y, m.sigma_a.z, m.sigma_s.x,
                     m.sigma_s.y, m.sigma_s.z, m.eta, r.length_scale);
}

}  // namespace prt::cli
