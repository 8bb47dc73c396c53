#include <prt/probe_object.h>

#include <prt/error.h>

#include <fmt/format.h>
#include <glm/gtc/matrix_transform.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace prt {

ProbeObject::ProbeObject(ProbeTransfer volume, const Mesh& object, const EnvMap& env, Renderer& renderer,
                         const ProbeObjectPlacement& place, std::string name)
    : t_(std::make_unique<const ProbeTransfer>(std::move(volume))), name_(std::move(name)) {
  const ProbeTransfer& t = *t_;
  if (t.bands != 3)
    throw Error(fmt::format("{} bands; the probe-lit object takes 3 (prt precompute --probes --bands 3)", t.bands));
  vertices_ = object.vertex_count();
  const glm::dvec3 lo(object.bounds_min()), hi(object.bounds_max());
  object_centre_ = (lo + hi) * 0.5;
  const glm::dvec3 sp = t.grid.spacing();
  double smallest = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k)
    if (sp[k] > 0) smallest = std::min(smallest, sp[k]);
  if (!std::isfinite(smallest)) smallest = 1;
  const double size = place.size > 0 ? place.size : 2.0 * smallest;
  const double diag = glm::length(hi - lo);
  object_diagonal_ = diag;
  scale_ = diag > 0 ? size / diag : 1.0;
  const glm::dvec3 gmin = t.grid.min, gmax = t.grid.max;
  if (place.at) {
    centre_ = *place.at;
    fixed_ = true;
  } else {
    // A circle at a third of the volume's height, a quarter of its width across.
    centre_ = {(gmin.x + gmax.x) / 2, gmin.y + (gmax.y - gmin.y) / 3, (gmin.z + gmax.z) / 2};
    radius_ = 0.25 * std::min(gmax.x - gmin.x, gmax.z - gmin.z);
  }
  relighter_ = std::make_unique<ProbeRelighter>(t, env);
  renderer.set_probe_object(object, t, glm::vec3(0.8f));
}

void ProbeObject::frame(Renderer& renderer, const glm::dmat3& R, double t) {
  const double a = 2 * M_PI * t;
  const glm::dvec3 at = fixed_ ? centre_ : centre_ + radius_ * glm::dvec3(std::cos(a), 0.0, std::sin(a));
  glm::dmat4 model = glm::translate(glm::dmat4(1.0), at) * glm::scale(glm::dmat4(1.0), glm::dvec3(scale_)) *
                     glm::translate(glm::dmat4(1.0), -object_centre_);
  renderer.set_probe_object_model(glm::mat4(model));
  // Only the probes of the cells the object's bounding sphere reaches are
  // relit: its vertices read no others.
  relighter_->set_rotation(R);
  const glm::dvec3 sp = t_->grid.spacing();
  const double reach = 0.5 * object_diagonal_ * scale_;
  std::vector<std::uint32_t> probes;
  int lo[3], hi[3];
  for (int k = 0; k < 3; ++k) {
    const int n = t_->grid.dims[std::size_t(k)];
    const double a0 = sp[k] > 0 ? (at[k] - reach - t_->grid.min[k]) / sp[k] : 0.0, a1 = sp[k] > 0 ? (at[k] + reach - t_->grid.min[k]) / sp[k] : 0.0;
    // Clamped as doubles: a spacing of 1e-40 (a flat axis) puts a0 past int's range.
    lo[k] = int(std::clamp(std::floor(a0), 0.0, double(n - 1)));
    hi[k] = int(std::clamp(std::ceil(a1), 0.0, double(n - 1)));
  }
  for (int z = lo[2]; z <= hi[2]; ++z)
    for (int y = lo[1]; y <= hi[1]; ++y)
      for (int x = lo[0]; x <= hi[0]; ++x) probes.push_back(std::uint32_t(t_->grid.index(x, y, z)));
  std::vector<glm::vec3> some;
  relighter_->relight(probes, some);
  lit_.resize(t_->probes() * 9);
  for (std::size_t i = 0; i < probes.size(); ++i)
    std::copy_n(some.begin() + std::ptrdiff_t(i * 9), 9, lit_.begin() + std::ptrdiff_t(std::size_t(probes[i]) * 9));
  renderer.set_probe_lighting(lit_);
}

void ProbeObject::set_environment(const EnvMap& env) { relighter_ = std::make_unique<ProbeRelighter>(*t_, env); }

std::string ProbeObject::describe() const {
  return fmt::format("{}: {} vertices lit by {} probes ({}x{}x{}, {})", name_, vertices_, t_->probes(), t_->grid.dims[0],
                     t_->grid.dims[1], t_->grid.dims[2], transfer_mode_name(t_->mode));
}

}  // namespace prt
