// Engines' SH conventions: see prt/sh_convention.h and docs/CONVENTIONS.md,
// "Engines' conventions", for what each array means and the sources read.
#include <prt/sh_convention.h>

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/sh.h>

#include <fmt/core.h>

#include <algorithm>
#include <cmath>
#include <numbers>

namespace prt::sh {

namespace {

constexpr double kPi = std::numbers::pi;

// prt's 3-band basis is Y_k(d) = kSign[k] kNorm[k] kPoly[k](d) with kPoly =
// 1, y, z, x, xy, yz, 3z^2-1, xz, x^2-y^2 (docs/CONVENTIONS.md's table).
const double kNorm[9] = {0.5 / std::sqrt(kPi),      std::sqrt(3 / (4 * kPi)),  std::sqrt(3 / (4 * kPi)),
                         std::sqrt(3 / (4 * kPi)),  std::sqrt(15 / (4 * kPi)), std::sqrt(15 / (4 * kPi)),
                         std::sqrt(5 / (16 * kPi)), std::sqrt(15 / (4 * kPi)), std::sqrt(15 / (16 * kPi))};
constexpr double kSign[9] = {1, -1, 1, -1, 1, -1, 1, -1, 1};
constexpr int kBand[9] = {0, 1, 1, 1, 2, 2, 2, 2, 2};
// (-1)^(l+m): Y_lm(x, y, -z) = (-1)^(l+m) Y_lm(x, y, z) (z is the polar axis).
constexpr double kFlipZ[9] = {1, 1, -1, 1, 1, -1, 1, -1, 1};

double poly(int k, const glm::dvec3& d) {
  switch (k) {
    case 0: return 1;
    case 1: return d.y;
    case 2: return d.z;
    case 3: return d.x;
    case 4: return d.x * d.y;
    case 5: return d.y * d.z;
    case 6: return 3 * d.z * d.z - 1;
    case 7: return d.x * d.z;
    default: return d.x * d.x - d.y * d.y;
  }
}

// Lambert's diffuse radiance per unit radiance coefficient: A_l / pi.
double cosine_over_pi(int k) { return clamped_cosine_factor(kBand[k]) / kPi; }

Sh9 padded(std::span<const glm::dvec3> c) {
  if (c.size() != 1 && c.size() != 4 && c.size() != 9)
    throw Error(fmt::format("engine SH conventions hold 1 to 3 bands (9 coefficients); got {} coefficients", c.size()));
  Sh9 out{};
  for (std::size_t k = 0; k < c.size(); ++k) out[k] = c[k];
  return out;
}

}  // namespace

std::string_view convention_name(Convention c) {
  switch (c) {
    case Convention::Prt: return "prt";
    case Convention::Three: return "three";
    case Convention::Filament: return "filament";
    case Convention::Unity: return "unity";
  }
  return "?";
}

Convention parse_convention(std::string_view name) {
  for (Convention c : {Convention::Prt, Convention::Three, Convention::Filament, Convention::Unity})
    if (name == convention_name(c)) return c;
  throw Error(fmt::format("unknown SH convention '{}': expected prt, three, filament or unity", name));
}

int convention_max_bands(Convention c) { return c == Convention::Prt ? kMaxBands : 3; }

glm::dvec3 to_engine_axes(Convention c, const glm::dvec3& d) {
  return c == Convention::Unity ? glm::dvec3(d.x, d.y, -d.z) : d;
}

Sh9 to_three(std::span<const glm::dvec3> radiance) {
  Sh9 t = padded(radiance);
  for (int k = 0; k < 9; ++k) t[k] *= kSign[k];
  return t;
}

Sh9 to_filament(std::span<const glm::dvec3> radiance) {
  Sh9 f = padded(radiance);
  for (int k = 0; k < 9; ++k) f[k] *= cosine_over_pi(k) * kSign[k] * kNorm[k];
  return f;
}

Sh9 to_unity(std::span<const glm::dvec3> radiance) {
  Sh9 u = padded(radiance);
  for (int k = 0; k < 9; ++k) u[k] *= kFlipZ[k] * cosine_over_pi(k) * kSign[k] * kNorm[k];
  return u;
}

Sh9 to_godot(std::span<const glm::dvec3> radiance) {
  Sh9 g = padded(radiance);
  for (int k = 0; k < 9; ++k) g[k] *= kSign[k] / kPi;
  return g;
}

UnityPacked unity_pack(const Sh9& s) {
  UnityPacked p;
  for (int c = 0; c < 3; ++c) {
    p[c] = {s[3][c], s[1][c], s[2][c], s[0][c] - s[6][c]};
    p[3 + c] = {s[4][c], s[5][c], 3 * s[6][c], s[7][c]};
  }
  p[6] = {s[8][0], s[8][1], s[8][2], 1.0};
  return p;
}

Sh9 unity_unpack(const UnityPacked& p) {
  Sh9 s;
  for (int c = 0; c < 3; ++c) {
    s[6][c] = p[3 + c].z / 3;
    s[0][c] = p[c].w + s[6][c];
    s[1][c] = p[c].y;
    s[2][c] = p[c].z;
    s[3][c] = p[c].x;
    s[4][c] = p[3 + c].x;
    s[5][c] = p[3 + c].y;
    s[7][c] = p[3 + c].w;
    s[8][c] = p[6][c];
  }
  return s;
}

std::vector<glm::dvec3> from_three(const Sh9& t) {
  std::vector<glm::dvec3> c(9);
  for (int k = 0; k < 9; ++k) c[k] = t[k] * kSign[k];
  return c;
}

std::vector<glm::dvec3> from_filament(const Sh9& f) {
  std::vector<glm::dvec3> c(9);
  for (int k = 0; k < 9; ++k) c[k] = f[k] / (cosine_over_pi(k) * kSign[k] * kNorm[k]);
  return c;
}

std::vector<glm::dvec3> from_unity(const Sh9& u) {
  std::vector<glm::dvec3> c(9);
  for (int k = 0; k < 9; ++k) c[k] = u[k] / (kFlipZ[k] * cosine_over_pi(k) * kSign[k] * kNorm[k]);
  return c;
}

// The engines' formulas, with the constants their sources print.
glm::dvec3 three_get_at(const Sh9& s, const glm::dvec3& d) {
  const double x = d.x, y = d.y, z = d.z;
  return s[0] * 0.282095 + s[1] * (0.488603 * y) + s[2] * (0.488603 * z) + s[3] * (0.488603 * x) +
         s[4] * (1.092548 * x * y) + s[5] * (1.092548 * y * z) + s[6] * (0.315392 * (3 * z * z - 1)) +
         s[7] * (1.092548 * x * z) + s[8] * (0.546274 * (x * x - y * y));
}

glm::dvec3 three_get_irradiance_at(const Sh9& s, const glm::dvec3& n) {
  const double x = n.x, y = n.y, z = n.z;
  return s[0] * 0.886227 + s[1] * (2 * 0.511664 * y) + s[2] * (2 * 0.511664 * z) + s[3] * (2 * 0.511664 * x) +
         s[4] * (2 * 0.429043 * x * y) + s[5] * (2 * 0.429043 * y * z) + s[6] * (0.743125 * z * z - 0.247708) +
         s[7] * (2 * 0.429043 * x * z) + s[8] * (0.429043 * (x * x - y * y));
}

glm::dvec3 godot_lightmap_capture(const Sh9& sh, const glm::dvec3& n) {
  // scene_forward_clustered.glsl's lightmap capture, written as Godot writes
  // it (c1 .. c5), on `wnormal` = n.
  const double c1 = 0.429043, c2 = 0.511664, c3 = 0.743125, c4 = 0.886227, c5 = 0.247708;
  const double x = n.x, y = n.y, z = n.z;
  return c1 * sh[8] * (x * x - y * y) + c3 * sh[6] * z * z + c4 * sh[0] - c5 * sh[6] + 2.0 * c1 * sh[4] * x * y +
         2.0 * c1 * sh[7] * x * z + 2.0 * c1 * sh[5] * y * z + 2.0 * c2 * sh[3] * x + 2.0 * c2 * sh[1] * y +
         2.0 * c2 * sh[2] * z;
}

glm::dvec3 filament_irradiance(const Sh9& s, const glm::dvec3& n) {
  glm::dvec3 e(0.0);
  for (int k = 0; k < 9; ++k) e += s[k] * poly(k, n);
  return {std::max(e.x, 0.0), std::max(e.y, 0.0), std::max(e.z, 0.0)};
}

glm::dvec3 unity_shade_sh9(const UnityPacked& p, const glm::dvec3& n) {
  const glm::dvec4 n4(n, 1.0);
  const glm::dvec4 b(n.x * n.y, n.y * n.z, n.z * n.z, n.z * n.x);
  const auto dot4 = [](const glm::dvec4& a, const glm::dvec4& v) {
    return a.x * v.x + a.y * v.y + a.z * v.z + a.w * v.w;
  };
  glm::dvec3 r;
  for (int c = 0; c < 3; ++c) r[c] = dot4(p[c], n4) + dot4(p[3 + c], b);
  return r + glm::dvec3(p[6]) * (n.x * n.x - n.y * n.y);
}

// ---- shader code ---------------------------------------------------------------

namespace {

struct Lang {
  bool hlsl;
  std::string v3, v4, zero3, konst;  // type names, the zero vector, "const" for globals
};

Lang lang_of(ShaderLanguage l) {
  if (l == ShaderLanguage::Hlsl) return {true, "float3", "float4", "float3(0.0, 0.0, 0.0)", "static const"};
  return {false, "vec3", "vec4", "vec3(0.0)", "const"};
}

// '#' keeps the decimal point: a float literal in both languages.
std::string num(double v) { return fmt::format("{:#.9g}", v); }

std::string vec3_array(const Lang& L, const char* name, std::span<const glm::dvec3> c) {
  const std::size_t n = c.size();
  std::string s = L.hlsl ? fmt::format("{} {} {}[{}] = {{\n", L.konst, L.v3, name, n)
                         : fmt::format("{} {} {}[{}] = {}[{}](\n", L.konst, L.v3, name, n, L.v3, n);
  for (std::size_t k = 0; k < n; ++k)
    s += fmt::format("    {}({}, {}, {}){}\n", L.v3, num(c[k].x), num(c[k].y), num(c[k].z), k + 1 < n ? "," : "");
  return s + (L.hlsl ? "};\n" : ");\n");
}

// prt's basis at any band count: the normalised associated Legendre
// recurrence (Q_l^m = N_l^m P_l^m / sin^m theta, Condon-Shortley phase
// included) times Re/Im of (x + i y)^m, summed against PRT_SH_COEFFS.
std::string prt_functions(const Lang& L, int bands, bool irradiance) {
  const std::string V = L.v3;
  std::string s;
  if (!irradiance) {
    const std::vector<double> a = clamped_cosine_factors(bands);
    s +=
        fmt::format("// A_l: the clamped cosine's factors (E_lm = A_l L_lm, no 1/pi).\n{} float PRT_SH_COSINE[{}] = {}",
                    L.konst, bands, L.hlsl ? "{" : fmt::format("float[{}](", bands));
    for (int l = 0; l < bands; ++l) s += num(a[l]) + (l + 1 < bands ? ", " : "");
    s += L.hlsl ? "};\n" : ");\n";
  }
  s += "// sum_k w_l PRT_SH_COEFFS[k] Y_k(d) for a unit direction d in prt's world axes, with prt's basis\n"
       "// (real, orthonormal, Condon-Shortley phase, z polar axis, k = l(l+1)+m; docs/CONVENTIONS.md).\n";
  s += fmt::format("{} prt_sh_sum({} d{}) {{\n", V, V, irradiance ? "" : ", bool cosine");
  s += fmt::format("    {} sum = {};\n", V, L.zero3);
  s += "    float cm = 1.0;\n    float sm = 0.0;\n"
       "    float qmm = 0.282094792;\n"
       "    for (int m = 0; m < PRT_SH_BANDS; ++m) {\n"
       "        if (m > 0) {\n"
       "            float c = cm * d.x - sm * d.y;\n"
       "            sm = sm * d.x + cm * d.y;\n"
       "            cm = c;\n"
       "            qmm *= -sqrt((2.0 * m + 1.0) / (2.0 * m));\n"
       "        }\n"
       "        float q1 = qmm;\n"
       "        float q2 = 0.0;\n"
       "        for (int l = m; l < PRT_SH_BANDS; ++l) {\n"
       "            float q = qmm;\n"
       "            if (l == m + 1) {\n"
       "                q = sqrt(2.0 * m + 3.0) * d.z * qmm;\n"
       "            } else if (l > m + 1) {\n"
       "                float a = sqrt((4.0 * l * l - 1.0) / (1.0 * l * l - 1.0 * m * m));\n"
       "                float b = sqrt((1.0 * (l - 1) * (l - 1) - 1.0 * m * m) / (4.0 * (l - 1) * (l - 1) - 1.0));\n"
       "                q = a * (d.z * q1 - b * q2);\n"
       "            }\n"
       "            q2 = q1;\n"
       "            q1 = q;\n";
  s += irradiance ? "            float w = q;\n" : "            float w = cosine ? PRT_SH_COSINE[l] * q : q;\n";
  s += "            int k = l * (l + 1);\n"
       "            if (m == 0) {\n"
       "                sum += w * PRT_SH_COEFFS[k];\n"
       "            } else {\n"
       "                sum += (1.41421356 * w) * (cm * PRT_SH_COEFFS[k + m] + sm * PRT_SH_COEFFS[k - m]);\n"
       "            }\n"
       "        }\n"
       "    }\n"
       "    return sum;\n"
       "}\n";
  if (irradiance) {
    s += "// Irradiance E(n) (the coefficients are E_lm; no 1/pi), n a unit normal in prt's world axes.\n";
    s += fmt::format("{} prt_sh_irradiance({} n) {{ return prt_sh_sum(n); }}\n", V, V);
  } else {
    s += "// Radiance arriving from the unit direction d (prt's world axes).\n";
    s += fmt::format("{} prt_sh_radiance({} d) {{ return prt_sh_sum(d, false); }}\n", V, V);
    s += "// Irradiance E(n) = integral L(d) max(n.d, 0) dd (no 1/pi), n a unit normal in prt's world axes.\n";
    s += fmt::format("{} prt_sh_irradiance({} n) {{ return prt_sh_sum(n, true); }}\n", V, V);
  }
  return s;
}

std::string three_functions(const Lang& L) {
  const std::string V = L.v3;
  std::string s;
  s += "// three.js SphericalHarmonics3.getAt (src/math/SphericalHarmonics3.js): radiance from d.\n";
  s += fmt::format("{} prt_sh_radiance({} d) {{\n", V, V);
  s += "    float x = d.x;\n    float y = d.y;\n    float z = d.z;\n"
       "    return PRT_SH_COEFFS[0] * 0.282095\n"
       "        + PRT_SH_COEFFS[1] * (0.488603 * y) + PRT_SH_COEFFS[2] * (0.488603 * z) + PRT_SH_COEFFS[3] * (0.488603 "
       "* x)\n"
       "        + PRT_SH_COEFFS[4] * (1.092548 * x * y) + PRT_SH_COEFFS[5] * (1.092548 * y * z)\n"
       "        + PRT_SH_COEFFS[6] * (0.315392 * (3.0 * z * z - 1.0))\n"
       "        + PRT_SH_COEFFS[7] * (1.092548 * x * z) + PRT_SH_COEFFS[8] * (0.546274 * (x * x - y * y));\n"
       "}\n";
  s += "// three.js shGetIrradianceAt (lights_pars_begin.glsl.js): irradiance E(n), no 1/pi (three's\n"
       "// BRDF_Lambert divides by pi).\n";
  s += fmt::format("{} prt_sh_irradiance({} n) {{\n", V, V);
  s += "    float x = n.x;\n    float y = n.y;\n    float z = n.z;\n"
       "    return PRT_SH_COEFFS[0] * 0.886227\n"
       "        + PRT_SH_COEFFS[1] * (2.0 * 0.511664 * y) + PRT_SH_COEFFS[2] * (2.0 * 0.511664 * z)\n"
       "        + PRT_SH_COEFFS[3] * (2.0 * 0.511664 * x)\n"
       "        + PRT_SH_COEFFS[4] * (2.0 * 0.429043 * x * y) + PRT_SH_COEFFS[5] * (2.0 * 0.429043 * y * z)\n"
       "        + PRT_SH_COEFFS[6] * (0.743125 * z * z - 0.247708)\n"
       "        + PRT_SH_COEFFS[7] * (2.0 * 0.429043 * x * z) + PRT_SH_COEFFS[8] * (0.429043 * (x * x - y * y));\n"
       "}\n";
  return s;
}

std::string filament_function(const Lang& L) {
  const std::string V = L.v3;
  std::string s =
      "// Filament Irradiance_SphericalHarmonics (shaders/src/surface_light_indirect.fs): E(n)/pi\n"
      "// (Lambert's 1/pi folded in), clamped at 0 as Filament clamps it.\n";
  s += fmt::format("{} prt_sh_irradiance({} n) {{\n", V, V);
  s += "    return max(PRT_SH_COEFFS[0]\n"
       "        + PRT_SH_COEFFS[1] * (n.y) + PRT_SH_COEFFS[2] * (n.z) + PRT_SH_COEFFS[3] * (n.x)\n"
       "        + PRT_SH_COEFFS[4] * (n.y * n.x) + PRT_SH_COEFFS[5] * (n.y * n.z)\n"
       "        + PRT_SH_COEFFS[6] * (3.0 * n.z * n.z - 1.0) + PRT_SH_COEFFS[7] * (n.z * n.x)\n"
       "        + PRT_SH_COEFFS[8] * (n.x * n.x - n.y * n.y), 0.0);\n"
       "}\n";
  return s;
}

std::string unity_code(const Lang& L, const UnityPacked& p) {
  static constexpr const char* names[7] = {"PRT_SHAr", "PRT_SHAg", "PRT_SHAb", "PRT_SHBr",
                                           "PRT_SHBg", "PRT_SHBb", "PRT_SHC"};
  std::string s = "// Unity's unity_SHAr, SHAg, SHAb, SHBr, SHBg, SHBb, SHC (Unity's left-handed axes).\n";
  for (int i = 0; i < 7; ++i)
    s += fmt::format("{} {} {} = {}({}, {}, {}, {});\n", L.konst, L.v4, names[i], L.v4, num(p[i].x), num(p[i].y),
                     num(p[i].z), num(p[i].w));
  const std::string V = L.v3, V4 = L.v4;
  s += "// Unity ShadeSH9 (UnityCG.cginc; linear colour space): E(n)/pi, n a unit normal in Unity's axes.\n";
  s += fmt::format("{} prt_sh_irradiance({} n) {{\n", V, V);
  s += fmt::format("    {} n4 = {}(n, 1.0);\n", V4, V4);
  s += fmt::format("    {} vB = n.xyzz * n.yzzx;\n", V4);
  s += fmt::format("    {} res;\n", V);
  s += "    res.r = dot(PRT_SHAr, n4) + dot(PRT_SHBr, vB);\n"
       "    res.g = dot(PRT_SHAg, n4) + dot(PRT_SHBg, vB);\n"
       "    res.b = dot(PRT_SHAb, n4) + dot(PRT_SHBb, vB);\n"
       "    return res + PRT_SHC.rgb * (n.x * n.x - n.y * n.y);\n"
       "}\n";
  return s;
}

}  // namespace

std::string shader_code(Convention c, std::span<const glm::dvec3> coeffs, bool irradiance, ShaderLanguage lang) {
  const Lang L = lang_of(lang);
  if (c != Convention::Prt && irradiance)
    throw Error(fmt::format("the {} convention takes radiance coefficients (it applies the clamped cosine itself)",
                            convention_name(c)));
  const int bands = bands_of(coeffs.size());
  switch (c) {
    case Convention::Prt:
      return fmt::format("{} int PRT_SH_BANDS = {};\n", L.konst, bands) + vec3_array(L, "PRT_SH_COEFFS", coeffs) +
             prt_functions(L, bands, irradiance);
    case Convention::Three: {
      const Sh9 t = to_three(coeffs);
      return vec3_array(L, "PRT_SH_COEFFS", t) + three_functions(L);
    }
    case Convention::Filament: {
      const Sh9 f = to_filament(coeffs);
      return vec3_array(L, "PRT_SH_COEFFS", f) + filament_function(L);
    }
    case Convention::Unity: return unity_code(L, unity_pack(to_unity(coeffs)));
  }
  return {};
}

}  // namespace prt::sh
