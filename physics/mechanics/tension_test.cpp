#include "physics/mechanics/tension_test.hpp"

#include <cmath>
#include <limits>
#include <numbers>

#include "engine/core/error.hpp"

namespace sparkdem::physics {

ParamSpec<TensionTest::Params> TensionTest::spec() {
  ParamSpec<Params> s("tension_test", "module",
                      "tension test of a cylindrical sample: axial stress from the pulled set's force over pi R^2, "
                      "axial and lateral strains by least squares over the middle of the sample, Young's modulus "
                      "and Poisson ratio (columns tension_*)");
  s.add_vec3("axis_point", &Params::axis_point).unit("m").doc("a point of the sample's axis");
  s.add_vec3("axis", &Params::axis).unit("1").doc("axis direction (any non-zero length)");
  s.add("radius", &Params::radius).unit("m").required().positive().doc("sample radius R (stress area pi R^2)");
  s.add("pulled", &Params::pulled).required().doc("particle set moved along the axis (listed in the stage's \"sets\")");
  s.add("fixed", &Params::fixed).required().doc("particle set clamped at the other end");
  s.add("middle_fraction", &Params::middle_fraction)
      .unit("1")
      .range(1e-6, 1.0)
      .doc("central fraction of the sample length where the strains are measured");
  return s;
}

TensionTest::TensionTest(const Params& p) : p_(p) {
  if (!(p.axis.norm() > 0.0) || !p.axis.allFinite()) throw ConfigError("/axis", "expected a non-zero finite vector, found a zero one");
  a_ = p.axis.normalized();
}

void TensionTest::declare(Declarations& d) const {
  d.particle_fields.push_back({kReferenceField, 3, "m", std::numeric_limits<double>::quiet_NaN(), false});
  d.reads = {"position", "force"};
  d.writes = {kReferenceField};
}

void TensionTest::capture(State& s) {
  auto& p = s.particles;
  auto& x0 = p.fields.data(kReferenceField);
  for (std::size_t i = 0; i < p.size(); ++i)
    if (std::isnan(x0[3 * i]))
      for (int k = 0; k < 3; ++k) x0[3 * i + k] = p.position[i][k];
}

void TensionTest::bind(State& s) {
  for (const std::string& set : {p_.pulled, p_.fixed})
    if (!s.particles.fields.has("set/" + set))
      throw SetupError("tension_test: particle set '" + set + "' is not defined (list it in the stage's \"sets\")");
  if (p_.pulled == p_.fixed) throw SetupError("tension_test: the pulled and fixed sets are the same set '" + p_.pulled + "'");
  capture(s);
}

void TensionTest::advance(State& s, const StepInfo&) { capture(s); }

std::vector<std::string> TensionTest::columns() const {
  return {"tension_force",          "tension_force_fixed",   "tension_stress",        "tension_axial_strain",
          "tension_lateral_strain", "tension_young_modulus", "tension_poisson_ratio", "tension_middle_count"};
}

std::vector<double> TensionTest::column_values(const State& s) const {
  const Result r = measure(s);
  return {r.force,          r.force_fixed,   r.stress,        r.axial_strain,
          r.lateral_strain, r.young_modulus, r.poisson_ratio, static_cast<double>(r.middle)};
}

TensionTest::Result TensionTest::measure(const State& s) const {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  Result r;
  const auto& p = s.particles;
  if (!p.fields.has(kReferenceField) || !p.fields.has("set/" + p_.pulled) || !p.fields.has("set/" + p_.fixed)) {
    r.young_modulus = r.poisson_ratio = nan;
    return r;
  }
  const auto& x0 = p.fields.data(kReferenceField);
  auto ref = [&](std::size_t i) { return Vec3(x0[3 * i], x0[3 * i + 1], x0[3 * i + 2]); };
  // Forces on the sets and their centroids along the axis.
  const auto& fp = p.fields.data("set/" + p_.pulled);
  const auto& ff = p.fields.data("set/" + p_.fixed);
  double Fp = 0.0, Ff = 0.0, sp = 0.0, sf = 0.0, np = 0.0, nf = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double si = (p.position[i] - p_.axis_point).dot(a_);
    if (fp[i] > 0.5) {
      Fp += p.force[i].dot(a_);
      sp += si;
      np += 1.0;
    }
    if (ff[i] > 0.5) {
      Ff += p.force[i].dot(a_);
      sf += si;
      nf += 1.0;
    }
  }
  const double d = (np > 0.0 && nf > 0.0 && sp / np < sf / nf) ? -1.0 : 1.0;
  r.force = -d * Fp;
  r.force_fixed = d * Ff;
  r.stress = r.force / (std::numbers::pi * p_.radius * p_.radius);
  // Extent of the reference configuration along the axis.
  double smin = std::numeric_limits<double>::infinity(), smax = -smin;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (std::isnan(x0[3 * i])) continue;
    const double si = (ref(i) - p_.axis_point).dot(a_);
    smin = std::min(smin, si);
    smax = std::max(smax, si);
  }
  const double sc = 0.5 * (smin + smax), half = 0.5 * p_.middle_fraction * (smax - smin);
  // Sums for the two fits (two passes for the axial one: centred sums, no cancellation).
  double ss = 0.0, sw = 0.0, n = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (std::isnan(x0[3 * i])) continue;
    const double si = (ref(i) - p_.axis_point).dot(a_);
    if (std::abs(si - sc) > half) continue;
    ss += si;
    sw += (p.position[i] - ref(i)).dot(a_);
    n += 1.0;
  }
  r.middle = static_cast<std::size_t>(n);
  if (n < 2.0) {
    r.axial_strain = r.lateral_strain = r.young_modulus = r.poisson_ratio = nan;
    return r;
  }
  const double sbar = ss / n, wbar = sw / n;
  double sxy = 0.0, sxx = 0.0, rr = 0.0, ru = 0.0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (std::isnan(x0[3 * i])) continue;
    const Vec3 X = ref(i) - p_.axis_point;
    const double si = X.dot(a_);
    if (std::abs(si - sc) > half) continue;
    const Vec3 u = p.position[i] - ref(i);
    sxy += (si - sbar) * (u.dot(a_) - wbar);
    sxx += (si - sbar) * (si - sbar);
    const Vec3 q = X - si * a_;
    const double rho = q.norm();
    if (rho <= 1e-9 * p_.radius) continue;
    rr += rho * rho;
    ru += rho * u.dot(q / rho);
  }
  r.axial_strain = sxx > 0.0 ? sxy / sxx : nan;
  r.lateral_strain = rr > 0.0 ? ru / rr : nan;
  r.young_modulus = r.axial_strain != 0.0 ? r.stress / r.axial_strain : nan;
  r.poisson_ratio = r.axial_strain != 0.0 ? -r.lateral_strain / r.axial_strain : nan;
  return r;
}

}  // namespace sparkdem::physics
