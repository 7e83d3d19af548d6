// Compiled (never linked) by the ctests contracts/*: a complete contact law registers; with
// -DSPARKDEM_DROP_MEMBER it lacks rayleigh_dt and must fail to compile naming the ContactLaw
// concept and the missing expression (engine/model/contracts.hpp).
#include "engine/model/registry.hpp"

struct ProbeLaw {
  static constexpr std::string_view kName = "probe";
  struct Params {
    double stiffness = 1.0;  ///< [N/m]
  };
  static sparkdem::ParamSpec<Params> spec() { return sparkdem::ParamSpec<Params>("probe", "contact_law", "a contract probe"); }
  explicit ProbeLaw(const Params& p) : p_(p) {}
  static std::vector<std::string> state_columns() { return {}; }
  sparkdem::ContactForces operator()(const sparkdem::ContactGeometry&, const sparkdem::RelativeMotion&, double, double*) const {
    return {};
  }
  double normal_stiffness(const sparkdem::ContactGeometry&) const { return p_.stiffness; }
  double tangential_stiffness(const sparkdem::ContactGeometry&) const { return p_.stiffness; }
#ifndef SPARKDEM_DROP_MEMBER
  double rayleigh_dt(double, double) const { return 1.0; }
#endif
  Params p_;
};

void register_probe(sparkdem::Registry& r) { r.contact_law<ProbeLaw>(); }
