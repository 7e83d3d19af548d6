#pragma once
/// Heat-conduction kernels of the particle network (issue 6). Pure functions, SI units:
/// temperatures [K], heat capacities [J/K], conductances [W/K], powers [W], energies [J].
///
/// MODEL (seed 001 = Hubert et al. 2017 §2.3, cohesive-joule-torsion.md §5; the network
/// conductances come from physics/electrical/branch_models.hpp with lambda in place of kappa):
///   C_i dT_i/dt = eta P_i + F_i - Q_i(T_i) - sum_j G_ij (T_i - T_j)                 (Eq. 16)
///     C_i   heat capacity of particle i (capacity conventions below)
///     P_i   electrical (Joule) power dissipated in particle i [W]; eta the fraction turned into heat
///     F_i   prescribed heat flow into i [W]
///     Q_i   loss to the ambient: h A_i (T_i - T_a) + eps sigma A_i (T_i^4 - T_a^4)
///     G_ij  branch thermal conductance [W/K] (transmission surface: lambda S_ij / l_ij, Eq. 16's
///           conduction term; sintered neck; Batchelor-O'Brien 2 lambda a)
/// Each conduction flux G_ij (T_j - T_i) is antisymmetric, so conduction conserves energy.
///
/// Heat capacity conventions (§5 "mass consistency"):
///   sphere           C_i = rho c (4/3) pi r_i^3                (the particle's own matter)
///   volume_fraction  C_i = rho c (4/3) pi r_i^3 / f_v,i        (GranOO, seed 001 Eq. 13: the
///                    element stands for its polyhedral cell; f_v,i = f(e_i) f_v(n_i), §3.2-3.3)
///   domain           C_i = rho c (4/3) pi r_i^3 V_d / sum_k V_k (the capacities sum to that of
///                    the continuum domain of volume V_d)
///
/// Explicit step (forward Euler): T_i <- T_i + dt / C_i (eta P_i + F_i - Q_i - (L T)_i). Stable and
/// monotone (no new extrema) for
///   dt <= min_i C_i / (sum_j G_ij + dQ_i/dT_i),   dQ/dT = h A + 4 eps sigma A T^3      (Gershgorin)
/// (every eigenvalue of C^-1 (L + Q') lies in [0, 2 max_i D_i / C_i]; the forward-Euler limit
/// 2/lambda_max is therefore never below this bound; §5's "stricter stability bound").
/// Implicit step (backward Euler, unconditionally stable), with the radiation linearised at T^n:
///   (C_i/dt + b_i) T_i^{n+1} + (L T^{n+1})_i = C_i T_i^n / dt + eta P_i + F_i - a_i,
///   Q_i(T) ~ a_i + b_i T,  b_i = h A_i + 4 eps sigma A_i (T_i^n)^3,
///   a_i = -h A_i T_a + eps sigma A_i ((T_i^n)^4 - T_a^4) - 4 eps sigma A_i (T_i^n)^4.
#include <cmath>

#include "engine/core/numbers.hpp"

namespace sparkdem::physics::thermal {

inline constexpr double kStefanBoltzmann = 5.670374419e-8;  ///< [W/(m^2 K^4)] (CODATA 2018, exact)

/// Heat capacity of a sphere of radius r [m]: rho [kg/m^3] c [J/(kg K)] (4/3) pi r^3 [J/K].
inline double sphere_heat_capacity(double rho_kg_m3, double c_J_kgK, double r_m) {
  return rho_kg_m3 * c_J_kgK * 4.0 / 3.0 * kPi * r_m * r_m * r_m;
}

/// Heat lost to the ambient [W]: convection h A (T - T_a) plus radiation eps sigma A (T^4 - T_a^4).
inline double ambient_loss(double h_W_m2K, double emissivity, double area_m2, double T_K, double ambient_K) {
  const double T2 = T_K * T_K, A2 = ambient_K * ambient_K;
  return h_W_m2K * area_m2 * (T_K - ambient_K) + emissivity * kStefanBoltzmann * area_m2 * (T2 * T2 - A2 * A2);
}

/// dQ/dT of ambient_loss [W/K]: h A + 4 eps sigma A T^3 (the loss's contribution to the
/// stability bound and the slope of its linearisation).
inline double ambient_loss_slope(double h_W_m2K, double emissivity, double area_m2, double T_K) {
  return h_W_m2K * area_m2 + 4.0 * emissivity * kStefanBoltzmann * area_m2 * T_K * T_K * T_K;
}

/// Exact temperature difference of two capacities C1, C2 [J/K] joined by G [W/K] after time t [s]
/// from an initial difference dT0: dT(t) = dT0 exp(-t / tau), tau = C1 C2 / (G (C1 + C2)).
inline double two_body_time_constant(double C1, double C2, double G) { return C1 * C2 / (G * (C1 + C2)); }

/// Steady temperature of a rod of length L [m] and conductivity k [W/(m K)] held at T0 at both
/// ends with a uniform heat source q [W/m^3]: T(x) = T0 + q x (L - x) / (2 k).
inline double parabolic_rod_temperature(double T0_K, double q_W_m3, double L_m, double k_W_mK, double x_m) {
  return T0_K + q_W_m3 * x_m * (L_m - x_m) / (2.0 * k_W_mK);
}

}  // namespace sparkdem::physics::thermal
