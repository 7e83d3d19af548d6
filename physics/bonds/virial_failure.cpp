#include "physics/bonds/virial_failure.hpp"

#include <algorithm>
#include <cmath>

#include "engine/state/pair_transfer.hpp"
#include "engine/state/state.hpp"

namespace sparkdem::physics {

std::vector<double> bond_hydrostatic_stress(const ParticleStore& p, const BondTable& b, double packing_fraction) {
  constexpr double kPi = 3.14159265358979323846;
  std::vector<double> trace(p.size(), 0.0);
  const auto& F = b.force();
  for (std::size_t r = 0; r < b.size() && r < F.size(); ++r) {
    if (b.broken(r)) continue;
    const Index i = b.i(r), j = b.j(r);
    const Vec3 mid = 0.5 * (p.position[i] + p.position[j]);
    trace[i] += (mid - p.position[i]).dot(F[r]);   // tr((x_b - x_i) (x) f_b,i)
    trace[j] += (mid - p.position[j]).dot(-F[r]);
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    const double V = 4.0 / 3.0 * kPi * p.radius[i] * p.radius[i] * p.radius[i] / packing_fraction;
    trace[i] /= 3.0 * V;
  }
  return trace;
}

ParamSpec<BondVirialFailure::Params> BondVirialFailure::spec() {
  ParamSpec<Params> s("bond_virial_failure", "module",
                      "bonds break when the mean hydrostatic virial stress of their two elements reaches `strength` "
                      "(GranOO brittle hydrostatic criterion; list it first among the force modules)");
  s.add("strength", &Params::strength).unit("Pa").positive().required().doc("hydrostatic tensile stress at failure");
  s.add("packing_fraction", &Params::packing_fraction).unit("1").range(1e-3, 1.0)
      .doc("solid fraction f_v: element volume V_i = (4/3) pi r_i^3 / f_v");
  return s;
}

void BondVirialFailure::advance(State& s, const StepInfo& info) {
  if (!s.bonds_active || s.bonds.size() == 0) return;
  const std::vector<double> h = bond_hydrostatic_stress(s.particles, s.bonds, p_.packing_fraction);
  std::vector<std::size_t> breaking;
  for (std::size_t r = 0; r < s.bonds.size(); ++r)
    if (!s.bonds.broken(r) && 0.5 * (h[s.bonds.i(r)] + h[s.bonds.j(r)]) >= p_.strength) breaking.push_back(r);
  for (const std::size_t r : breaking) break_bond(s, r, info.step, info.time, kBreakModeHydrostatic);
}

std::vector<double> BondVirialFailure::column_values(const State& s) const {
  if (!s.bonds_active || s.bonds.size() == 0) return {0.0};
  const std::vector<double> h = bond_hydrostatic_stress(s.particles, s.bonds, p_.packing_fraction);
  return {h.empty() ? 0.0 : *std::max_element(h.begin(), h.end())};
}

}  // namespace sparkdem::physics
