#pragma once
/// # ptc_temperature — matrix eigenstrain eps0(T) of a semicrystalline polymer host
///
/// Source: /work/shared/physics/cpc-and-networks.md §1.6 "Temperature coupling" (not in seed
/// 002, which imposes eps0 directly): eps0(T) = integral_{T_ref}^{T} alpha_m dT', optionally
/// with a jump at the polymer melting point. eps0 is the LINEAR eigenstrain of the matrix
/// relative to the fillers (the fillers are rigid and non-expanding in the model, so alpha_m is
/// the matrix-filler mismatch alpha_polymer - alpha_filler).
///
/// MODEL. A smoothed step S(T) centred on the melting point T_m [K] of width w [K]:
///     x = (T - T_m) / w + 1/2,   S = 0 (x <= 0),  3 x^2 - 2 x^3 (0 < x < 1),  1 (x >= 1)
/// (cubic smoothstep: S and S' continuous; w = 0 is the sharp step S = H(T - T_m), S(T_m) = 0).
/// The expansion coefficient switches from alpha_s (solid, below melt) to alpha_l (melt) with the
/// same step, alpha(T) = alpha_s + (alpha_l - alpha_s) S(T), and melting adds the linear strain
/// jump Delta_m (a volume change Delta V / V on melting gives Delta_m ~ Delta V / (3 V)):
///     G(T) = alpha_s (T - T_m) + (alpha_l - alpha_s) I(T) + Delta_m S(T),
///     I(T) = integral_{-inf}^{T} S dT' = 0 (x <= 0),  w (x^3 - x^4 / 2) (0 < x < 1),
///            T - T_m (x >= 1)            [w (1 - 1/2) = w / 2 at x = 1 = T_m + w / 2 - T_m]
///     eps0(T) = G(T) - G(T_ref).
/// Without melting (Delta_m = 0 and alpha_l = alpha_s) eps0 = alpha_s (T - T_ref).
///
/// INVERSE. For alpha_s, alpha_l > 0 and Delta_m >= 0, eps0 is strictly increasing (sharp step:
/// increasing with a jump of Delta_m at T_m), so every strain has one temperature
///     T(eps) = min { T : eps0(T) >= eps }
/// (the sharp jump: every eps inside [eps0(T_m), eps0(T_m) + Delta_m] maps to T_m). Outside the
/// step the inverse is linear; inside, bisection to machine precision.
namespace sparkdem::physics::ptc {

struct ThermalStrainLaw {
  double alpha_solid = 2e-4;              ///< alpha_s [1/K], > 0
  double alpha_melt = 2e-4;               ///< alpha_l [1/K], > 0 (above the melting step)
  double reference_temperature = 293.15;  ///< T_ref [K]: eps0(T_ref) = 0
  double melting_temperature = 0.0;       ///< T_m [K]; 0 = no melting step (alpha_s everywhere)
  double melting_strain = 0.0;            ///< Delta_m [1] >= 0: linear strain jump on melting
  double melting_width = 0.0;             ///< w [K] >= 0 (0: sharp)
};

/// Throws SetupError unless alpha_s, alpha_l > 0, Delta_m >= 0, w >= 0, T_ref > 0, T_m >= 0.
void validate(const ThermalStrainLaw& law);

/// S(T) [1] of the header (0 without a melting step).
double melting_fraction(const ThermalStrainLaw& law, double T);

/// eps0(T) [1] of the header.
double thermal_strain(const ThermalStrainLaw& law, double T);

/// The temperature [K] at which eps0 first reaches eps (header: T(eps)); eps may be negative
/// (T < T_ref).
double temperature_at_strain(const ThermalStrainLaw& law, double eps);

}  // namespace sparkdem::physics::ptc
