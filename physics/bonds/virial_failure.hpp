#pragma once
/// # bond_virial_failure — bonds break on the hydrostatic (virial) stress of their elements
///
/// GranOO's later brittle criterion (Jebahi et al., IJNME 112(13) 2017; GranOO 2.0's
/// `_ComputeVirialStress` with `HydrostaticCriterion`, cohesive-joule-torsion.md §9.4), offered
/// beside the beam's own per-bond criteria. Per element i, the Love–Weber (virial) stress of the
/// forces its intact bonds apply to it:
///   sigma_i = (1 / V_i) sum_b (x_b - x_i) (x) f_b,i,   x_b = midpoint of the bond, f_b,i = force on i
///   V_i = (4/3) pi r_i^3 / packing_fraction      (the element's share of the solid's volume)
///   sigma_h,i = tr(sigma_i) / 3                   (> 0 in tension)
/// A bond breaks when the mean hydrostatic stress of its two elements reaches `strength` (choice,
/// documented: GranOO evaluates the criterion per element; taking the mean of the two ends makes
/// the decision symmetric and independent of the bond order). Broken bonds are logged with mode
/// "hydrostatic". `criterion: von_mises` (issue 20: an averaged criterion that sees shear, which a
/// hydrostatic one cannot in torsion) uses instead the von Mises stress of the mean of the two
/// elements' symmetric virial tensors,
///   sigma_vm = sqrt(3/2 s:s),  s = sym(sigma) - tr(sigma)/3 I,
/// logged as "virial_von_mises". It runs in
/// the force phase right after the bond pass (list it first among the force modules), reads the
/// bond forces of this step and breaks bonds before the integrator uses them, so a broken bond's
/// last force still acts in the step it breaks in, as with the beam's own criteria.
///
/// | parameter         | unit | meaning                                              |
/// |-------------------|------|------------------------------------------------------|
/// | strength          | Pa   | hydrostatic tensile stress at which a bond breaks    |
/// | packing_fraction  | 1    | solid fraction f_v of the packing (V_i = V_sphere / f_v) |
/// | criterion         | —    | hydrostatic (default) or von_mises                   |
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "engine/model/module.hpp"
#include "engine/model/param_spec.hpp"

namespace sparkdem {
struct State;
class BondTable;
class ParticleStore;
}  // namespace sparkdem

namespace sparkdem::physics {

/// Hydrostatic virial stress [Pa] of every particle from the per-row forces of the intact bonds
/// (BondTable::force(): force on i, j gets minus), with V_i = (4/3) pi r_i^3 / packing_fraction.
std::vector<double> bond_hydrostatic_stress(const ParticleStore& p, const BondTable& b, double packing_fraction);

/// The full virial (Love-Weber) stress tensor [Pa] of every particle, same definition:
/// sigma_i = (1 / V_i) sum_b (x_b - x_i) (x) f_b,i (not symmetrised).
std::vector<Eigen::Matrix3d> bond_virial_stress(const ParticleStore& p, const BondTable& b, double packing_fraction);

/// von Mises stress [Pa] of the symmetric part of a stress tensor: sqrt(3/2 s:s), s its deviator.
double von_mises_stress(const Eigen::Matrix3d& sigma);

/// The averaged criterion value [Pa] of every bond row (0 for broken rows): the mean hydrostatic
/// stress of its two elements, or (von_mises) the von Mises stress of their mean virial tensor.
std::vector<double> bond_virial_criterion(const ParticleStore& p, const BondTable& b, double packing_fraction, bool von_mises);

class BondVirialFailure final : public Module {
 public:
  struct Params {
    double strength = 0.0;
    double packing_fraction = 1.0;
    std::string criterion = "hydrostatic";  ///< hydrostatic | von_mises
  };
  static ParamSpec<Params> spec();
  explicit BondVirialFailure(const Params& p) : p_(p) {}
  std::string name() const override { return "bond_virial_failure"; }
  void declare(Declarations& d) const override { d.writes = {"force"}; }
  void advance(State& s, const StepInfo& info) override;
  std::vector<std::string> columns() const override {
    return {p_.criterion == "von_mises" ? "bond_virial_max_von_mises_stress" : "bond_virial_max_hydrostatic_stress"};
  }
  std::vector<double> column_values(const State& s) const override;

 private:
  Params p_;
};

}  // namespace sparkdem::physics
