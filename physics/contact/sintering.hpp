#pragma once
/// # sintering — thermo-viscoelastic sintering contact (Nosewicz-Rojek; seed 000's hot press)
///
/// Sources: Nosewicz, Rojek, Pietrzak, Chmielewski, Powder Technol. 246 (2013) 157 and Adv.
/// Powder Technol. 28 (2017) 1745 (the model behind seed 000's samples); the authors' public
/// Kratos implementation (DEM_sintering_continuum_CL.cpp); Parhami & McMeeking, Mech. Mater. 27
/// (1998) 111 (driving force); equations rebuilt in ../shared/physics/sintering-electrical.md §3.
///
/// Normal: a Maxwell branch (Hertz spring k_n in series with the grain-boundary-diffusion
/// dashpot eta_n), in parallel with the sintering driving force and a numerical damper:
///   F_n   = F_e + F_d - F_s                         (repulsive positive, along n = j -> i)
///   dF_e/dt = k_n (v - F_e / eta_n),  v = dh/dt = -v_n + d(r_i + r_j)/dt;  du_s/dt = F_e / eta_n
///           (v is the overlap rate: the centres' approach plus the radii's thermal growth, so a
///           cooled neck pulls its particles together as the solid it stands for contracts; with
///           -v_n alone a compact cooled in the die kept its centres and gained porosity
///           (1 - p) 3 alpha dT, issue 21 item 7)
///   k_n   = 2 E* sqrt(R*) sqrt(|h - u_s|)           (Hertz tangent on the elastic approach; with
///           neck_stiffness = neck_radius: 2 E* max(a, sqrt(R* |h - u_s|)), the bonded neck)
///   eta_n = pi a^4 / (8 D_eff),  D_eff = D_gb delta_b Omega / (k_B T),
///   D_gb  = D_0 exp(-Q / (R_gas T)),  T = mean temperature of the pair
///   F_s   = pi gamma_s [4 R (1 - cos(psi/2)) + a sin(psi/2)]   while a < a_eq = r_min sin(psi/2)
///   F_d   = c_n (v - du_s/dt),  c_n = 2 gamma sqrt(m* k_n)
/// Maxwell update (kernel::maxwell_step): exact exponential for k_n, eta_n and v held over the
/// step, x = k_n dt / eta_n,  phi(x) = (1 - e^-x)/x:
///   F_e' = F_e e^-x + k_n v dt phi(x),   du_s = dt [v (1 - phi(x)) + phi(x) F_e / eta_n]
/// Unconditionally stable and monotone for any dt / (eta/k): it relaxes without overshoot
/// when eta -> 0 at a fresh contact (the trapezoidal rule of the Kratos code rings there).
/// The viscous processes run in physical time: with a stage time scale s (physical seconds per
/// mechanical second) the dashpots are eta / s in mechanical time.
///
/// Neck radius a (state column `neck_radius`, read by the electrical module's
/// `"neck": "law"`): from the overlap h by `neck` (kratos: a = 1.43 sqrt(r_min^2 - x^2),
/// x = r_min - h/2; coble: sqrt(2 r* h); cv: constant volume — the kernels shared with the
/// electrical module; intersection: the circle where the spheres meet, for the grown spheres of
/// the module mass_conserving_radii), never decreasing while the pair lives, at least min_neck_fraction r_min
/// once sintering (eta_n > 0 at a fresh contact), at most r_min. A pair with a > 0 is
/// persistent: it outlives zero or negative overlap (the neck holds the particles together).
/// After a >= a_eq the driving force stops; the dashpot either stops too, freezing u_s
/// (`after_equilibrium: frozen`, the Kratos code), or keeps flowing under the contact load
/// (`creep`: grain-boundary diffusion creep driven by the applied pressure, as in the
/// Bouvard-McMeeking law N = eta du/dt - F_s, which has no equilibrium stop; a capped at r_min).
/// With `frozen` a pressed compact stops densifying once its necks reach a_eq (a 300-particle
/// NiAl compact at 1300 C / 30 MPa stalls at porosity 0.144). `creep` stops at the overlap
/// h = creep_overlap_limit x r_min (default 1: the smaller particle's centre reaches the other's
/// surface; beyond it a pair-wise neck means nothing and the small particle would be swallowed).
/// With `creep_stop_gb_fraction` f_stop > 0 it also stops once either particle's grain-boundary
/// fraction sum_k a_k^2 / (4 r^2) (seed 000 Eq. 22, from the previous step's necks) reaches
/// f_stop: a particle whose surface is all grain boundary has no pore left to shrink into (f_stop
/// = 1: full density by Eq. 23). Without it the interior of the NiAl compact creeps past full
/// density (issue 21: mass porosity -0.18 to -0.24 in the core at the last snapshot). With
/// `stop_flow_at_dense` (for the grown particles of the module mass_conserving_radii) a pair stops
/// flowing altogether, driving force and dashpots, once either particle is flagged dense by that
/// module (its necks' caps cover its surface).
///
/// Power-law creep (`powerlaw_creep_rate` > 0; issue 36): dislocation creep of the necks acting in
/// parallel with grain-boundary diffusion, so the dashpot's rates add,
///   du_s/dt = F_e / eta_n + hdot_pl(F_e),  hdot_pl = (a / c^2) eps_dot_0(T) (F_e / (beta pi a^2 sigma_0))^n
/// (kernel::PowerLawCreep: Storakers, Biwa & Larsson 1997; Storakers, Fleck & McMeeking 1999), on a
/// compressive F_e only, under the same conditions as the creep beyond a_eq (hot, a neck, h below
/// creep_overlap_limit x r_min, grain-boundary fraction below creep_stop_gb_fraction) but whatever
/// after_equilibrium says. GB diffusion is linear in the load and stiffens as a^4; power-law creep
/// rises as F^n a^(1-2n): the apparent exponent of the pair falls from n at small, highly loaded
/// necks to 1 at large ones. The tangential element keeps eta_t = tangential_factor x eta_n (GB).
///
/// Tangential: a Maxwell element too, k_t = 8 G* sqrt(R* |h - u_s|) in series with
/// eta_t = tangential_factor x eta_n, state = the elastic tangential force (rotated into the
/// current tangent plane), plus damping 2 gamma sqrt(m* k_t). A pair without a neck (cold
/// contact) is capped by Coulomb friction mu |F_n|; a sintered neck is not.
/// Below sintering_start_temperature: no driving force, eta = +inf (elastic); a sintered neck
/// stays bonded (carries tension, `cold_necks: bonded`) or becomes a plain frictional contact
/// (`cold_necks: contact`: compression only, the neck radius is kept for the conductance).
/// Walls (punches, die): Hertz + damping + Coulomb friction (wall_friction), no sintering.
/// Over SIMD lanes (`lanes`, issue 63): the same operations on blocks of rows, bit for bit, except
/// with power-law creep or the constant-volume neck (row by row: `lanes_enabled`).
///
/// Choices the sources leave open (parameters): R in F_s for unequal spheres (`sintering_radius`:
/// r_min as in Kratos, R* or 2R*), the tangential factor (1 = eta_t = eta_n), cooling below the
/// start temperature (`cold_necks`), the neck geometry (`neck`), a neck strength (default: none),
/// the dashpot beyond the equilibrium neck (`after_equilibrium`).
///
/// | parameter                    | unit    | meaning                                          |
/// |------------------------------|---------|--------------------------------------------------|
/// | youngs_modulus, poisson_ratio| Pa, 1   | E, nu of the particles (Hertz)                    |
/// | surface_energy               | J/m^2   | gamma_s                                           |
/// | dihedral_angle               | rad     | psi                                               |
/// | gb_diffusivity_prefactor     | m^2/s   | D_0 of D_gb                                       |
/// | gb_activation_energy         | J/mol   | Q of D_gb                                         |
/// | gb_width                     | m       | delta_b (atomic GB width of the diffusion law)    |
/// | atomic_volume                | m^3     | Omega                                             |
/// | sintering_start_temperature  | K       | below it: no sintering                            |
/// | temperature                  | K       | used when no module provides the field            |
/// | damping_ratio                | 1       | gamma of the numerical damping                    |
/// | tangential_factor            | 1       | eta_t / eta_n                                     |
/// | friction, wall_friction      | 1       | Coulomb mu (contacts without a neck; walls)        |
/// | min_neck_fraction            | 1       | smallest neck of a sintering pair / r_min         |
/// | neck_strength                | Pa      | a neck breaks when the tension exceeds it x pi a^2 (0: never) |
/// | stop_flow_at_dense           | bool    | pairs of a dense particle (mass_conserving_radii) stop flowing |
/// | powerlaw_creep_rate          | 1/s     | eps_dot_0 at powerlaw_creep_stress and _temperature (0: off) |
/// | powerlaw_creep_stress        | Pa      | sigma_0                                           |
/// | powerlaw_creep_exponent      | 1       | n                                                 |
/// | powerlaw_creep_activation_energy | J/mol | Q of eps_dot_0(T) (Arrhenius about T_ref)        |
/// | powerlaw_creep_temperature   | K       | T_ref                                             |
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "engine/contact/geometry.hpp"
#include "engine/contact/lanes.hpp"
#include "engine/core/error.hpp"
#include "engine/core/lane_math.hpp"
#include "engine/model/param_spec.hpp"
#include "physics/contact/contact_kernels.hpp"
#include "physics/electrical/conductance_kernels.hpp"

