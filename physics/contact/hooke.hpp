#pragma once
/// # linear_spring_dashpot — linear normal spring with a dashpot, tangential spring with history
///
/// Normal:     F_n = k_n delta - gamma_n v_n,
///             gamma_n = 2 sqrt(m* k_n) (-ln e)/sqrt(pi^2 + ln^2 e)  (exact restitution e)
/// Tangential: k_t = kt_ratio k_n, gamma_t = gammat_ratio gamma_n, Coulomb |F_t| <= mu |F_n|
///             (kernel::tangential_history; Cundall & Strack 1979).
/// Stable step: 2 sqrt(m_i / sum_j k_ij) over current contacts; a-priori bound 2 sqrt(m/(2 k_n))
/// for a particle about to meet a wall or an equal particle.
///
/// | parameter        | unit | meaning                                   |
/// |------------------|------|-------------------------------------------|
/// | normal_stiffness | N/m  | k_n                                       |
/// | restitution      | 1    | normal coefficient of restitution e        |
/// | kt_ratio         | 1    | k_t / k_n (2/7 gives equal periods)        |
/// | gammat_ratio     | 1    | gamma_t / gamma_n                          |
/// | friction         | 1    | mu                                        |
#include <cmath>
#include <string>
#include <string_view>
#include <vector>

#include "engine/contact/geometry.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/contact/contact_kernels.hpp"

namespace sparkdem::physics {

struct LinearSpringDashpot {
  static constexpr std::string_view kName = "linear_spring_dashpot";
  struct Params {
    double normal_stiffness = 1e5;
    double restitution = 0.5;
    double kt_ratio = 2.0 / 7.0;
    double gammat_ratio = 0.5;
    double friction = 0.5;
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s(std::string(kName), "contact_law", "linear spring-dashpot with tangential history and friction");
    s.add("normal_stiffness", &Params::normal_stiffness).unit("N/m").positive().doc("normal spring stiffness k_n");
    s.add("restitution", &Params::restitution).unit("1").range(0.01, 1.0).doc("normal coefficient of restitution");
    s.add("kt_ratio", &Params::kt_ratio).unit("1").nonnegative().doc("tangential/normal stiffness ratio");
    s.add("gammat_ratio", &Params::gammat_ratio).unit("1").nonnegative().doc("tangential/normal damping ratio");
    s.add("friction", &Params::friction).unit("1").nonnegative().doc("Coulomb friction coefficient");
    return s;
  }
  static std::vector<std::string> state_columns() { return {"shear_x", "shear_y", "shear_z"}; }
  explicit LinearSpringDashpot(const Params& p)
      : p_(p), elastic_(p.restitution >= 1.0), l_e_(elastic_ ? 0.0 : std::log(p.restitution)), root_(std::sqrt(kPi * kPi + l_e_ * l_e_)) {}

  ContactForces operator()(const ContactGeometry& g, const RelativeMotion& m, double dt, double* xi) const {
    const double gn = damping(g.m_eff);
    const double fn = p_.normal_stiffness * g.overlap - gn * m.vn;
    ContactForces f;
    f.tangential = kernel::tangential_history(g.n, m.vt, p_.kt_ratio * p_.normal_stiffness, p_.gammat_ratio * gn, p_.friction, std::abs(fn),
                                              dt, xi);
    f.force = fn * g.n + f.tangential;
    return f;
  }
  /// kernel::linear_damping_for_restitution(e, m_eff, k_n) with its per-law constants (ln e and
  /// sqrt(pi^2 + ln^2 e)) computed once, in the same operations [N s/m].
  double damping(double m_eff) const { return elastic_ ? 0.0 : 2.0 * std::sqrt(m_eff * p_.normal_stiffness) * (-l_e_) / root_; }
  /// operator() for the pairs of a block of rows (engine/contact/lanes.hpp), lane by lane in its order
  /// (damping()'s operations).
  template <int W>
  [[gnu::always_inline]] void lanes(PairLanes<W>& b, double dt) const {
    alignas(64) double kt[W], gt[W], fn_abs[W];
    const double kn = p_.normal_stiffness, ktc = p_.kt_ratio * p_.normal_stiffness;
    const bool elastic = elastic_;
    const double l_e = l_e_, root = root_;
#pragma omp simd
    for (int l = 0; l < W; ++l) {
      const double gn = elastic ? 0.0 : 2.0 * std::sqrt(b.m_eff[l] * kn) * (-l_e) / root;
      const double fn = kn * b.delta[l] - gn * b.vn[l];
      b.fx[l] = fn;  // the normal force, until the force is assembled below
      fn_abs[l] = std::abs(fn);
      kt[l] = ktc;
      gt[l] = p_.gammat_ratio * gn;
    }
    kernel::tangential_history_lanes(b, kt, gt, p_.friction, fn_abs, dt);
    kernel::assemble_force_lanes(b);
  }
  double normal_stiffness(const ContactGeometry&) const { return p_.normal_stiffness; }
  double tangential_stiffness(const ContactGeometry&) const { return p_.kt_ratio * p_.normal_stiffness; }
  /// True at mu = 0: the Coulomb cap then zeroes the whole tangential force (stable step).
  bool tangential_free() const { return p_.friction == 0.0; }
  double rayleigh_dt(double radius, double density) const {
    const double m = density * 4.0 / 3.0 * kPi * radius * radius * radius;
    return 2.0 * std::sqrt(m / (2.0 * p_.normal_stiffness));
  }

 private:
  Params p_;
  bool elastic_;      ///< e >= 1: no dashpot
  double l_e_, root_;  ///< ln e and sqrt(pi^2 + ln^2 e)
};

}  // namespace sparkdem::physics
