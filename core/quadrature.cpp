#include <prt/quadrature.h>

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/sh.h>

#include <cmath>

namespace prt {

Rule1D gauss_legendre(int n, double a, double b) {
  PRT_CHECK(n >= 1);
  Rule1D r;
  r.x.resize(n);
  r.w.resize(n);
  for (int i = 0; i < (n + 1) / 2; ++i) {
    // Tricomi's initial guess, then Newton on P_n.
    double z = std::cos(M_PI * (i + 0.75) / (n + 0.5));
    double dp = 1.0;
    for (int it = 0; it < 100; ++it) {
      double p0 = 1.0, p1 = z;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      const double pn = n == 1 ? z : p1, pn1 = n == 1 ? 1.0 : p0;
      dp = n * (z * pn - pn1) / (z * z - 1.0);
      const double dz = pn / dp;
      z -= dz;
      if (std::abs(dz) < 1e-16) break;
    }
    // Recompute the derivative at the converged root for the weight.
    double p0 = 1.0, p1 = z;
    for (int k = 2; k <= n; ++k) {
      const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
      p0 = p1;
      p1 = p2;
    }
    dp = n == 1 ? 1.0 : n * (z * p1 - p0) / (z * z - 1.0);
    const double w = 2.0 / ((1.0 - z * z) * dp * dp);
    const double h = 0.5 * (b - a), c = 0.5 * (b + a);
    r.x[i] = c - h * z;
    r.x[n - 1 - i] = c + h * z;
    r.w[i] = r.w[n - 1 - i] = h * w;
  }
  return r;
}

SphereRule gauss_legendre_sphere(int n_theta, int n_phi) {
  PRT_CHECK(n_theta >= 1 && n_phi >= 1);
  const Rule1D gl = gauss_legendre(n_theta);
  SphereRule r;
  r.directions.reserve(std::size_t(n_theta) * n_phi);
  r.weights.reserve(std::size_t(n_theta) * n_phi);
  for (int i = 0; i < n_theta; ++i) {
    const double z = gl.x[i], s = std::sqrt(std::max(0.0, 1.0 - z * z));
    for (int j = 0; j < n_phi; ++j) {
      const double phi = 2.0 * M_PI * (j + 0.5) / n_phi;
      r.directions.emplace_back(s * std::cos(phi), s * std::sin(phi), z);
      r.weights.push_back(gl.w[i] * 2.0 * M_PI / n_phi);
    }
  }
  return r;
}

std::vector<double> fejer_weights(int H) {
  PRT_CHECK(H >= 1);
  std::vector<double> w(H);
  for (int i = 0; i < H; ++i) {
    const double th = M_PI * (i + 0.5) / H;
    double s = 0.0;
    for (int k = 1; k <= H / 2; ++k) s += std::cos(2.0 * k * th) / (4.0 * k * k - 1.0);
    w[i] = 2.0 / H * (1.0 - 2.0 * s);
  }
  return w;
}

std::vector<double> latlong_box_integrals(int bands, double t0, double t1, double p0, double p1, int nodes) {
  sh::check_bands(bands);
  const Rule1D rt = gauss_legendre(nodes, t0, t1), rp = gauss_legendre(nodes, p0, p1);
  std::vector<double> sum(std::size_t(bands) * bands, 0.0), y(sum.size());
  for (std::size_t i = 0; i < rt.x.size(); ++i)
    for (std::size_t j = 0; j < rp.x.size(); ++j) {
      const double th = rt.x[i], ph = rp.x[j];
      // The lat-long direction of (theta, phi) (a 1x1 map's pixel coordinates); Y at that world direction.
      const glm::dvec3 d = latlong_direction(ph / (2.0 * M_PI), th / M_PI, 1, 1);
      sh::eval(bands, d.x, d.y, d.z, y.data());
      const double w = rt.w[i] * rp.w[j] * std::sin(th);
      for (std::size_t k = 0; k < y.size(); ++k) sum[k] += w * y[k];
    }
  return sum;
}

}  // namespace prt