namespace sparkdem::physics {

namespace kernel {

inline constexpr double kBoltzmann = 1.380649e-23;   ///< k_B [J/K]
inline constexpr double kGasConstant = 8.314462618;  ///< R [J/(mol K)]

/// Effective grain-boundary diffusion coefficient [m^5/(N s)] (Coble; Nosewicz 2013):
///   D_eff = D_0 exp(-Q / (R T)) delta_b Omega / (k_B T).
inline double gb_effective_diffusivity(double d0_m2_per_s, double q_J_per_mol, double delta_b_m, double omega_m3, double t_K) {
  return d0_m2_per_s * std::exp(-q_J_per_mol / (kGasConstant * t_K)) * delta_b_m * omega_m3 / (kBoltzmann * t_K);
}

/// Normal viscosity of a neck of radius a [N s/m]: eta_n = pi a^4 / (8 D_eff) (Nosewicz 2013).
inline double neck_viscosity(double a_m, double d_eff) { return kPi * a_m * a_m * a_m * a_m / (8.0 * d_eff); }

/// Parhami-McMeeking sintering driving force [N] (attractive magnitude):
///   F_s = pi gamma_s [4 R (1 - cos(psi/2)) + a sin(psi/2)],
/// with cos(psi/2) and sin(psi/2) given (a law's dihedral angle is constant: computed once).
inline double sintering_force(double gamma_s, double cos_half_psi, double sin_half_psi, double R_m, double a_m) {
  return kPi * gamma_s * (4.0 * R_m * (1.0 - cos_half_psi) + a_m * sin_half_psi);
}

/// Kratos' neck radius [m]: a = 1.43 sqrt(r_min^2 - x^2), x = r_min - h/2 (0 for h <= 0).
inline double kratos_neck_radius(double r_min_m, double h_m) {
  if (!(h_m > 0.0)) return 0.0;
  const double x = r_min_m - 0.5 * std::min(h_m, 2.0 * r_min_m);
  return 1.43 * std::sqrt(std::max(0.0, r_min_m * r_min_m - x * x));
}

/// Radius of the circle where two overlapping spheres meet [m] (0 for h <= 0): on the radical
/// plane at x_i = (d^2 + r_i^2 - r_j^2) / (2d) from centre i, d = r_i + r_j - h,
///   a = sqrt(r_i^2 - x_i^2),
/// capped at the smaller radius (a small sphere whose centre passed the plane). The neck of the
/// grown spheres of mass_conserving_radii (physics/contact/mass_conserving_radii.hpp).
inline double intersection_neck_radius(double r_i, double r_j, double h_m) {
  if (!(h_m > 0.0)) return 0.0;
  const double r_min = std::min(r_i, r_j);
  const double d = r_i + r_j - h_m;
  if (!(d > std::abs(r_i - r_j))) return r_min;
  const double x = (d * d + r_i * r_i - r_j * r_j) / (2.0 * d);
  return std::min(r_min, std::sqrt(std::max(0.0, r_i * r_i - x * x)));
}

/// One step of a Maxwell element (spring k in series with dashpot eta) driven by the rate v,
/// exact for k, eta and v constant over dt: dF/dt = k (v - F/eta), du/dt = F/eta.
///   x = k dt / eta, phi = (1 - e^-x)/x:  F' = F e^-x + k v dt phi,  du = dt [v (1 - phi) + phi F/eta]
/// eta = +inf: elastic (F' = F + k v dt, du = 0). k = 0: F' = F, du = F dt / eta.
/// Monotone and bounded for every dt: F' lies between F and eta v.
struct MaxwellStep {
  double force;  ///< F at the end of the step
  double flow;   ///< du: dashpot displacement over the step
};
/// The step's decay factors {e^-x, phi(x)} for x = k dt / eta (eta = +inf: {1, 1}).
struct MaxwellFactors {
  double decay;  ///< e^-x
  double phi;    ///< (1 - e^-x)/x
};
/// Branch-free (its cases are selects), so that Sintering::lanes runs it on every lane; e^-x and
/// expm1 come from lanemath (engine/core/lane_math.hpp): the same bits row by row and over lanes.
[[gnu::always_inline]] inline MaxwellFactors maxwell_factors(double k, double eta, double dt) {
  const double x = k * dt / eta;
  const lanemath::ExpAndExpm1 e = lanemath::exp_and_expm1(-x);
  const double phi = x > 1e-8 ? -e.expm1 / x : 1.0 - 0.5 * x;
  // eta = +inf: elastic {1, 1}; eta <= 0: x = +inf (k > 0) or an instantly relaxing element {0, 0}
  const bool elastic = !(eta < std::numeric_limits<double>::infinity()), instant = !(eta > 0.0);
  return {elastic ? 1.0 : (instant ? 0.0 : e.exp), elastic ? 1.0 : (instant ? 0.0 : phi)};
}
/// Power-law creep of a contact between two spheres [m/s] (the approach rate in physical time):
/// Storakers, Biwa & Larsson, Int. J. Solids Struct. 34 (1997) 3061, self-similar indentation of a
/// creeping solid, their Eq. (78) with m -> inf (no strain hardening), the material
/// eps_dot = eps_dot_0 (sigma / sigma_0)^n, and the contact profile a^2 = c^2 D h:
///   F / (pi a^2) = [3 (n + 2) / n] sigma_0 (adot / (3 D) / eps_dot_0)^(1/n),  D = 2 R*,
///   c^2(n) = 1.43 exp(-0.97 / n)  (their Fig. 5: 1.43 ideally plastic, 1 at n = 3, ~0.5 linear),
/// so, with adot = c^2 R* hdot / a,
///   hdot = (a / c^2) eps_dot_0 (F / (beta pi a^2 sigma_0))^n,  beta(n) = 3 (n + 2) / n * 6^(-1/n)
/// (the form of Storakers, Fleck & McMeeking, J. Mech. Phys. Solids 47 (1999) 785). Compressive
/// force only (F <= 0: no creep); a is the neck radius of the pair.
struct PowerLawCreep {
  double c2;      ///< c^2(n)
  double beta;    ///< beta(n)
  double n;       ///< stress exponent
  double sigma0;  ///< reference stress [Pa]
  static PowerLawCreep of(double n, double sigma0) {
    return {1.43 * std::exp(-0.97 / n), 3.0 * (n + 2.0) / n * std::pow(6.0, -1.0 / n), n, sigma0};
  }
  /// hdot [m/s] at force F [N], neck a [m] and reference strain rate eps_dot_0 [1/s] (at the temperature).
  double rate(double F, double a, double eps_dot_0) const {
    if (!(F > 0.0) || !(a > 0.0) || !(eps_dot_0 > 0.0)) return 0.0;
    return a / c2 * eps_dot_0 * std::pow(F / (beta * kPi * a * a * sigma0), n);
  }
};

/// Arrhenius reference strain rate [1/s]: eps_dot_0(T) = eps_dot_ref exp(-Q/R (1/T - 1/T_ref)).
inline double arrhenius_rate(double rate_ref_per_s, double q_J_per_mol, double t_ref_K, double t_K) {
  return rate_ref_per_s * std::exp(-q_J_per_mol / kGasConstant * (1.0 / t_K - 1.0 / t_ref_K));
}

/// eta = 0 (a dashpot of a neck of zero radius, eta ~ a^4): the limit x -> inf, F' = 0 and the
/// dashpot takes the whole motion plus the released spring, du = v dt + F/k (k = 0: v dt).
inline MaxwellStep maxwell_step(double force, double k, double eta, double v, double dt) {
  if (!(eta < std::numeric_limits<double>::infinity())) return {force + k * v * dt, 0.0};
  if (!(eta > 0.0)) return {0.0, v * dt + (k > 0.0 ? force / k : 0.0)};
  const MaxwellFactors m = maxwell_factors(k, eta, dt);
  return {force * m.decay + k * v * dt * m.phi, dt * (v * (1.0 - m.phi) + m.phi * force / eta)};
}

/// A neck's resistance to the relative rotation of its particles, over a step [N m s]: the moment
/// on i is -(bend (I - n n^T) + twist n n^T) (w_i - w_j).
///   bend  = c a^2 / 12:  the normal line F = c v on the neck disk of radius a, with the normal
///                        velocity linear across the disk, v(x) = theta' x, instead of uniform.
///                        For grain-boundary diffusion (the plating flux solves a Poisson problem
///                        on the disk, p = 0 at its edge) a uniform v gives F = -C v pi a^4 / 8 and
///                        v = theta' x gives M = -C theta' pi a^6 / 96: M / theta' = (F / v) a^2 / 12.
///   twist = c_t a^2 / 2: the tangential line F_t = c_t v_t with the in-plane velocity rising
///                        linearly from the centre, v_t(r) = phi' r: M = (c_t / (pi a^2)) phi' pi a^4 / 2.
/// Derived here under the assumptions of neck_viscosity (a flat disk neck, the Coble/Nosewicz
/// boundary flux); used by the inertia-free step only (LinearContact::bend, twist).
struct NeckMoments {
  double bend, twist;
};
inline NeckMoments neck_rotation_resistance(double c_normal, double c_tangential, double a_m) {
  return {c_normal * a_m * a_m / 12.0, c_tangential * a_m * a_m / 2.0};
}

}  // namespace kernel

struct Sintering {
  static constexpr std::string_view kName = "sintering";
  static constexpr bool kPersistent = true;
  static constexpr bool kThermal = true;
  struct Params {
    double youngs_modulus = 1e9;
    double poisson_ratio = 0.3;
    double surface_energy = 2.0;
    double dihedral_angle = 2.0;
    double gb_diffusivity_prefactor = 1e-4;
    double gb_activation_energy = 2e5;
    double gb_width = 5e-10;
    double atomic_volume = 1.2e-29;
    double sintering_start_temperature = 1000.0;
    double temperature = 293.15;
    double damping_ratio = 0.3;
    double tangential_factor = 1.0;
    double friction = 0.3;
    double wall_friction = 0.3;
    double min_neck_fraction = 0.05;
    double neck_strength = 0.0;
    std::string neck = "kratos";
    std::string sintering_radius = "r_min";
    std::string cold_necks = "bonded";
    std::string after_equilibrium = "frozen";
    double creep_overlap_limit = 1.0;
    std::string neck_stiffness = "elastic_approach";
    double creep_stop_gb_fraction = 0.0;
    bool stop_flow_at_dense = false;
    double powerlaw_creep_rate = 0.0;
    double powerlaw_creep_stress = 1.0e8;
    double powerlaw_creep_exponent = 5.5;
    double powerlaw_creep_activation_energy = 2.5e5;
    double powerlaw_creep_temperature = 1473.15;
  };
  static ParamSpec<Params> spec() {
    using P = Params;
    ParamSpec<P> s(std::string(kName), "contact_law",
                   "thermo-viscoelastic sintering (Nosewicz-Rojek): Hertz spring in series with the grain-boundary "
                   "dashpot pi a^4/(8 D_eff), Parhami-McMeeking driving force, persistent necks");
    s.add("youngs_modulus", &P::youngs_modulus).unit("Pa").positive().doc("E (Hertz)");
    s.add("poisson_ratio", &P::poisson_ratio).unit("1").range(0.0, 0.5).doc("nu");
    s.add("surface_energy", &P::surface_energy).unit("J/m^2").nonnegative().doc("gamma_s");
    s.add("dihedral_angle", &P::dihedral_angle).unit("rad").range(0.0, 3.14159265358979).doc("psi; equilibrium neck r_min sin(psi/2)");
    s.add("gb_diffusivity_prefactor", &P::gb_diffusivity_prefactor).unit("m^2/s").positive().doc("D_0 of D_gb = D_0 exp(-Q/RT)");
    s.add("gb_activation_energy", &P::gb_activation_energy).unit("J/mol").nonnegative().doc("Q of D_gb");
    s.add("gb_width", &P::gb_width).unit("m").positive().doc("delta_b, atomic grain-boundary width of the diffusion law");
    s.add("atomic_volume", &P::atomic_volume).unit("m^3").positive().doc("Omega");
    s.add("sintering_start_temperature", &P::sintering_start_temperature).unit("K").positive().doc("no sintering below it");
    s.add("temperature", &P::temperature).unit("K").positive().doc("temperature when no module provides the field \"temperature\"");
    s.add("damping_ratio", &P::damping_ratio).unit("1").nonnegative().doc("gamma of the numerical damping 2 gamma sqrt(m* k)");
    s.add("tangential_factor", &P::tangential_factor).unit("1").positive().doc("eta_t / eta_n");
    s.add("friction", &P::friction).unit("1").nonnegative().doc("Coulomb mu of contacts without a neck");
    s.add("wall_friction", &P::wall_friction).unit("1").nonnegative().doc("Coulomb mu against walls (punches, die)");
    s.add("min_neck_fraction", &P::min_neck_fraction).unit("1").range(1e-6, 1.0).doc("smallest neck of a sintering pair, / r_min");
    s.add("neck_strength", &P::neck_strength)
        .unit("Pa")
        .nonnegative()
        .doc("a neck breaks when its tension exceeds this x pi a^2 (0: never)");
    s.add("neck", &P::neck)
        .choices({"kratos", "coble", "cv", "intersection"})
        .doc(
            "neck radius from the overlap: Kratos 1.43 sqrt(r_min^2 - x^2), Coble, constant volume, or the circle where the two "
            "spheres meet, sqrt(r_i^2 - x_i^2) with x_i the radical plane's distance (with mass_conserving_radii)");
    s.add("sintering_radius", &P::sintering_radius)
        .choices({"r_min", "r_eff", "two_r_eff"})
        .doc("R of the driving force for unequal spheres");
    s.add("cold_necks", &P::cold_necks)
        .choices({"bonded", "contact"})
        .doc("a neck below the start temperature: elastic bond (tension too) or frictional contact");
    s.add("creep_overlap_limit", &P::creep_overlap_limit).unit("1").positive().doc("creep: the dashpot stops at overlap h = this x r_min");
    s.add("neck_stiffness", &P::neck_stiffness)
        .choices({"elastic_approach", "neck_radius"})
        .doc(
            "spring of a pair with a neck: Hertz on the elastic approach, 2 E* sqrt(R* |h - u_s|) (the Kratos code), or the bonded "
            "circular contact of the neck, 2 E* max(a, sqrt(R* |h - u_s|)) (Johnson, Contact Mechanics, 1985, section 5.2: a flat circular "
            "junction of radius a is 2 E* a stiff); tangential 8 G* times the same radius");
    s.add("creep_stop_gb_fraction", &P::creep_stop_gb_fraction)
        .unit("1")
        .nonnegative()
        .doc(
            "creep: the dashpot of a pair also stops once either particle's grain-boundary fraction sum a^2 / (4 r^2) over its necks "
            "reaches this (seed 000 Eq. 22-23: 1 = the particle's surface all grain boundary, full density); 0: never");
    s.add("stop_flow_at_dense", &P::stop_flow_at_dense)
        .doc(
            "a pair stops flowing (driving force and dashpots, before and after a_eq) once either particle is dense: its surface closed "
            "by its necks (the particle flag written by the module mass_conserving_radii, which then also holds it incompressible); "
            "the exact-geometry form of creep_stop_gb_fraction for grown particles");
    s.add("powerlaw_creep_rate", &P::powerlaw_creep_rate)
        .unit("1/s")
        .nonnegative()
        .doc(
            "eps_dot_0 of the power-law creep branch in parallel with the grain-boundary dashpot (rates add): "
            "hdot = (a / c^2) eps_dot_0(T) (F / (beta pi a^2 sigma_0))^n, Storakers, Biwa & Larsson 1997; the strain rate at "
            "powerlaw_creep_stress and powerlaw_creep_temperature; 0: no power-law creep");
    s.add("powerlaw_creep_stress", &P::powerlaw_creep_stress).unit("Pa").positive().doc("sigma_0, the reference stress of eps_dot_0");
    s.add("powerlaw_creep_exponent", &P::powerlaw_creep_exponent).unit("1").range(1.0, 20.0).doc("n, the stress exponent");
    s.add("powerlaw_creep_activation_energy", &P::powerlaw_creep_activation_energy)
        .unit("J/mol")
        .nonnegative()
        .doc("Q: eps_dot_0(T) = powerlaw_creep_rate exp(-Q/R (1/T - 1/T_ref))");
    s.add("powerlaw_creep_temperature", &P::powerlaw_creep_temperature).unit("K").positive().doc("T_ref of powerlaw_creep_rate");
    s.add("after_equilibrium", &P::after_equilibrium)
        .choices({"frozen", "creep"})
        .doc("neck at a_eq: the dashpot stops (frozen, Kratos) or keeps creeping under load (creep); the driving force stops in both");
    return s;
  }
  /// State: neck radius [m], Maxwell force F_e [N], viscous approach u_s [m], tangential elastic
  /// force [N] (3 values), r_i + r_j at the last evaluation [m] (the thermal approach rate).
  static std::vector<std::string> state_columns() {
    return {"neck_radius", "elastic_force", "viscous_approach", "tangential_fx", "tangential_fy", "tangential_fz", "radius_sum"};
  }
  enum Column { kNeck = 0, kElastic = 1, kViscous = 2, kTangential = 3, kRadiusSum = 6 };
  enum class NeckKind { Kratos, Coble, ConstantVolume, Intersection };
  enum class RadiusKind { Rmin, Reff, TwoReff };

