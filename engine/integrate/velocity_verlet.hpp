#pragma once
/// Velocity-Verlet for translation and rotation of spheres (isotropic inertia).
///   v(n+1/2) = v(n) + dt/2 F(n)/m,  x(n+1) = x(n) + dt v(n+1/2),  v(n+1) = v(n+1/2) + dt/2 F(n+1)/m
///   w likewise with T/I; the orientation is advanced by the exact rotation of angle |w| dt
///   about w: q(n+1) = exp(dt w(n+1/2) / 2) q(n), renormalised (rotation_quaternion).
#include <cmath>

#include "engine/state/particle_store.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem {

/// The unit quaternion of the rotation by angle |w| dt about w (w != 0) [rad/s, s], from
/// w2 = |w|^2: (cos(h), sin(h) w/|w|), h = |w| dt / 2. A sphere turns by a small angle per step:
/// below h = 0.01 the Taylor series to the ninth power (remainder < h^10 / 10! < 3e-27, far below
/// the rounding of the result) replaces sin and cos, and since cos(h) and sin(h)/|w| =
/// (dt/2) sin(h)/h are series in h^2 = w2 dt^2 / 4 alone, that branch takes no square root and no
/// division (the costliest part of the step of a spinning bed: a sincos, a square root and a
/// division per particle per step).
inline Quat rotation_quaternion(const Vec3& w, double w2, double dt) {
  const double h2 = 0.25 * w2 * dt * dt;
  double sw, c;
  if (h2 < 1e-4) {  // h < 1e-2; reciprocals folded at compile time: multiplications, not divisions
    sw = 0.5 * dt * (1.0 - h2 * (1.0 / 6.0) * (1.0 - h2 * (1.0 / 20.0) * (1.0 - h2 * (1.0 / 42.0) * (1.0 - h2 * (1.0 / 72.0)))));
    c = 1.0 - h2 * 0.5 * (1.0 - h2 * (1.0 / 12.0) * (1.0 - h2 * (1.0 / 30.0) * (1.0 - h2 * (1.0 / 56.0))));
  } else {
    const double norm_w = std::sqrt(w2), h = 0.5 * norm_w * dt;
    sw = std::sin(h) / norm_w;
    c = std::cos(h);
  }
  return Quat(c, sw * w.x(), sw * w.y(), sw * w.z());
}

/// q brought back to unit length after a product of unit quaternions, whose length is 1 + e with
/// e of the order of the rounding (1e-16): one Newton step of 1/sqrt(x) at x = |q|^2 from 1,
/// q (3 - |q|^2) / 2, leaves |q| - 1 = O(e^2), with no square root and no division.
inline Quat renormalised(const Quat& q) {
  Quat r = q;
  r.coeffs() *= 0.5 * (3.0 - q.coeffs().squaredNorm());
  return r;
}

/// Half kick and drift, then the forces and torques cleared for the step's force passes (the
/// last read of the old ones is this kick; the plan's items between it and the pair pass, walls
/// and neighbours, read none: engine/schedule/scheduler.hpp). One pass over the particle arrays
/// instead of two. The arrays are read through local pointers: stores through the ParticleStore's
/// vectors would otherwise make the compiler reload every array's base on each particle (declared in the
/// region's body: captured by the lambda, they would be read through its closure).
inline void verlet_first_half(ParticleStore& p, double dt) {
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  par::region(par::worth(n, par::kLight), [&] {
    Vec3* __restrict x = p.position.data();
    Vec3* __restrict v = p.velocity.data();
    Vec3* __restrict w = p.omega.data();
    Vec3* __restrict f = p.force.data();
    Vec3* __restrict t = p.torque.data();
    Quat* __restrict q = p.orientation.data();
    const double* __restrict m = p.mass.data();
    const double* __restrict inertia = p.inertia.data();
    const std::int32_t* __restrict fixed = p.fixed.data();
    const double h = dt;
#pragma omp for schedule(static) nowait
    for (std::int64_t i = 0; i < n; ++i) {
      if (fixed[i]) {                                // prescribed velocity (zero = frozen): moved, not integrated
        if (fixed[i] == 1) x[i] += h * v[i];         // 2: a rotating set, moved by the simulation
      } else {
        v[i] += 0.5 * h / m[i] * f[i];
        x[i] += h * v[i];
        w[i] += 0.5 * h / inertia[i] * t[i];
        const double w2 = w[i].squaredNorm();
        if (w2 > 0.0 && h > 0.0)  // most spheres of a settling bed do not spin
          q[i] = renormalised(rotation_quaternion(w[i], w2, h) * q[i]);
      }
      f[i].setZero();
      t[i].setZero();
    }
  });
}

inline void verlet_second_half(ParticleStore& p, double dt) {
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  par::region(par::worth(n, par::kLight), [&] {
    Vec3* __restrict v = p.velocity.data();
    Vec3* __restrict w = p.omega.data();
    const Vec3* __restrict f = p.force.data();
    const Vec3* __restrict t = p.torque.data();
    const double* __restrict m = p.mass.data();
    const double* __restrict inertia = p.inertia.data();
    const std::int32_t* __restrict fixed = p.fixed.data();
    const double h = dt;
#pragma omp for schedule(static) nowait
    for (std::int64_t i = 0; i < n; ++i) {
      if (fixed[i]) continue;
      v[i] += 0.5 * h / m[i] * f[i];
      w[i] += 0.5 * h / inertia[i] * t[i];
    }
  });
}

}  // namespace sparkdem
