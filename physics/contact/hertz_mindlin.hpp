#pragma once
/// # hertz_mindlin — the reference contact law of sparkdem
///
/// Normal (Hertz 1882):         F_n^e = 4/3 E* sqrt(R* delta) delta
/// Normal damping (Tsuji form):  F_n^d = -alpha(e) sqrt(m* 4/3 E* sqrt(R* delta)) v_n
///   alpha(e) is obtained by inverting the exact dimensionless impact equation
///   (kernel::hertz_tsuji_restitution), so the restitution coefficient equals the requested e
///   for any impact velocity (Tsuji et al. 1992's polynomial is only a fit).
/// Tangential (Mindlin 1949, no-slip stiffness): k_t = 8 G* sqrt(R* delta), with history and
///   Coulomb limit |F_t| <= mu |F_n| (kernel::tangential_history);
///   tangential damping gamma_t = alpha(e) sqrt(m* k_t) (same damping ratio as the normal).
/// No tension clamp: the damping may briefly pull at the end of a contact (as in LAMMPS).
/// Identical materials: 1/E* = 2 (1 - nu^2)/E, 1/G* = 2 (2 - nu)/G.
/// Validity: small elastic strains, delta << R, no adhesion.
///
/// | parameter        | unit | meaning                        |
/// |------------------|------|--------------------------------|
/// | youngs_modulus   | Pa   | E                              |
/// | poisson_ratio    | 1    | nu                             |
/// | restitution      | 1    | normal restitution e (0.05..1] |
/// | friction         | 1    | Coulomb coefficient mu         |
#include <string>
#include <string_view>
#include <vector>

#include "engine/contact/geometry.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/contact/contact_kernels.hpp"

namespace sparkdem::physics {

struct HertzMindlin {
  static constexpr std::string_view kName = "hertz_mindlin";
  struct Params {
    double youngs_modulus = 1e9;
    double poisson_ratio = 0.3;
    double restitution = 0.5;
    double friction = 0.5;
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s(std::string(kName), "contact_law",
                        "Hertz normal + Mindlin tangential with history, Coulomb friction, damping giving an exact "
                        "restitution coefficient");
    s.add("youngs_modulus", &Params::youngs_modulus).unit("Pa").positive().doc("Young's modulus E");
    s.add("poisson_ratio", &Params::poisson_ratio).unit("1").range(0.0, 0.5).doc("Poisson ratio nu");
    s.add("restitution", &Params::restitution).unit("1").range(0.05, 1.0).doc("normal coefficient of restitution");
    s.add("friction", &Params::friction).unit("1").nonnegative().doc("Coulomb friction coefficient mu");
    return s;
  }
  static std::vector<std::string> state_columns() { return {"shear_x", "shear_y", "shear_z"}; }

  explicit HertzMindlin(const Params& p)
      : p_(p),
        e_star_(kernel::effective_modulus(p.youngs_modulus, p.poisson_ratio)),
        g_star_(kernel::effective_shear_modulus(p.youngs_modulus, p.poisson_ratio)),
        alpha_(kernel::hertz_tsuji_alpha_for_restitution(p.restitution)) {}

  ContactForces operator()(const ContactGeometry& g, const RelativeMotion& m, double dt, double* xi) const {
    const double a = std::sqrt(g.r_eff * g.overlap);
    const double knfac = 4.0 / 3.0 * e_star_ * a;
    const double fn = knfac * g.overlap - alpha_ * std::sqrt(g.m_eff * knfac) * m.vn;
    const double kt = 8.0 * g_star_ * a;
    const double gt = alpha_ * std::sqrt(g.m_eff * kt);
    ContactForces f;
    f.tangential = kernel::tangential_history(g.n, m.vt, kt, gt, p_.friction, std::abs(fn), dt, xi);
    f.force = fn * g.n + f.tangential;
    return f;
  }
  /// operator() for the pairs of a block of rows (engine/contact/lanes.hpp), lane by lane in its order.
  template <int W>
  [[gnu::always_inline]] void lanes(PairLanes<W>& b, double dt) const {
    alignas(64) double kt[W], gt[W], fn_abs[W];
    const double knc = 4.0 / 3.0 * e_star_, ktc = 8.0 * g_star_;
#pragma omp simd
    for (int l = 0; l < W; ++l) {
      const double a = std::sqrt(b.r_eff[l] * b.delta[l]);
      const double knfac = knc * a;
      const double fn = knfac * b.delta[l] - alpha_ * std::sqrt(b.m_eff[l] * knfac) * b.vn[l];
      b.fx[l] = fn;  // the normal force, until the force is assembled below
      fn_abs[l] = std::abs(fn);
      kt[l] = ktc * a;
      gt[l] = alpha_ * std::sqrt(b.m_eff[l] * kt[l]);
    }
    kernel::tangential_history_lanes(b, kt, gt, p_.friction, fn_abs, dt);
    kernel::assemble_force_lanes(b);
  }
  double normal_stiffness(const ContactGeometry& g) const { return kernel::hertz_stiffness(e_star_, g.r_eff, g.overlap); }
  double tangential_stiffness(const ContactGeometry& g) const { return 8.0 * g_star_ * std::sqrt(g.r_eff * g.overlap); }
  /// True at mu = 0: the Coulomb cap then zeroes the whole tangential force (stable step).
  bool tangential_free() const { return p_.friction == 0.0; }
  double rayleigh_dt(double radius, double density) const {
    return kernel::rayleigh_step(radius, density, p_.youngs_modulus, p_.poisson_ratio);
  }
  double alpha() const { return alpha_; }
  double e_star() const { return e_star_; }

 private:
  Params p_;
  double e_star_, g_star_, alpha_;
};

}  // namespace sparkdem::physics