  explicit Sintering(const Params& p)
      : p_(p),
        e_star_(kernel::effective_modulus(p.youngs_modulus, p.poisson_ratio)),
        g_star_(kernel::effective_shear_modulus(p.youngs_modulus, p.poisson_ratio)),
        sin_half_(std::sin(0.5 * p.dihedral_angle)),
        cos_half_(std::cos(0.5 * p.dihedral_angle)),
        neck_kind_(p.neck == "coble"          ? NeckKind::Coble
                   : p.neck == "cv"           ? NeckKind::ConstantVolume
                   : p.neck == "intersection" ? NeckKind::Intersection
                                              : NeckKind::Kratos),
        radius_kind_(p.sintering_radius == "r_eff"       ? RadiusKind::Reff
                     : p.sintering_radius == "two_r_eff" ? RadiusKind::TwoReff
                                                         : RadiusKind::Rmin),
        cold_contact_(p.cold_necks == "contact"),
        creep_(p.after_equilibrium == "creep"),
        neck_spring_(p.neck_stiffness == "neck_radius"),
        power_law_(kernel::PowerLawCreep::of(p.powerlaw_creep_exponent, p.powerlaw_creep_stress)) {
    if (p.creep_stop_gb_fraction > 0.0 && p.stop_flow_at_dense)
      throw ConfigError("/stop_flow_at_dense", "expected one creep stop, found stop_flow_at_dense true and creep_stop_gb_fraction > 0 (set it to 0)");
  }

