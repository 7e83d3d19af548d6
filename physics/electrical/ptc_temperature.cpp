#include "physics/electrical/ptc_temperature.hpp"

#include <cmath>
#include <string>

#include "engine/core/error.hpp"

namespace sparkdem::physics::ptc {

namespace {
bool has_melting(const ThermalStrainLaw& l) { return l.melting_temperature > 0.0; }

/// I(T) = integral of S from -inf to T [K] (header).
double step_integral(const ThermalStrainLaw& l, double T) {
  if (!has_melting(l)) return 0.0;
  const double w = l.melting_width, Tm = l.melting_temperature;
  if (w <= 0.0) return T > Tm ? T - Tm : 0.0;
  const double x = (T - Tm) / w + 0.5;
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return T - Tm;
  return w * (x * x * x - 0.5 * x * x * x * x);
}

/// G(T) of the header [1].
double G(const ThermalStrainLaw& l, double T) {
  return l.alpha_solid * (T - l.melting_temperature) + (l.alpha_melt - l.alpha_solid) * step_integral(l, T) +
         l.melting_strain * melting_fraction(l, T);
}
}  // namespace

void validate(const ThermalStrainLaw& l) {
  auto bad = [](const std::string& what) { throw SetupError("ptc thermal strain law: " + what); };
  if (!(l.alpha_solid > 0.0) || !std::isfinite(l.alpha_solid)) bad("expansion coefficient (solid) must be > 0 [1/K]");
  if (!(l.alpha_melt > 0.0) || !std::isfinite(l.alpha_melt)) bad("expansion coefficient (melt) must be > 0 [1/K]");
  if (!(l.reference_temperature > 0.0) || !std::isfinite(l.reference_temperature)) bad("reference temperature must be > 0 [K]");
  if (!(l.melting_temperature >= 0.0) || !std::isfinite(l.melting_temperature)) bad("melting temperature must be >= 0 [K] (0: none)");
  if (!(l.melting_strain >= 0.0) || !std::isfinite(l.melting_strain)) bad("melting strain jump must be >= 0 [1]");
  if (!(l.melting_width >= 0.0) || !std::isfinite(l.melting_width)) bad("melting width must be >= 0 [K]");
}

double melting_fraction(const ThermalStrainLaw& l, double T) {
  if (!has_melting(l)) return 0.0;
  const double w = l.melting_width, Tm = l.melting_temperature;
  if (w <= 0.0) return T > Tm ? 1.0 : 0.0;
  const double x = (T - Tm) / w + 0.5;
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  return x * x * (3.0 - 2.0 * x);
}

double thermal_strain(const ThermalStrainLaw& l, double T) { return G(l, T) - G(l, l.reference_temperature); }

double temperature_at_strain(const ThermalStrainLaw& l, double eps) {
  if (!std::isfinite(eps)) return eps;  // +inf strain: never reached; -inf: anything
  if (!has_melting(l)) return l.reference_temperature + eps / l.alpha_solid;
  const double w = l.melting_width, Tm = l.melting_temperature;
  const double lo = Tm - 0.5 * w, hi = Tm + 0.5 * w;
  const double e_lo = thermal_strain(l, lo);
  // Just above the step (for a sharp step the right limit: S = 1, I = 0).
  const double e_hi = w > 0.0 ? thermal_strain(l, hi) : e_lo + l.melting_strain;
  if (eps <= e_lo) return lo + (eps - e_lo) / l.alpha_solid;
  if (eps > e_hi) return hi + (eps - e_hi) / l.alpha_melt;
  if (w <= 0.0) return Tm;  // inside the sharp jump
  double a = lo, b = hi;    // eps0(a) < eps <= eps0(b), eps0 strictly increasing on [a, b]
  for (int it = 0; it < 200 && b - a > 1e-13 * std::abs(b); ++it) {
    const double m = 0.5 * (a + b);
    (thermal_strain(l, m) >= eps ? b : a) = m;
  }
  return b;
}

}  // namespace sparkdem::physics::ptc
