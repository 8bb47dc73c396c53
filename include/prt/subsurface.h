// prt/subsurface.h - translucent materials: multiple scattering by the
// dipole diffusion approximation of Jensen, Marschner, Levoy & Hanrahan 2001
// (docs/SUBSURFACE.md states the model with its formulas and units).
//
// Units: the coefficients are in 1/mm and distances in mm; R_d(r) is then in
// 1/mm^2 and its integral over the plane, R_d,total, has no unit. A mesh's
// distances become millimetres through a length scale (mm per mesh unit, as
// D3DX's fLengthScale).
#pragma once

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

// A homogeneous translucent material, per RGB channel: sigma_a the
// absorption coefficient and sigma_s the reduced scattering coefficient
// sigma_s' = sigma_s (1 - g), both in 1/mm; eta the relative index of
// refraction (the material's over the medium around it, > 1 for a
// material in air).
struct SubsurfaceMaterial {
  std::string name;  // the preset's name, "" for coefficients given directly
  glm::dvec3 sigma_a{0.0};
  glm::dvec3 sigma_s{0.0};
  double eta = 1.3;

  bool operator==(const SubsurfaceMaterial&) const = default;
};

// The measured materials of Jensen et al. 2001's table (its Figure 5), by
// the names D3DX's samples used: apple, chicken1, chicken2, cream, ketchup,
// marble, potato, skimmilk, skin1, skin2, wholemilk; `measured_rd` the
// table's total diffuse reflectance (docs/SUBSURFACE.md compares it with
// subsurface_total_reflectance).
struct SubsurfacePreset {
  std::string_view name;
  glm::dvec3 sigma_s;  // reduced, 1/mm
  glm::dvec3 sigma_a;  // 1/mm
  double eta;
  glm::dvec3 measured_rd;
};
std::span<const SubsurfacePreset> subsurface_presets();
// The preset named `name` (letter case ignored) as a material; nullopt if
// there is none.
std::optional<SubsurfaceMaterial> subsurface_preset(std::string_view name);
// "apple, chicken1, ...": the presets' names, for messages and --help.
std::string subsurface_preset_names();

// Throws prt::Error naming `what` and the problem unless every coefficient is
// finite and >= 0, each channel's sigma_a + sigma_s is > 0 (light goes
// somewhere) and eta is in [1, 3] (a material denser than what surrounds it,
// and within the range of F_dr's fit: 0.002 off the exact integral from 1 to
// 2, 0.016 at 3).
void check_subsurface_material(const SubsurfaceMaterial& m, std::string_view what);

// F_dr(eta), the diffuse Fresnel reflectance of the boundary seen from
// inside: Jensen 2001's polynomial fit -1.440 / eta^2 + 0.710 / eta + 0.668 +
// 0.0636 eta.
double diffuse_fresnel_reflectance(double eta);
// 1 - the exact Fresnel reflectance of an unpolarised ray entering a
// dielectric of relative index eta at incidence cos_theta (clamped to
// [0, 1]); 0 past the critical angle where eta < 1. Inline: the
// transmitted irradiance's transfer weighs every ray by it (122 million
// calls on a 120k-vertex mesh at 1024 rays, 4% of its time as a call into
// prt::core).
inline double fresnel_transmittance(double eta, double cos_theta) {
  if (eta == 1.0) return 1.0;  // no boundary (the formulas' 0 / 0 at grazing incidence)
  const double ci = std::clamp(cos_theta, 0.0, 1.0);
  const double sin_t2 = (1.0 - ci * ci) / (eta * eta);
  if (sin_t2 >= 1.0) return 0.0;  // total internal reflection
  const double ct = std::sqrt(1.0 - sin_t2);
  const double rs = (ci - eta * ct) / (ci + eta * ct), rp = (eta * ci - ct) / (eta * ci + ct);
  return 1.0 - 0.5 * (rs * rs + rp * rp);
}