  bool alive(const double* st) const { return st[kNeck] > 0.0; }
  /// The state column of the neck radius when the law reads the particles' grain-boundary
  /// fractions (creep_stop_gb_fraction > 0), else -1 (ContactModelT then skips the sums).
  int grain_boundary_fraction_column() const { return p_.creep_stop_gb_fraction > 0.0 ? kNeck : -1; }
  /// The particle field ContactModelT reads into ContactGeometry::gb_fraction instead of the Eq. 22
  /// sums (stop_flow_at_dense: the dense flag of mass_conserving_radii, 1 or 0), else empty.
  std::string grain_boundary_fraction_field() const { return p_.stop_flow_at_dense ? "mass_conserving_radii/dense" : ""; }
  /// The run watchdog's default bound on overlap / smaller radius (engine/watchdog.hpp):
  /// densification legitimately drives a pair's centres together up to creep_overlap_limit x r_min
  /// (default 1: the smaller centre on the other's surface) plus the elastic approach; 0.5 r_min
  /// beyond that the spheres have passed through each other, which no sintering stage does.
  double overlap_ratio_bound() const { return std::max(1.0, p_.creep_overlap_limit) + 0.5; }

  /// Neck radius of the geometry [m] (0 for h <= 0), before the pair's history is applied.
  double geometric_neck(double r_i, double r_j, double h) const {
    if (!(h > 0.0)) return 0.0;
    if (neck_kind_ == NeckKind::Coble) return electrical::coble_neck_radius(r_i, r_j, h);
    if (neck_kind_ == NeckKind::ConstantVolume) return electrical::cv_neck_radius(r_i, r_j, h);
    if (neck_kind_ == NeckKind::Intersection) return kernel::intersection_neck_radius(r_i, r_j, h);
    return kernel::kratos_neck_radius(std::min(r_i, r_j), h);
  }
  /// Normal viscosity in physical time [N s/m] at temperature T (+inf below the start).
  double viscosity(double a, double t_K) const {
    if (!(t_K >= p_.sintering_start_temperature)) return std::numeric_limits<double>::infinity();
    return kernel::neck_viscosity(a, effective_diffusivity(t_K));
  }
  /// D_eff(T) of this law, remembered per thread for the last temperature asked: a compact under a
  /// prescribed temperature asks every contact for the same T, and exp(-Q/RT) was a tenth of the
  /// contact pass. The cache is keyed by the law's identity (a number no other law object shares)
  /// and T itself, so the value is the one the kernel returns.
  double effective_diffusivity(double t_K) const {
    thread_local std::uint64_t owner = 0;
    thread_local double t_last = std::numeric_limits<double>::quiet_NaN(), d_last = 0.0;
    if (owner != identity_ || !(t_K == t_last)) {
      d_last = kernel::gb_effective_diffusivity(p_.gb_diffusivity_prefactor, p_.gb_activation_energy, p_.gb_width, p_.atomic_volume, t_K);
      t_last = t_K;
      owner = identity_;
    }
    return d_last;
  }
  double driving_radius(const ContactGeometry& g) const {
    if (radius_kind_ == RadiusKind::Reff) return g.r_eff;
    if (radius_kind_ == RadiusKind::TwoReff) return 2.0 * g.r_eff;
    return std::min(g.r_i, g.r_j);
  }

  /// A dashpot as a line in F over a step: flow rate du_s/dt = F / eta + offset (creep_line).
  struct CreepLine {
    double eta;     ///< [N s/m]
    double offset;  ///< [m/s]
  };

