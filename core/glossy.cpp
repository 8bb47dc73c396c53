// Glossy PRT numerics. See prt/glossy.h.
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/quadrature.h>
#include <prt/sh.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <cmath>

namespace prt::glossy {

namespace {

void check_exponent(double e) {
  if (!(e >= 0.0) || !std::isfinite(e)) throw Error(fmt::format("--gloss must be a finite number >= 0, got {:.6g}", e));
}

// Legendre polynomials P_0..P_{n-1} at t (Bonnet's recurrence).
void legendre(int n, double t, double* p) {
  if (n > 0) p[0] = 1.0;
  if (n > 1) p[1] = t;
  for (int l = 2; l < n; ++l) p[l] = ((2.0 * l - 1.0) * t * p[l - 1] - (l - 1.0) * p[l - 2]) / l;
}

}  // namespace

std::vector<double> phong_lobe_factors(double e, int bands, int nodes) {
  check_exponent(e);
  sh::check_bands(bands);
  // Integer e: t^e P_l is a polynomial of degree e + l, integrated exactly
  // with ceil((e + bands) / 2) nodes. Other e: t^e has an algebraic
  // singularity at 0, where Gauss-Legendre converges only like n^-(2e+2)
  // (1e-8 at e = 0.5 with 256 nodes); t = u^q (q = 8) turns the integrand into
  // q u^(q(e+1)-1) P_l(u^q), smooth to order 8 at least, and 4 bands + 64
  // nodes give double precision (checked against the recurrence in the tests).
  const bool integer = e == std::floor(e) && e <= 4096.0;
  const int q = integer ? 1 : 8;
  if (nodes <= 0) nodes = integer ? int(e + bands) / 2 + 2 : 4 * bands + 64;
  const Rule1D rule = gauss_legendre(nodes, 0.0, 1.0);
  std::vector<double> lambda(std::size_t(bands), 0.0), p(std::size_t(bands), 0.0);
  for (std::size_t k = 0; k < rule.x.size(); ++k) {
    const double u = rule.x[k], t = q == 1 ? u : std::pow(u, q);
    legendre(bands, t, p.data());
    const double w = rule.w[k] * (q == 1 ? std::pow(t, e) : q * std::pow(u, q * (e + 1.0) - 1.0));
    for (int l = 0; l < bands; ++l) lambda[std::size_t(l)] += w * p[std::size_t(l)];
  }
  for (double& x : lambda) x *= e + 1.0;
  return lambda;
}

std::vector<double> phong_lobe_factors_recurrence(double e, int bands) {
  check_exponent(e);
  sh::check_bands(bands);
  std::vector<double> lambda(std::size_t(bands), 0.0);
  lambda[0] = 1.0;
  if (bands > 1) lambda[1] = (e + 1.0) / (e + 2.0);
  for (int l = 2; l < bands; ++l) lambda[std::size_t(l)] = (e - l + 2.0) / (e + l + 1.0) * lambda[std::size_t(l - 2)];
  return lambda;
}

HemisphereRule hemisphere_rule(const glm::dvec3& n, int bands) {
  sh::check_bands(bands);
  if (!(std::abs(glm::length(n) - 1.0) <= 1e-6))
    throw Error(fmt::format("hemisphere rule: the normal ({}, {}, {}) is not unit length", n.x, n.y, n.z));
  // A right-handed frame (t, b, n).
  const glm::dvec3 a = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 t = glm::normalize(glm::cross(a, n)), b = glm::cross(n, t);
  const int nphi = 2 * bands;
  const Rule1D rule = gauss_legendre(bands, 0.0, 1.0);
  HemisphereRule h;
  for (std::size_t i = 0; i < rule.x.size(); ++i) {
    const double ct = rule.x[i], st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
    for (int j = 0; j < nphi; ++j) {
      const double phi = 2.0 * M_PI * (j + 0.5) / nphi;
      h.directions.push_back(st * std::cos(phi) * t + st * std::sin(phi) * b + ct * n);
      h.weights.push_back(rule.w[i] * 2.0 * M_PI / nphi);
    }
  }
  return h;
}

std::vector<double> hemisphere_product_matrix(const glm::dvec3& n, int bands) {
  const HemisphereRule h = hemisphere_rule(n, bands);
  const int K = bands * bands;
  std::vector<double> m(std::size_t(K) * K, 0.0), y(std::size_t(K), 0.0);
  for (std::size_t i = 0; i < h.directions.size(); ++i) {
    const glm::dvec3& s = h.directions[i];
    sh::eval(bands, s.x, s.y, s.z, y.data());
    for (int p = 0; p < K; ++p) {
      const double wp = h.weights[i] * y[std::size_t(p)];
      for (int q = p; q < K; ++q) m[std::size_t(p) * K + q] += wp * y[std::size_t(q)];
    }
  }
  for (int p = 0; p < K; ++p)
    for (int q = 0; q < p; ++q) m[std::size_t(p) * K + q] = m[std::size_t(q) * K + p];
  return m;
}

std::optional<glm::dvec3> mirror_direction(const glm::dvec3& n, const glm::dvec3& p, const glm::dvec3& eye) {
  const glm::dvec3 to_eye = eye - p;
  const double d = glm::length(to_eye);
  const glm::dvec3 view = d > 0.0 ? to_eye / d : n;
  const double ndv = glm::dot(n, view);
  if (!(ndv > 0.0)) return std::nullopt;
  return 2.0 * ndv * n - view;
}

double glossy_radiance(const std::vector<double>& transferred, const std::vector<double>& lambda, int bands,
                       const glm::dvec3& r, double rho_s) {
  PRT_CHECK_OP(transferred.size(), >=, std::size_t(bands) * bands);
  PRT_CHECK_OP(lambda.size(), >=, std::size_t(bands));
  std::vector<double> y(std::size_t(bands) * bands, 0.0);
  sh::eval(bands, r.x, r.y, r.z, y.data());
  double sum = 0;
  for (int l = 0; l < bands; ++l)
    for (int m = -l; m <= l; ++m) {
      const std::size_t k = std::size_t(sh::index(l, m));
      sum += lambda[std::size_t(l)] * transferred[k] * y[k];
    }
  return rho_s * sum;
}

}  // namespace prt::glossy