// The zonal factors K_l = 2 pi int_0^1 T(eta, mu) mu P_l(mu) dmu of the
// transmitted cosine T(eta, cos) max(cos, 0), l < bands: the irradiance
// transmitted into a surface of normal n under lighting L (unshadowed) is
// sum_lm K_l L_lm Y_lm(n), as the clamped cosine's A_l give the irradiance
// (sh::clamped_cosine_factors, prt/filter.h); eta = 1 gives the A_l. Gauss-Legendre in mu (T is smooth
// on [0, 1] for eta >= 1).
std::vector<double> fresnel_cosine_factors(double eta, int bands);

// One channel's dipole: the real source at depth z_r = 1 / sigma_t' under the
// surface and the virtual one at z_v = z_r (1 + 4 A / 3) above it,
// A = (1 + F_dr) / (1 - F_dr).
struct Dipole {
  Dipole(double sigma_a, double sigma_s, double eta);
  double alpha_prime = 0.0;  // sigma_s' / sigma_t'
  double sigma_tr = 0.0;     // sqrt(3 sigma_a sigma_t'), 1/mm
  double z_r = 0.0, z_v = 0.0;  // mm
  // R_d(r) = alpha' / (4 pi) [z_r (1 + sigma_tr d_r) e^(-sigma_tr d_r) / d_r^3
  //                         + z_v (1 + sigma_tr d_v) e^(-sigma_tr d_v) / d_v^3],
  // d = sqrt(r^2 + z^2): the diffuse reflectance at distance r (mm) from
  // where light entered, 1/mm^2.
  double rd(double r) const;
  // Its integral over the disc of radius rho (mm) about where light entered,
  // int_0^rho R_d(r) 2 pi r dr, closed form (each pole's integrand is the
  // derivative of -z e^(-sigma_tr d) / d in d):
  // (alpha' / 2) sum over the poles of (e^(-sigma_tr z) - z e^(-sigma_tr D) / D),
  // D = sqrt(rho^2 + z^2). total() as rho grows; 0 at rho = 0.
  double disc(double rho) const;
  // The profile's 2-D Laplacian d^2 R_d / dr^2 + (1 / r) dR_d / dr at r (mm),
  // 1/mm^4: the second-order term of R_d's mean over a small disc,
  // R_d + rho^2 / 8 Laplacian (prt/subsurface_scatter.h's far sources).
  double laplacian(double r) const;
  // dR_d / dr at r (mm), 1/mm^3.
  double slope(double r) const;
  // Its integral over the plane, the closed form
  // (alpha' / 2) (1 + e^(-(4/3) A sqrt(3 (1 - alpha')))) e^(-sqrt(3 (1 - alpha'))).
  double total() const;
};
// What a translucent transfer was computed from, as its file records it
// (docs/FORMAT.md, "Subsurface material"; prt info prints it): the material
// and the length scale, millimetres per mesh unit.
struct SubsurfaceRecord {
  SubsurfaceMaterial material;
  double length_scale = 1.0;

  bool operator==(const SubsurfaceRecord&) const = default;
};

// Why lights inside the scene do not light a translucent transfer
// (TransferHeader::subsurface, prt precompute --material subsurface): the
// sentence prt relight, render, view, export --bake and Python refuse them
// with, each after the name of its option.
inline constexpr const char* kTranslucentLightsWhy =
    "a translucent transfer (prt precompute --material subsurface) takes no lights inside the scene: their direct "
    "light here is a diffuse surface's (albedo / pi x the irradiance at the point), while a translucent material's "
    "light enters the surface around each point and scatters under it, which its rows hold for the environment's "
    "light only; light it with the map alone (a sun left in the map)";

glm::dvec3 subsurface_rd(const SubsurfaceMaterial& m, double r_mm);
glm::dvec3 subsurface_total_reflectance(const SubsurfaceMaterial& m);

}  // namespace prt