  /// The normal Maxwell element of a particle pair over the next step, from its geometry and
  /// state alone (not from the motion): neck radius, flags, dashpot line, spring, driving force.
  struct NormalElement {
    double T = 0.0;         ///< pair temperature [K]
    bool hot = false;       ///< at or above the sintering start
    bool neck = false;      ///< a > 0
    bool sintering = false; ///< the driving force acts (a < a_eq)
    double a = 0.0;         ///< neck radius [m]
    double eta_n = 0.0;     ///< grain-boundary dashpot, mechanical time [N s/m] (+inf: not flowing)
    double r_spring = 0.0;  ///< radius of the spring's contact [m]
    double kn = 0.0;        ///< spring [N/m]
    CreepLine line;         ///< the dashpot as a line in F (with power-law creep)
    double fs = 0.0;        ///< driving force [N] (attractive magnitude)
  };
  NormalElement normal_element(const ContactGeometry& g, const double* st) const {
    NormalElement e;
    e.T = std::isnan(g.temperature) ? p_.temperature : g.temperature;
    e.hot = e.T >= p_.sintering_start_temperature;
    const double h = g.overlap;
    const double r_min = std::min(g.r_i, g.r_j);
    double a = st[kNeck];
    if (e.hot && h > 0.0) a = std::max({a, geometric_neck(g.r_i, g.r_j, h), p_.min_neck_fraction * r_min});
    e.a = std::min(a, r_min);
    e.neck = e.a > 0.0;
    // A dense particle (its surface closed by its necks, stop_flow_at_dense) has neither a pore to
    // shrink into nor a free surface to drive sintering: its pairs stop flowing altogether.
    const bool closed = p_.stop_flow_at_dense && g.gb_fraction >= 0.5;
    e.sintering = e.hot && e.neck && e.a < r_min * sin_half_ && !closed;
    const bool dense = closed || (p_.creep_stop_gb_fraction > 0.0 && g.gb_fraction >= p_.creep_stop_gb_fraction);
    const bool creeping = e.hot && e.neck && h < p_.creep_overlap_limit * r_min && !dense;
    const bool flowing = e.sintering || (creep_ && creeping);
    // Mechanical-time viscosity: eta / s.
    e.eta_n = flowing ? viscosity(e.a, e.T) / g.time_scale : std::numeric_limits<double>::infinity();
    e.r_spring = spring_radius(g.r_eff, h - st[kViscous], e.a);
    e.kn = 2.0 * e_star_ * e.r_spring;
    e.line = e.neck ? creep_line(st[kElastic], e.a, e.T, g.time_scale, e.eta_n, creeping) : CreepLine{e.eta_n, 0.0};
    if (e.sintering) e.fs = kernel::sintering_force(p_.surface_energy, cos_half_, sin_half_, driving_radius(g), e.a);
    return e;
  }

  /// The pair's normal elastic force after a step of dt as an affine function of its approach rate
  /// v over the step (the centres' approach plus the radii's growth, mechanical time): F_e' = f0 +
  /// c v, exactly what operator() computes (kernel::maxwell_step is affine in v:
  ///   F_e' = F_e e^-x - k dt phi(x) offset + k dt phi(x) v,  x = k dt / eta),
  /// and the driving force F_s, so that the pair pushes its particles apart with f0 + c v - F_s
  /// (numerical damping aside). c -> eta for a fast-relaxing dashpot, k dt for a frozen (elastic)
  /// one; a cold pair without a neck is Hertz on its overlap (c = 0). The inertia-free step of
  /// issue 36 item 1 solves the network of these lines for the particle velocities.
  struct LinearResponse {
    double f0 = 0.0;  ///< [N]
    double c = 0.0;   ///< [N s/m]
    double fs = 0.0;  ///< [N]
  };
  LinearResponse linear_response(const ContactGeometry& g, double dt, const double* st) const {
    const NormalElement e = normal_element(g, st);
    if (!e.neck) return {kernel::hertz_force(e_star_, g.r_eff, std::max(g.overlap - st[kViscous], 0.0)), 0.0, 0.0};
    // maxwell_step's force, F e^-x + k dt phi (v - offset), split into its two parts.
    const kernel::MaxwellFactors m = kernel::maxwell_factors(e.kn, e.line.eta, dt);
    const double c = e.kn * dt * m.phi;
    return {st[kElastic] * m.decay - c * e.line.offset, c, e.fs};
  }

  /// The pair's (or wall contact's) forces after a step of dt as affine functions of its motion
  /// over the step (LinearContact; the inertia-free step of issue 36, engine/integrate/quasi_static.hpp),
  /// exactly what operator() then computes from the solved motion, numerical damping aside:
  ///   normal (a neck):   F_n = f0 + c v - F_s + c g,  {f0, c} of linear_response, g the radii's
  ///                      growth rate since the last call (the law's known part of the approach);
  ///   normal (no neck):  Hertz on the overlap, F(h) + k_H dt v to first order (unilateral);
  ///   tangential:        the Maxwell element (k_t, eta_t) over the step, F_t = F_t e^-x - k_t dt phi(x) v_t
  ///                      (eta_t = +inf: the elastic spring, phi = 1), Coulomb-capped without a neck;
  ///   wall:              Hertz, iterated by the solve on the step's overlap (unilateral), and the
  ///                      tangential -min(k_t dt, wall_friction F_n / |v_t|) v_t: the step's own slip
  ///                      (an inertia-free pass carries no slip history; a contact without a neck likewise).
  /// What operator() does that this leaves out, measured by the force residual of the step
  /// (QuasiStaticStats::max_residual): a contact without a neck takes F(h) at the step start, not
  /// F(h + v dt); a cold bonded neck clipped at zero (cold_necks: contact); the dashpots c (v - du/dt).
  LinearContact linear_contact(const ContactGeometry& g, double dt, const double* st) const {
    LinearContact lc;
    if (g.wall) {
      lc.f0 = kernel::hertz_force(e_star_, g.r_eff, g.overlap);
      lc.c = kernel::hertz_stiffness(e_star_, g.r_eff, g.overlap) * dt;
      const double kt = 8.0 * g_star_ * std::sqrt(g.r_eff * g.overlap);
      lc.ft0 = -kt * in_plane(st + kTangential, g.n);
      lc.ct = kt * dt;
      lc.mu = p_.wall_friction;
      lc.unilateral = true;
      lc.hertz = 4.0 / 3.0 * e_star_ * std::sqrt(g.r_eff);
      lc.overlap = g.overlap;
      return lc;
    }
    const NormalElement e = normal_element(g, st);
    const double radius_sum = g.r_i + g.r_j;
    const double growth = st[kRadiusSum] > 0.0 && dt > 0.0 ? (radius_sum - st[kRadiusSum]) / dt : 0.0;
    if (e.neck) {
      const LinearResponse lr = linear_response(g, dt, st);
      lc.f0 = lr.f0 - lr.fs + lr.c * growth;
      lc.c = lr.c;
      // maxwell_step's flow plus the line's offset, du = dt [(v - off)(1 - phi) + phi F_e / eta + off],
      // v = approach + growth (eta = +inf: phi = 1, no flow).
      const kernel::MaxwellFactors mf = kernel::maxwell_factors(e.kn, e.line.eta, dt);
      const double off = e.line.offset;
      const double creep = std::isfinite(e.line.eta) ? mf.phi * st[kElastic] / e.line.eta : 0.0;
      lc.flow1 = dt * (1.0 - mf.phi);
      lc.flow0 = dt * ((growth - off) * (1.0 - mf.phi) + creep + off);
    } else {
      const double he = std::max(g.overlap - st[kViscous], 0.0);
      lc.f0 = kernel::hertz_force(e_star_, g.r_eff, he);
      lc.c = kernel::hertz_stiffness(e_star_, g.r_eff, he) * dt;
      lc.unilateral = true;
      lc.mu = p_.friction;
      lc.hertz = 4.0 / 3.0 * e_star_ * std::sqrt(g.r_eff);
      lc.overlap = he;
    }
    const double kt = 8.0 * g_star_ * e.r_spring;
    const kernel::MaxwellFactors mf = kernel::maxwell_factors(kt, p_.tangential_factor * e.eta_n, dt);
    lc.ft0 = in_plane(st + kTangential, g.n) * mf.decay;
    lc.ct = kt * dt * mf.phi;
    if (e.neck) {
      const kernel::NeckMoments nm = kernel::neck_rotation_resistance(lc.c, lc.ct, e.a);
      lc.bend = nm.bend;
      lc.twist = nm.twist;
    }
    return lc;
  }
  /// A stored tangential vector turned into the plane normal to n, its length kept (operator()).
  static Vec3 in_plane(const double* v3, const Vec3& n) {
    Vec3 v(v3[0], v3[1], v3[2]);
    const double mag = v.norm();
    v -= v.dot(n) * n;
    const double proj = v.norm();
    return proj > 0.0 ? Vec3(v * (mag / proj)) : v;
  }

