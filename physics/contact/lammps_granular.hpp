#pragma once
/// # lammps_hertz_tsuji — the exact law of ../shared/peers/lammps_pour.in
///   pair_style granular: hertz/material E e nu  tangential linear_history k_t x_gammat mu  damping tsuji
///
/// Normal:   F_ne = k_nfac delta, k_nfac = 4/3 E* sqrt(R* delta), 1/E* = 2 (1 - nu^2)/E
/// Damping:  F_nd = -alpha_T(e) sqrt(m* k_nfac) v_n, alpha_T = Tsuji et al. 1992 polynomial
/// Tangent:  linear_history with stiffness k_t [N/m] (a constant, as in LAMMPS),
///           gamma_t = x_gammat alpha_T sqrt(m* k_nfac), Coulomb mu |F_ne + F_nd|
/// Walls: `fix wall/gran granular hertz/material` of the Debian LAMMPS (29 Sep 2021) uses
///   E*_wall = E / (2 (1 - nu)) instead of the pair value E / (2 (1 - nu^2)) (found by probing the
///   installed lmp; LAMMPS releases from 2023 use the pair formula). `lammps2021_wall_modulus`
///   (default true, for like-for-like runs against the Debian peer) selects the old one.
/// Source: LAMMPS documentation of pair_style granular (2022); Tsuji, Tanaka, Ishida,
/// Powder Technol. 71 (1992) 239.
#include <string>
#include <string_view>
#include <vector>

#include "engine/contact/geometry.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/contact/contact_kernels.hpp"

namespace sparkdem::physics {

struct LammpsHertzTsuji {
  /// LAMMPS pair_granular.cpp's EPSILON: the history is rotated into the tangent plane only when
  /// its normal component matters to that fraction of the friction limit (kernel::tangential_history).
  static constexpr double kLammpsFrameEpsilon = 1e-10;
  static constexpr std::string_view kName = "lammps_hertz_tsuji";
  struct Params {
    double youngs_modulus = 1e7;
    double restitution = 0.3;
    double poisson_ratio = 0.3;
    double tangential_stiffness = 1.0;
    double x_gammat = 1.0;
    double friction = 0.3;
    bool lammps2021_wall_modulus = true;
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s(std::string(kName), "contact_law", "LAMMPS granular: hertz/material + linear_history tangential + tsuji damping");
    s.add("youngs_modulus", &Params::youngs_modulus).unit("Pa").positive().doc("E of hertz/material");
    s.add("restitution", &Params::restitution).unit("1").range(0.0, 1.0).doc("e fed to the Tsuji polynomial");
    s.add("poisson_ratio", &Params::poisson_ratio).unit("1").range(0.0, 0.5).doc("nu of hertz/material");
    s.add("tangential_stiffness", &Params::tangential_stiffness).unit("N/m").nonnegative().doc("k_t of linear_history");
    s.add("x_gammat", &Params::x_gammat).unit("1").nonnegative().doc("tangential damping / normal damping");
    s.add("friction", &Params::friction).unit("1").nonnegative().doc("Coulomb coefficient mu");
    s.add("lammps2021_wall_modulus", &Params::lammps2021_wall_modulus)
        .doc("walls use E/(2(1-nu)) as fix wall/gran of LAMMPS 29Sep2021 does (false: the pair E/(2(1-nu^2)))");
    return s;
  }
  static std::vector<std::string> state_columns() { return {"shear_x", "shear_y", "shear_z"}; }
  explicit LammpsHertzTsuji(const Params& p)
      : p_(p),
        e_star_(kernel::effective_modulus(p.youngs_modulus, p.poisson_ratio)),
        e_star_wall_(p.lammps2021_wall_modulus ? p.youngs_modulus / (2.0 * (1.0 - p.poisson_ratio)) : e_star_),
        alpha_(kernel::tsuji_alpha_polynomial(p.restitution)) {}

  ContactForces operator()(const ContactGeometry& g, const RelativeMotion& m, double dt, double* xi) const {
    const double knfac = 4.0 / 3.0 * (g.wall ? e_star_wall_ : e_star_) * std::sqrt(g.r_eff * g.overlap);
    const double damp = alpha_ * std::sqrt(g.m_eff * knfac);
    const double fn = knfac * g.overlap - damp * m.vn;
    ContactForces f;
    f.tangential = kernel::tangential_history(g.n, m.vt, p_.tangential_stiffness, p_.x_gammat * damp, p_.friction, std::abs(fn), dt, xi,
                                                kLammpsFrameEpsilon);
    f.force = fn * g.n + f.tangential;
    return f;
  }
  /// operator() for the pairs of a block of rows (engine/contact/lanes.hpp), lane by lane in its order.
  template <int W>
  [[gnu::always_inline]] void lanes(PairLanes<W>& b, double dt) const {
    alignas(64) double kt[W], gt[W], fn_abs[W];
    const double knc = 4.0 / 3.0 * e_star_;
#pragma omp simd
    for (int l = 0; l < W; ++l) {
      const double knfac = knc * std::sqrt(b.r_eff[l] * b.delta[l]);
      const double damp = alpha_ * std::sqrt(b.m_eff[l] * knfac);
      const double fn = knfac * b.delta[l] - damp * b.vn[l];
      b.fx[l] = fn;  // the normal force, until the force is assembled below
      fn_abs[l] = std::abs(fn);
      kt[l] = p_.tangential_stiffness;
      gt[l] = p_.x_gammat * damp;
    }
    kernel::tangential_history_lanes(b, kt, gt, p_.friction, fn_abs, dt, kLammpsFrameEpsilon);
    kernel::assemble_force_lanes(b);
  }
  double normal_stiffness(const ContactGeometry& g) const {
    return kernel::hertz_stiffness(g.wall ? e_star_wall_ : e_star_, g.r_eff, g.overlap);
  }
  double tangential_stiffness(const ContactGeometry&) const { return p_.tangential_stiffness; }
  /// True at mu = 0: the Coulomb cap then zeroes the whole tangential force (stable step).
  bool tangential_free() const { return p_.friction == 0.0; }
  double rayleigh_dt(double radius, double density) const {
    return kernel::rayleigh_step(radius, density, p_.youngs_modulus, p_.poisson_ratio);
  }

 private:
  Params p_;
  double e_star_, e_star_wall_, alpha_;
};

}  // namespace sparkdem::physics
