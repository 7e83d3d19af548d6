#include "physics/bonds/virial_failure.hpp"

#include <algorithm>
#include <cmath>

#include "engine/core/numbers.hpp"
#include "engine/state/pair_transfer.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

std::vector<double> bond_hydrostatic_stress(const ParticleStore& p, const BondTable& b, double packing_fraction) {
  std::vector<double> trace(p.size(), 0.0);
  const auto& F = b.force();
  for (std::size_t r = 0; r < b.size() && r < F.size(); ++r) {
    if (b.broken(r)) continue;
    const Index i = b.i(r), j = b.j(r);
    const Vec3 mid = 0.5 * (p.position[i] + p.position[j]);
    trace[i] += (mid - p.position[i]).dot(F[r]);  // tr((x_b - x_i) (x) f_b,i)
    trace[j] += (mid - p.position[j]).dot(-F[r]);
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double V = 4.0 / 3.0 * kPi * p.radius[i] * p.radius[i] * p.radius[i] / packing_fraction;
    trace[i] /= 3.0 * V;
  }
  return trace;
}

std::vector<Eigen::Matrix3d> bond_virial_stress(const ParticleStore& p, const BondTable& b, double packing_fraction) {
  std::vector<Eigen::Matrix3d> sigma(p.size(), Eigen::Matrix3d::Zero());
  const auto& F = b.force();
  for (std::size_t r = 0; r < b.size() && r < F.size(); ++r) {
    if (b.broken(r)) continue;
    const Index i = b.i(r), j = b.j(r);
    const Vec3 mid = 0.5 * (p.position[i] + p.position[j]);
    sigma[i] += (mid - p.position[i]) * F[r].transpose();
    sigma[j] += (mid - p.position[j]) * (-F[r]).transpose();
  }
  for (std::size_t i = 0; i < p.size(); ++i) sigma[i] /= 4.0 / 3.0 * kPi * p.radius[i] * p.radius[i] * p.radius[i] / packing_fraction;
  return sigma;
}

double von_mises_stress(const Eigen::Matrix3d& sigma) {
  const Eigen::Matrix3d sym = 0.5 * (sigma + sigma.transpose());
  const Eigen::Matrix3d dev = sym - sym.trace() / 3.0 * Eigen::Matrix3d::Identity();
  return std::sqrt(1.5 * dev.cwiseProduct(dev).sum());
}

std::vector<double> bond_virial_criterion(const ParticleStore& p, const BondTable& b, double packing_fraction, bool von_mises) {
  std::vector<double> c(b.size(), 0.0);
  if (von_mises) {
    const std::vector<Eigen::Matrix3d> s = bond_virial_stress(p, b, packing_fraction);
    for (std::size_t r = 0; r < b.size(); ++r)
      if (!b.broken(r)) c[r] = von_mises_stress(0.5 * (s[b.i(r)] + s[b.j(r)]));
  } else {
    const std::vector<double> h = bond_hydrostatic_stress(p, b, packing_fraction);
    for (std::size_t r = 0; r < b.size(); ++r)
      if (!b.broken(r)) c[r] = 0.5 * (h[b.i(r)] + h[b.j(r)]);
  }
  return c;
}

ParamSpec<BondVirialFailure::Params> BondVirialFailure::spec() {
  ParamSpec<Params> s("bond_virial_failure", "module",
                      "bonds break when the mean hydrostatic virial stress of their two elements reaches `strength` "
                      "(GranOO brittle hydrostatic criterion; list it first among the force modules)");
  s.add("strength", &Params::strength).unit("Pa").positive().required().doc("hydrostatic tensile stress at failure");
  s.add("packing_fraction", &Params::packing_fraction)
      .unit("1")
      .range(1e-3, 1.0)
      .doc("solid fraction f_v: element volume V_i = (4/3) pi r_i^3 / f_v");
  s.add("criterion", &Params::criterion)
      .choices({"hydrostatic", "von_mises"})
      .doc("hydrostatic: mean hydrostatic stress of the two elements; von_mises: von Mises stress of their mean virial tensor");
  return s;
}

void BondVirialFailure::advance(State& s, const StepInfo& info) {
  if (!s.bonds_active || s.bonds.size() == 0) return;
  const bool vm = p_.criterion == "von_mises";
  const std::vector<double> c = bond_virial_criterion(s.particles, s.bonds, p_.packing_fraction, vm);
  std::vector<std::size_t> breaking;
  for (std::size_t r = 0; r < s.bonds.size(); ++r)
    if (!s.bonds.broken(r) && c[r] >= p_.strength) breaking.push_back(r);
  for (const std::size_t r : breaking) break_bond(s, r, info.step, info.time, vm ? kBreakModeVirialVonMises : kBreakModeHydrostatic);
}

std::vector<double> BondVirialFailure::column_values(const State& s) const {
  if (!s.bonds_active || s.bonds.size() == 0) return {0.0};
  if (p_.criterion == "von_mises") {
    const std::vector<double> c = bond_virial_criterion(s.particles, s.bonds, p_.packing_fraction, true);
    return {c.empty() ? 0.0 : *std::max_element(c.begin(), c.end())};
  }
  const std::vector<double> h = bond_hydrostatic_stress(s.particles, s.bonds, p_.packing_fraction);
  return {h.empty() ? 0.0 : *std::max_element(h.begin(), h.end())};
}

}  // namespace sparkdem::physics