  ContactForces operator()(const ContactGeometry& g, const RelativeMotion& m, double dt, double* st) const {
    if (g.wall) return wall_contact(g, m, dt, st);
    const NormalElement e = normal_element(g, st);
    const bool hot = e.hot, neck = e.neck;
    const double eta_n = e.eta_n, kn = e.kn, r_spring = e.r_spring, h = g.overlap;
    double a = e.a;  // zero when the neck breaks below
    const double he = h - st[kViscous];
    // Approach rate of the Maxwell element: the centres' approach plus the radii's growth (thermal
    // expansion changes h at fixed centres: a neck cooled by dT pulls its particles together by
    // alpha dT (r_i + r_j), as the solid it stands for contracts).
    const double radius_sum = g.r_i + g.r_j;
    const double v = -m.vn + (st[kRadiusSum] > 0.0 && dt > 0.0 ? (radius_sum - st[kRadiusSum]) / dt : 0.0);
    st[kRadiusSum] = radius_sum;
    double fe = st[kElastic];
    double us = st[kViscous];
    double fs = 0.0, us_rate = 0.0;
    if (neck) {
      const kernel::MaxwellStep ms = kernel::maxwell_step(fe, kn, e.line.eta, v - e.line.offset, dt);
      fe = ms.force;
      us += ms.flow + e.line.offset * dt;
      us_rate = dt > 0.0 ? ms.flow / dt + e.line.offset : 0.0;
      fs = e.fs;
      if (!hot && cold_contact_) fe = std::max(fe, 0.0);
    } else {
      // Cold contact without a neck: Hertz on the (elastic) overlap.
      fe = kernel::hertz_force(e_star_, g.r_eff, std::max(he, 0.0));
    }
    const double cn = 2.0 * p_.damping_ratio * std::sqrt(g.m_eff * kn);
    double fn = fe + cn * (v - us_rate) - fs;
    // Tangential Maxwell element.
    const double kt = 8.0 * g_star_ * r_spring;
    const double eta_t = p_.tangential_factor * eta_n;
    Vec3 ft(st[kTangential], st[kTangential + 1], st[kTangential + 2]);
    if (!neck && !(g.m_eff > 0.0)) ft.setZero();  // inertia-free pass: no slip carried (linear_contact)
    const double mag = ft.norm();
    ft -= ft.dot(g.n) * g.n;
    const double proj = ft.norm();
    if (proj > 0.0) ft *= mag / proj;
    const double vt = m.vt.norm();
    if (vt > 0.0 || mag > 0.0) {
      // Same exponential step on each component (the element is linear and isotropic in-plane).
      const kernel::MaxwellFactors mf = kernel::maxwell_factors(kt, eta_t, dt);
      ft = ft * mf.decay - kt * dt * mf.phi * m.vt;
    }
    const double ct = 2.0 * p_.damping_ratio * std::sqrt(g.m_eff * kt);
    Vec3 ftot = ft - ct * m.vt;
    if (!neck) {
      const double cap = p_.friction * std::abs(fn);
      const double fm = ftot.norm();
      if (fm > cap) {
        ftot *= fm > 0.0 ? cap / fm : 0.0;
        ft = ftot + ct * m.vt;
      }
    }
    // A neck that breaks in tension stops carrying load at the next step.
    if (neck && p_.neck_strength > 0.0 && -fn > p_.neck_strength * kPi * a * a) {
      a = 0.0;
      fe = 0.0;
      us = 0.0;
      ft.setZero();
    }
    st[kNeck] = neck ? a : 0.0;
    st[kElastic] = neck ? fe : 0.0;
    st[kViscous] = neck ? us : 0.0;
    st[kTangential] = ft[0];
    st[kTangential + 1] = ft[1];
    st[kTangential + 2] = ft[2];
    ContactForces f;
    f.tangential = ftot;
    f.force = fn * g.n + ftot;
    return f;
  }

  // ---- the law over SIMD lanes (issue 63; engine/contact/lanes.hpp) ----
  static constexpr int kLaneState = 7;  ///< the lane path carries all seven state columns
  /// The lane path covers every parameter but power-law creep (its pow per row) and the
  /// constant-volume neck (a Newton solve per row): with those, rows run through operator().
  bool lanes_enabled() const { return !(p_.powerlaw_creep_rate > 0.0) && neck_kind_ != NeckKind::ConstantVolume; }
  /// operator() for the pairs of a block of rows, lane by lane in its order: every branch of the
  /// scalar law (normal_element, maxwell_step, maxwell_factors, the tangential element, the
  /// Coulomb cap of a neckless pair, the neck's break) becomes a select between results computed
  /// as the scalar code computes them, so every lane gives operator()'s bits (the exponentials are
  /// lanemath's in both). Lanes of a row that is not live compute garbage that is never written.
  template <int W>
  [[gnu::always_inline]] void lanes(PairLanes<W, kLaneState>& b, double dt) const {
    alignas(64) double T[W], d_eff[W];
    temperatures_lanes(b, T, d_eff);
    switch (neck_kind_) {
      case NeckKind::Coble: return lanes_for<W, NeckKind::Coble>(b, dt, T, d_eff);
      case NeckKind::Intersection: return lanes_for<W, NeckKind::Intersection>(b, dt, T, d_eff);
      default: return lanes_for<W, NeckKind::Kratos>(b, dt, T, d_eff);
    }
  }

 private:
  /// The pair temperature of every lane (normal_element: the parameter when the field is absent)
  /// and D_eff(T) from effective_diffusivity (std::exp and its per-thread cache: one call when the
  /// block shares one temperature, as under a prescribed one).
  template <int W>
  [[gnu::always_inline]] void temperatures_lanes(const PairLanes<W, kLaneState>& b, double* T, double* d_eff) const {
    bool uniform = true;
    for (int l = 0; l < W; ++l) {
      T[l] = std::isnan(b.temp[l]) ? p_.temperature : b.temp[l];
      uniform = uniform && T[l] == T[0];
    }
    if (uniform) {
      const double d = effective_diffusivity(T[0]);
      for (int l = 0; l < W; ++l) d_eff[l] = d;
    } else {
      for (int l = 0; l < W; ++l) d_eff[l] = effective_diffusivity(T[l]);
    }
  }
  /// geometric_neck of one lane for the neck kind K (the kernels' operations, their h <= 0 branch a select).
  template <NeckKind K>
  [[gnu::always_inline]] static double geometric_neck_lane(double ri, double rj, double r_min, double h) {
    double a;
    if constexpr (K == NeckKind::Coble) {
      const double r_star = 2.0 / (1.0 / ri + 1.0 / rj);
      a = std::sqrt(2.0 * r_star * h);
    } else if constexpr (K == NeckKind::Intersection) {
      const double d = ri + rj - h;
      const double x = (d * d + ri * ri - rj * rj) / (2.0 * d);
      const double y = ri * ri - x * x;
      const double c = std::sqrt(0.0 < y ? y : 0.0);
      a = d > std::abs(ri - rj) ? (c < r_min ? c : r_min) : r_min;
    } else {
      const double hc = 2.0 * r_min < h ? 2.0 * r_min : h;
      const double x = r_min - 0.5 * hc;
      const double y = r_min * r_min - x * x;
      a = 1.43 * std::sqrt(0.0 < y ? y : 0.0);
    }
    return h > 0.0 ? a : 0.0;
  }
  /// What the three stages of the lane path pass on, per lane. Flags are 0/1 numbers in memory: a
  /// flag kept in a register across one big loop was folded by GCC into logic its vectoriser refuses.
  template <int W>
  struct LaneElement {
    alignas(64) double hot[W], neck[W], a[W], eta_n[W], r_spring[W], kn[W], fs[W];  // normal_element
    alignas(64) double fn[W], fe[W], us[W];                                           // the normal step
  };
  template <int W, NeckKind K>
  [[gnu::always_inline]] void lanes_for(PairLanes<W, kLaneState>& b, double dt, const double* T, const double* d_eff) const {
    LaneElement<W> e;
    normal_element_lanes<W, K>(b, T, d_eff, e);
    normal_step_lanes<W>(b, dt, e);
    tangential_lanes<W>(b, dt, e);
  }
  // In the three stages every parameter and input is read into a local before any select (a load
  // under a condition, a masked load, keeps the loop from vectorising), and every switch of the
  // parameters becomes a bound or a weight: a condition common to all lanes, in a select or combined
  // with a lane's condition, turns into control flow the vectoriser refuses. Each bound gives the
  // scalar test's outcome (a bound of +-inf: never; products by 1 and 0 and sums with 0 are exact).

