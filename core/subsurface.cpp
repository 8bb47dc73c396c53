// Translucent materials: the dipole diffusion approximation (prt/subsurface.h).
#include <prt/error.h>
#include <prt/quadrature.h>
#include <prt/subsurface.h>

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <numbers>

namespace prt {

namespace {

// Jensen, Marschner, Levoy & Hanrahan 2001, Figure 5: sigma_s' and sigma_a
// in 1/mm, the relative index (1.5 for marble, 1.3 for the rest) and the
// measured total diffuse reflectance, R, G, B.
constexpr std::array<SubsurfacePreset, 11> kPresets = {{
    {"apple", {2.29, 2.39, 1.97}, {0.0030, 0.0034, 0.046}, 1.3, {0.85, 0.84, 0.53}},
    {"chicken1", {0.15, 0.21, 0.38}, {0.015, 0.077, 0.19}, 1.3, {0.31, 0.15, 0.10}},
    {"chicken2", {0.19, 0.25, 0.32}, {0.018, 0.088, 0.20}, 1.3, {0.32, 0.16, 0.10}},
    {"cream", {7.38, 5.47, 3.15}, {0.0002, 0.0028, 0.0163}, 1.3, {0.98, 0.90, 0.73}},
    {"ketchup", {0.18, 0.07, 0.03}, {0.061, 0.97, 1.45}, 1.3, {0.16, 0.01, 0.00}},
    {"marble", {2.19, 2.62, 3.00}, {0.0021, 0.0041, 0.0071}, 1.5, {0.83, 0.79, 0.75}},
    {"potato", {0.68, 0.70, 0.55}, {0.0024, 0.0090, 0.12}, 1.3, {0.77, 0.62, 0.21}},
    {"skimmilk", {0.70, 1.22, 1.90}, {0.0014, 0.0025, 0.0142}, 1.3, {0.81, 0.81, 0.69}},
    {"skin1", {0.74, 0.88, 1.01}, {0.032, 0.17, 0.48}, 1.3, {0.44, 0.22, 0.13}},
    {"skin2", {1.09, 1.59, 1.79}, {0.013, 0.070, 0.145}, 1.3, {0.63, 0.44, 0.34}},
    {"wholemilk", {2.55, 3.21, 3.77}, {0.0011, 0.0024, 0.014}, 1.3, {0.91, 0.88, 0.76}},
}};

bool same_name(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

}  // namespace

std::span<const SubsurfacePreset> subsurface_presets() { return kPresets; }

std::optional<SubsurfaceMaterial> subsurface_preset(std::string_view name) {
  for (const SubsurfacePreset& p : kPresets)
    if (same_name(p.name, name)) return SubsurfaceMaterial{std::string(p.name), p.sigma_a, p.sigma_s, p.eta};
  return std::nullopt;
}

std::string subsurface_preset_names() {
  std::string out;
  for (const SubsurfacePreset& p : kPresets) out += (out.empty() ? "" : ", ") + std::string(p.name);
  return out;
}

void check_subsurface_material(const SubsurfaceMaterial& m, std::string_view what) {
  const char* channel[] = {"red", "green", "blue"};
  for (int c = 0; c < 3; ++c) {
    for (const auto& [name, v] : {std::pair{"sigma_a", m.sigma_a[c]}, std::pair{"sigma_s'", m.sigma_s[c]}})
      if (!std::isfinite(v) || v < 0)
        throw Error(fmt::format("{}: {} ({}) must be finite and >= 0 (1/mm), got {}", what, name, channel[c], v));
    if (!(m.sigma_a[c] + m.sigma_s[c] > 0))
      throw Error(fmt::format("{}: sigma_a + sigma_s' ({}) must be > 0: light must be absorbed or scattered", what,
                              channel[c]));
  }
  if (!std::isfinite(m.eta) || m.eta < 1 || m.eta > 3)
    throw Error(fmt::format("{}: the relative index of refraction must be 1 to 3, got {}", what, m.eta));
}

double diffuse_fresnel_reflectance(double eta) { return -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta; }

std::vector<double> fresnel_cosine_factors(double eta, int bands) {
  // 64 nodes: the integrand is a polynomial of degree <= bands (16 at most)
  // times the smooth T; the factors agree with 128 nodes' to 4e-15 (eta 1 to
  // 3, 16 bands).
  constexpr int kNodes = 64;
  const Rule1D rule = gauss_legendre(kNodes, 0.0, 1.0);
  std::vector<double> k(std::size_t(std::max(bands, 0)), 0.0);
  for (std::size_t i = 0; i < rule.x.size(); ++i) {
    const double mu = rule.x[i], weight = rule.w[i] * 2.0 * std::numbers::pi * fresnel_transmittance(eta, mu) * mu;
    double p_prev = 1.0, p = mu;  // P_0, P_1, then Bonnet's recurrence
    for (std::size_t l = 0; l < k.size(); ++l) {
      const double p_l = l == 0 ? 1.0 : p;
      k[l] += weight * p_l;
      if (l >= 1) {
        const double next = ((2.0 * double(l) + 1.0) * mu * p - double(l) * p_prev) / (double(l) + 1.0);
        p_prev = p;
        p = next;
      }
    }
  }
  return k;
}

Dipole::Dipole(double sigma_a, double sigma_s, double eta) {
  const double sigma_t = sigma_a + sigma_s;
  const double f_dr = diffuse_fresnel_reflectance(eta);
  const double a = (1.0 + f_dr) / (1.0 - f_dr);
  alpha_prime = sigma_s / sigma_t;
  sigma_tr = std::sqrt(3.0 * sigma_a * sigma_t);
  z_r = 1.0 / sigma_t;
  z_v = z_r * (1.0 + 4.0 * a / 3.0);
}

double Dipole::rd(double r) const {
  const auto pole = [&](double z) {
    const double d = std::sqrt(r * r + z * z);
    return z * (1.0 + sigma_tr * d) * std::exp(-sigma_tr * d) / (d * d * d);
  };
  return alpha_prime / (4.0 * std::numbers::pi) * (pole(z_r) + pole(z_v));
}

double Dipole::disc(double rho) const {
  const auto pole = [&](double z) {
    const double D = std::sqrt(rho * rho + z * z);
    return std::exp(-sigma_tr * z) - z * std::exp(-sigma_tr * D) / D;
  };
  return 0.5 * alpha_prime * (pole(z_r) + pole(z_v));
}

double Dipole::laplacian(double r) const {
  // Each pole is h(d) = z (1 + s d) e^(-s d) / d^3 of d = sqrt(r^2 + z^2):
  // h' = h g, g = -s^2 d / (1 + s d) - 3 / d, h'' = h (g^2 + g'), and in r
  // the Laplacian is h'' r^2 / d^2 + h' (2 / d - r^2 / d^3).
  const double s = sigma_tr;
  const auto pole = [&](double z) {
    const double d = std::sqrt(r * r + z * z), sd = 1.0 + s * d;
    const double h = z * sd * std::exp(-s * d) / (d * d * d);
    const double g = -s * s * d / sd - 3.0 / d, dg = -s * s / (sd * sd) + 3.0 / (d * d);
    const double h1 = h * g, h2 = h * (g * g + dg);
    return h2 * r * r / (d * d) + h1 * (2.0 / d - r * r / (d * d * d));
  };
  return alpha_prime / (4.0 * std::numbers::pi) * (pole(z_r) + pole(z_v));
}

double Dipole::slope(double r) const {
  const double s = sigma_tr;  // h' r / d, the poles as in laplacian()
  const auto pole = [&](double z) {
    const double d = std::sqrt(r * r + z * z), sd = 1.0 + s * d;
    const double h = z * sd * std::exp(-s * d) / (d * d * d);
    return h * (-s * s * d / sd - 3.0 / d) * r / d;
  };
  return alpha_prime / (4.0 * std::numbers::pi) * (pole(z_r) + pole(z_v));
}

double Dipole::total() const {
  // The poles' integrals over the plane are 2 pi e^(-sigma_tr z) each, and
  // sigma_tr z_r = sqrt(3 (1 - alpha')), sigma_tr z_v the same times
  // 1 + 4 A / 3: the closed form, written through the poles' depths.
  return 0.5 * alpha_prime * (std::exp(-sigma_tr * z_r) + std::exp(-sigma_tr * z_v));
}

glm::dvec3 subsurface_rd(const SubsurfaceMaterial& m, double r_mm) {
  glm::dvec3 out;
  for (int c = 0; c < 3; ++c) out[c] = Dipole(m.sigma_a[c], m.sigma_s[c], m.eta).rd(r_mm);
  return out;
}

glm::dvec3 subsurface_total_reflectance(const SubsurfaceMaterial& m) {
  glm::dvec3 out;
  for (int c = 0; c < 3; ++c) out[c] = Dipole(m.sigma_a[c], m.sigma_s[c], m.eta).total();
  return out;
}

}  // namespace prt
