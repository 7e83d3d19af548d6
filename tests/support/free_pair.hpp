#pragma once
/// Two equal spheres sintering free of load: the law's parameters and the closed form of their
/// neck growth, written out independently of the law's kernels (tests of the sintering law and of
/// the inertia-free path).
#include <cmath>
#include <numbers>
#include <random>

#include "physics/contact/sintering.hpp"
#include "support/scene.hpp"

namespace sparkdem::test::free_pair {

using physics::Sintering;

// Equal spheres, NiAl-like density, a stiff modulus so that the elastic approach is small.
constexpr double kR = 1e-6, kRho = 5900.0, kT = 1500.0;

/// The pair's initial overlap [m].
constexpr double kH0 = 0.002 * kR;
/// The two spheres, centred on the origin along x, overlapping by kH0.
inline void add_pair(State& s) {
  add_sphere(s, Vec3(-(kR - 0.5 * kH0), 0, 0), kR, kRho);
  add_sphere(s, Vec3(kR - 0.5 * kH0, 0, 0), kR, kRho);
}

/// A 3 x 3 x 3 cube of spheres `spacing` x kR apart, each moved by up to 0.03 kR per axis, radii
/// kR (r_centre +- r_half_width) (uniform; std::mt19937_64 seed 7): the sintering cluster of the
/// inertia-free and mass-conserving tests.
inline void add_cluster27(State& s, double spacing, double r_centre, double r_half_width) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k)
        add_sphere(s, spacing * kR * Vec3(i, j, k) + 0.03 * kR * Vec3(u(rng), u(rng), u(rng)), kR * (r_centre + r_half_width * u(rng)), kRho);
}

inline Sintering::Params law_params() {
  Sintering::Params p;
  p.youngs_modulus = 1e12;
  p.poisson_ratio = 0.3;
  p.surface_energy = 2.0;
  p.dihedral_angle = 2.5;
  p.gb_diffusivity_prefactor = 1e-5;
  p.gb_activation_energy = 1e5;
  p.gb_width = 5e-10;
  p.atomic_volume = 1.2e-29;
  p.sintering_start_temperature = 1000.0;
  p.temperature = kT;
  p.min_neck_fraction = 0.01;
  p.neck = "kratos";
  return p;
}

// The closed-form rate, written out independently of the law's kernels:
//   a(h)   = 1.43 sqrt(r^2 - (r - h/2)^2)                (Kratos neck, equal spheres)
//   D_eff  = D0 exp(-Q/(R T)) delta_b Omega / (k_B T)
//   eta(a) = pi a^4 / (8 D_eff)
//   F_s(a) = pi gamma [4 r (1 - cos(psi/2)) + a sin(psi/2)]
//   dh/dt  = F_s / eta            (free pair: the dashpot carries the whole driving force)
inline double neck_of(double h) { return 1.43 * std::sqrt(kR * kR - (kR - 0.5 * h) * (kR - 0.5 * h)); }
inline double rate(double h) {
  const auto p = law_params();
  const double d_eff = p.gb_diffusivity_prefactor * std::exp(-p.gb_activation_energy / (8.314462618 * kT)) * p.gb_width * p.atomic_volume /
                       (1.380649e-23 * kT);
  const double a = neck_of(h);
  const double eta = std::numbers::pi * std::pow(a, 4) / (8.0 * d_eff);
  const double fs = std::numbers::pi * p.surface_energy *
                    (4.0 * kR * (1.0 - std::cos(0.5 * p.dihedral_angle)) + a * std::sin(0.5 * p.dihedral_angle));
  return fs / eta;
}
inline double rk4(double h, double t0, double t1, int n) {
  const double dt = (t1 - t0) / n;
  for (int s = 0; s < n; ++s) {
    const double k1 = rate(h), k2 = rate(h + 0.5 * dt * k1), k3 = rate(h + 0.5 * dt * k2), k4 = rate(h + dt * k3);
    h += dt / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4);
  }
  return h;
}

}  // namespace sparkdem::test::free_pair