  /// normal_element on every lane: the neck radius, the flags, the dashpot, the spring, the driving force.
  template <int W, NeckKind K>
  [[gnu::always_inline]] void normal_element_lanes(const PairLanes<W, kLaneState>& b, const double* T, const double* d_eff,
                                                   LaneElement<W>& e) const {
    constexpr double inf = std::numeric_limits<double>::infinity();
    const double kn_c = 2.0 * e_star_, fs_c = kPi * p_.surface_energy;
    const double t_start = p_.sintering_start_temperature, min_neck = p_.min_neck_fraction;
    const double sin_half = sin_half_, cos_half = cos_half_, time_scale = b.time_scale;
    const double closed_at = p_.stop_flow_at_dense ? 0.5 : inf;                                // gbf >= it: closed
    const double dense_at = p_.creep_stop_gb_fraction > 0.0 ? p_.creep_stop_gb_fraction : inf;  // gbf >= it: dense
    const double creep_limit = creep_ ? p_.creep_overlap_limit : -inf;                          // h < it r_min: creeping
    const double spring_w = neck_spring_ ? 1.0 : 0.0;                                           // spring radius max(hertz, a w)
    // driving_radius: w_eff r_eff + w_min r_min
    const double w_eff = radius_kind_ == RadiusKind::Reff ? 1.0 : (radius_kind_ == RadiusKind::TwoReff ? 2.0 : 0.0);
    const double w_min = radius_kind_ == RadiusKind::Rmin ? 1.0 : 0.0;
#pragma omp simd
    for (int l = 0; l < W; ++l) {
      const double h = b.delta[l], ri = b.ri[l], rj = b.rj[l], r_eff = b.r_eff[l], gbf = b.gbf[l], d = d_eff[l];
      const bool hot = T[l] >= t_start;
      const double r_min = rj < ri ? rj : ri;
      double a = b.s[kNeck][l];
      const double gn = geometric_neck_lane<K>(ri, rj, r_min, h), mn = min_neck * r_min;
      double grown = a < gn ? gn : a;  // std::max({a, gn, mn}): the first largest
      grown = grown < mn ? mn : grown;
      a = (hot & (h > 0.0)) ? grown : a;
      a = r_min < a ? r_min : a;
      const bool neck = a > 0.0;
      const bool sintering = hot & neck & (a < r_min * sin_half) & (gbf < closed_at);
      const bool creeping = hot & neck & (h < creep_limit * r_min) & (gbf < closed_at) & (gbf < dense_at);  // after_equilibrium: creep
      e.eta_n[l] = sintering | creeping ? kPi * a * a * a * a / (8.0 * d) / time_scale : inf;
      const double hertz_r = std::sqrt(r_eff * std::abs(h - b.s[kViscous][l]));
      const double r_spring = hertz_r < a * spring_w ? a : hertz_r;
      e.r_spring[l] = r_spring;
      e.kn[l] = kn_c * r_spring;
      const double drive_r = w_eff * r_eff + w_min * r_min;
      e.fs[l] = sintering ? fs_c * (4.0 * drive_r * (1.0 - cos_half) + a * sin_half) : 0.0;
      e.a[l] = a;
      e.hot[l] = hot ? 1.0 : 0.0;
      e.neck[l] = neck ? 1.0 : 0.0;
    }
  }

  /// operator()'s normal force on every lane: the Maxwell step of a neck (maxwell_step) or Hertz
  /// on the elastic overlap (no neck), the numerical damper and the driving force.
  template <int W>
  [[gnu::always_inline]] void normal_step_lanes(PairLanes<W, kLaneState>& b, double dt, LaneElement<W>& e) const {
    constexpr double inf = std::numeric_limits<double>::infinity();
    const double two_damping = 2.0 * p_.damping_ratio, hertz_c = 4.0 / 3.0 * e_star_;
    const double cold_floor = cold_contact_ ? 0.0 : -inf;  // a cold neck's F_e below it: 0
    const double rate_floor = dt > 0.0 ? 0.0 : inf;        // r_i + r_j before > it: its rate
    const double dt_rate = dt > 0.0 ? dt : inf;            // u_s rate du / dt_rate (0 at dt = 0)
#pragma omp simd
    for (int l = 0; l < W; ++l) {
      const double h = b.delta[l], r_eff = b.r_eff[l], m_eff = b.m_eff[l], eta_n = e.eta_n[l], kn = e.kn[l];
      const double fe0 = b.s[kElastic][l], us0 = b.s[kViscous][l], rs_old = b.s[kRadiusSum][l];
      const bool neck = e.neck[l] != 0.0, hot = e.hot[l] != 0.0;
      const double radius_sum = b.ri[l] + b.rj[l];
      const double v = -b.vn[l] + (rs_old > rate_floor ? (radius_sum - rs_old) / dt : 0.0);
      b.s[kRadiusSum][l] = radius_sum;
      const double vv = v - 0.0;  // v - the creep line's offset (0 without power-law creep)
      const kernel::MaxwellFactors mf = kernel::maxwell_factors(kn, eta_n, dt);
      const bool elastic = !(eta_n < inf), instant = !(eta_n > 0.0);
      const double f_visc = fe0 * mf.decay + kn * vv * dt * mf.phi;
      const double u_visc = dt * (vv * (1.0 - mf.phi) + mf.phi * fe0 / eta_n);
      const double f_step = elastic ? fe0 + kn * vv * dt : (instant ? 0.0 : f_visc);
      const double u_step = elastic ? 0.0 : (instant ? vv * dt + (kn > 0.0 ? fe0 / kn : 0.0) : u_visc);
      const double fe_neck = f_step < (hot ? -inf : cold_floor) ? 0.0 : f_step;
      const double he_raw = h - us0, he = he_raw < 0.0 ? 0.0 : he_raw;
      const double fe = neck ? fe_neck : hertz_c * std::sqrt(r_eff * he) * he;
      const double us_rate = neck ? u_step / dt_rate + 0.0 : 0.0;
      const double fs = neck ? e.fs[l] : 0.0;
      const double cn = two_damping * std::sqrt(m_eff * kn);
      e.fn[l] = fe + cn * (v - us_rate) - fs;
      e.fe[l] = fe;
      e.us[l] = neck ? us0 + (u_step + 0.0 * dt) : us0;
      // An inertia-free pass carries no slip of a pair without a neck (operator()); cleared here, not in
      // tangential_lanes, where GCC threads the zeros into its later tests and stops vectorising.
      const bool no_slip_carried = !neck & !(m_eff > 0.0);
      b.s[kTangential][l] = no_slip_carried ? 0.0 : b.s[kTangential][l];
      b.s[kTangential + 1][l] = no_slip_carried ? 0.0 : b.s[kTangential + 1][l];
      b.s[kTangential + 2][l] = no_slip_carried ? 0.0 : b.s[kTangential + 2][l];
    }
  }

  /// operator()'s tangential element on every lane (its stored force turned into the tangent plane,
  /// the Maxwell step, the damper, the Coulomb cap of a pair without a neck), the neck's break,
  /// the new state and the force on i.
  template <int W>
  [[gnu::always_inline]] void tangential_lanes(PairLanes<W, kLaneState>& b, double dt, const LaneElement<W>& e) const {
    constexpr double inf = std::numeric_limits<double>::infinity();
    const double two_damping = 2.0 * p_.damping_ratio, kt_c = 8.0 * g_star_;
    const double tangential_factor = p_.tangential_factor, friction = p_.friction;
    const double strength = p_.neck_strength > 0.0 ? p_.neck_strength : inf;  // -F_n > it pi a^2: broken
#pragma omp simd
    for (int l = 0; l < W; ++l) {
      const double m_eff = b.m_eff[l], a = e.a[l], fn = e.fn[l];
      const bool neck = e.neck[l] != 0.0, no_neck = e.neck[l] == 0.0;
      const double kt = kt_c * e.r_spring[l], eta_t = tangential_factor * e.eta_n[l];
      double fx = b.s[kTangential][l], fy = b.s[kTangential + 1][l], fz = b.s[kTangential + 2][l];
      const double nx = b.nx[l], ny = b.ny[l], nz = b.nz[l];
      const double mag = std::sqrt((fx * fx + fy * fy) + fz * fz);
      const double dot = (fx * nx + fy * ny) + fz * nz;
      fx = fx - dot * nx;
      fy = fy - dot * ny;
      fz = fz - dot * nz;
      const double proj = std::sqrt((fx * fx + fy * fy) + fz * fz);
      const double stretch = mag / proj;
      fx = proj > 0.0 ? fx * stretch : fx;
      fy = proj > 0.0 ? fy * stretch : fy;
      fz = proj > 0.0 ? fz * stretch : fz;
      const double vtx = b.vtx[l], vty = b.vty[l], vtz = b.vtz[l];
      const double vt = std::sqrt((vtx * vtx + vty * vty) + vtz * vtz);
      const kernel::MaxwellFactors mt = kernel::maxwell_factors(kt, eta_t, dt);
      const double ck = kt * dt * mt.phi;
      const bool moving = (vt > 0.0) | (mag > 0.0);
      fx = moving ? fx * mt.decay - ck * vtx : fx;
      fy = moving ? fy * mt.decay - ck * vty : fy;
      fz = moving ? fz * mt.decay - ck * vtz : fz;
      const double ct = two_damping * std::sqrt(m_eff * kt);
      double tx = fx - ct * vtx, ty = fy - ct * vty, tz = fz - ct * vtz;
      // Coulomb cap of a pair without a neck
      const double cap = friction * std::abs(fn);
      const double fm = std::sqrt((tx * tx + ty * ty) + tz * tz);
      const bool capped = no_neck & (fm > cap);
      const double shrink = fm > 0.0 ? cap / fm : 0.0;
      tx = capped ? tx * shrink : tx;
      ty = capped ? ty * shrink : ty;
      tz = capped ? tz * shrink : tz;
      fx = capped ? tx + ct * vtx : fx;
      fy = capped ? ty + ct * vty : fy;
      fz = capped ? tz + ct * vtz : fz;
      // a neck broken in tension: its state cleared
      const bool broken = neck & (-fn > strength * kPi * a * a);
      b.s[kNeck][l] = neck ? (broken ? 0.0 : a) : 0.0;
      b.s[kElastic][l] = neck ? (broken ? 0.0 : e.fe[l]) : 0.0;
      b.s[kViscous][l] = neck ? (broken ? 0.0 : e.us[l]) : 0.0;
      b.s[kTangential][l] = broken ? 0.0 : fx;
      b.s[kTangential + 1][l] = broken ? 0.0 : fy;
      b.s[kTangential + 2][l] = broken ? 0.0 : fz;
      b.ftx[l] = tx;
      b.fty[l] = ty;
      b.ftz[l] = tz;
      b.fx[l] = fn * nx + tx;
      b.fy[l] = fn * ny + ty;
      b.fz[l] = fn * nz + tz;
    }
  }

 public:

  /// The dashpot of the normal Maxwell element as a line in F over the step: flow rate
  /// du_s/dt = F / eta + offset (mechanical time). Without power-law creep: {eta_n, 0}. With it, the
  /// rates add, du_s/dt = F / eta_n + hdot_pl(F), and hdot_pl is linearised at the step's F_e
  /// (its tangent, the Newton step of the implicit update): hdot_pl(F) ~ (n r / F_e) F + (1 - n) r,
  /// r = hdot_pl(F_e), so the element stays linear and kernel::maxwell_step integrates it exactly
  /// with the approach rate v - offset.
  CreepLine creep_line(double fe, double a, double t_K, double time_scale, double eta_n, bool creeping) const {
    if (!(p_.powerlaw_creep_rate > 0.0) || !creeping || !(fe > 0.0)) return {eta_n, 0.0};
    const double rate0 = kernel::arrhenius_rate(p_.powerlaw_creep_rate, p_.powerlaw_creep_activation_energy,
                                                p_.powerlaw_creep_temperature, t_K);
    const double r = time_scale * power_law_.rate(fe, a, rate0);
    if (!(r > 0.0)) return {eta_n, 0.0};
    const double slope = power_law_.n * r / fe;  // d hdot / dF [m/(N s)]
    return {1.0 / (1.0 / eta_n + slope), (1.0 - power_law_.n) * r};
  }

  /// Particle-wall: Hertz + damping + Coulomb friction (elastic tangential spring with history).
  ContactForces wall_contact(const ContactGeometry& g, const RelativeMotion& m, double dt, double* st) const {
    const double kn = kernel::hertz_stiffness(e_star_, g.r_eff, g.overlap);
    const double fn = kernel::hertz_force(e_star_, g.r_eff, g.overlap) - 2.0 * p_.damping_ratio * std::sqrt(g.m_eff * kn) * m.vn;
    const double kt = 8.0 * g_star_ * std::sqrt(g.r_eff * g.overlap);
    const double gt = 2.0 * p_.damping_ratio * std::sqrt(g.m_eff * kt);
    // History column kTangential.. holds the tangential displacement for walls. An inertia-free pass
    // (m* = 0, a quasi-static stage) carries no slip from step to step: F_t = -min(k_t dt, mu F_n / |v_t|) v_t,
    // the regularised Coulomb law the solve balances (linear_contact; engine/integrate/quasi_static.cpp).
    if (!(g.m_eff > 0.0)) std::fill(st + kTangential, st + kTangential + 3, 0.0);
    ContactForces f;
    f.tangential = kernel::tangential_history(g.n, m.vt, kt, gt, p_.wall_friction, std::abs(fn), dt, st + kTangential);
    f.force = fn * g.n + f.tangential;
    return f;
  }

  /// Contact radius of the spring [m]: the Hertz radius of the elastic approach sqrt(R* |h - u_s|),
  /// or (neck_stiffness = neck_radius) the larger of it and the neck radius a.
  double spring_radius(double r_eff, double elastic_approach, double a) const {
    const double hertz = std::sqrt(r_eff * std::abs(elastic_approach));
    return neck_spring_ ? std::max(hertz, a) : hertz;
  }
  /// Stiffness of a live pair (the Gershgorin rows): 2 E* and 8 G* times spring_radius.
  double normal_stiffness(const ContactGeometry& g, const double* st) const {
    return 2.0 * e_star_ * spring_radius(g.r_eff, g.overlap - st[kViscous], st[kNeck]);
  }
  double tangential_stiffness(const ContactGeometry& g, const double* st) const {
    return 8.0 * g_star_ * spring_radius(g.r_eff, g.overlap - st[kViscous], st[kNeck]);
  }
  /// Numerical dashpots of a live pair {c_n, c_t} [N s/m] (the explicit-damping step limit).
  std::pair<double, double> damping(const ContactGeometry& g, const double* st) const {
    return {2.0 * p_.damping_ratio * std::sqrt(g.m_eff * normal_stiffness(g, st)),
            2.0 * p_.damping_ratio * std::sqrt(g.m_eff * tangential_stiffness(g, st))};
  }
  double normal_stiffness(const ContactGeometry& g) const { return kernel::hertz_stiffness(e_star_, g.r_eff, std::abs(g.overlap)); }
  double tangential_stiffness(const ContactGeometry& g) const { return 8.0 * g_star_ * std::sqrt(g.r_eff * std::abs(g.overlap)); }
  double rayleigh_dt(double radius, double density) const {
    return kernel::rayleigh_step(radius, density, p_.youngs_modulus, p_.poisson_ratio);
  }
  const Params& params() const { return p_; }

 private:
  Params p_;
  double e_star_, g_star_, sin_half_, cos_half_;
  /// A number no other law object constructed in this process shares (copies share it, with the
  /// same parameters): the key of effective_diffusivity's per-thread cache.
  std::uint64_t identity_ = [] {
    static std::atomic<std::uint64_t> next{0};
    return ++next;
  }();
  NeckKind neck_kind_;
  RadiusKind radius_kind_;
  bool cold_contact_;
  bool creep_;
  bool neck_spring_;  ///< neck_stiffness = neck_radius
  kernel::PowerLawCreep power_law_;
};

}  // namespace sparkdem::physics
