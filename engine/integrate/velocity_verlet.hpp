#pragma once
/// Velocity-Verlet for translation and rotation of spheres (isotropic inertia).
///   v(n+1/2) = v(n) + dt/2 F(n)/m,  x(n+1) = x(n) + dt v(n+1/2),  v(n+1) = v(n+1/2) + dt/2 F(n+1)/m
///   w likewise with T/I; the orientation is advanced by the exact rotation of angle |w| dt
///   about w: q(n+1) = exp(dt w(n+1/2) / 2) q(n), renormalised (rotation_quaternion).
#include <algorithm>
#include <cmath>

#include "engine/core/simd.hpp"
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

/// The arrays of the first half step, read through local pointers: stores through the
/// ParticleStore's vectors would otherwise make the compiler reload every array's base on each
/// particle.
struct FirstHalfArrays {
  Vec3* __restrict x;
  Vec3* __restrict v;
  Vec3* __restrict w;
  Vec3* __restrict f;
  Vec3* __restrict t;
  Quat* __restrict q;
  const double* __restrict m;
  const double* __restrict inertia;
  const std::int32_t* __restrict fixed;
};

/// One particle's half kick and drift, its forces and torques cleared: the scalar path, and the
/// reference of the lanes (first_half_lanes).
[[gnu::always_inline]] inline void first_half_one(const FirstHalfArrays& a, std::int64_t i, double h) {
  if (a.fixed[i]) {                                  // prescribed velocity (zero = frozen): moved, not integrated
    if (a.fixed[i] == 1) a.x[i] += h * a.v[i];       // 2: a rotating set, moved by the simulation
  } else {
    a.v[i] += 0.5 * h / a.m[i] * a.f[i];
    a.x[i] += h * a.v[i];
    a.w[i] += 0.5 * h / a.inertia[i] * a.t[i];
    const double w2 = a.w[i].squaredNorm();
    if (w2 > 0.0 && h > 0.0)  // most spheres of a settling bed do not spin
      a.q[i] = renormalised(rotation_quaternion(a.w[i], w2, h) * a.q[i]);
  }
  a.f[i].setZero();
  a.t[i].setZero();
}

/// A block of W particles as structure of arrays (entry c * W + l: component c of particle l).
template <int W>
struct FirstHalfBlock {
  alignas(64) double x[3 * W], v[3 * W], w[3 * W], f[3 * W], t[3 * W], m[W], in[W], w2[W];
  alignas(64) double q[4 * W];  ///< x, y, z, w
  alignas(64) double slow[W];   ///< 0: a lane whose rotation is left to rotation_quaternion (h >= 0.01)
};

/// The half kick and drift of every lane, as first_half_one computes them; w2 = |w|^2 after the kick.
template <int W>
[[gnu::always_inline]] inline void kick_drift_lanes(FirstHalfBlock<W>& b, double h) {
#pragma omp simd
  for (int l = 0; l < W; ++l) {
    const double kv = 0.5 * h / b.m[l], kw = 0.5 * h / b.in[l];
    for (int c = 0; c < 3; ++c) {
      const double v = b.v[c * W + l] + kv * b.f[c * W + l];
      b.v[c * W + l] = v;
      b.x[c * W + l] = b.x[c * W + l] + h * v;
      b.w[c * W + l] = b.w[c * W + l] + kw * b.t[c * W + l];
    }
    const double wx = b.w[l], wy = b.w[W + l], wz = b.w[2 * W + l];
    b.w2[l] = (wx * wx + wy * wy) + wz * wz;
  }
}

/// The rotation of every lane that turns (w2 > 0, h > 0): rotation_quaternion's Taylor branch, Eigen's
/// SSE2 quaternion product with q and renormalised, their operations in their order (the squared
/// norm of the four coefficients is (x^2 + z^2) + (y^2 + w^2) there). Lanes past the Taylor branch are
/// marked slow and keep q.
template <int W>
[[gnu::always_inline]] inline void rotate_lanes(FirstHalfBlock<W>& b, double h) {
#pragma omp simd
  for (int l = 0; l < W; ++l) {
    const double wx = b.w[l], wy = b.w[W + l], wz = b.w[2 * W + l], w2 = b.w2[l];
    const double h2 = 0.25 * w2 * h * h;
    const double sw = 0.5 * h * (1.0 - h2 * (1.0 / 6.0) * (1.0 - h2 * (1.0 / 20.0) * (1.0 - h2 * (1.0 / 42.0) * (1.0 - h2 * (1.0 / 72.0)))));
    const double c = 1.0 - h2 * 0.5 * (1.0 - h2 * (1.0 / 12.0) * (1.0 - h2 * (1.0 / 30.0) * (1.0 - h2 * (1.0 / 56.0))));
    const double ax = sw * wx, ay = sw * wy, az = sw * wz, aw = c;
    const double bx = b.q[l], by = b.q[W + l], bz = b.q[2 * W + l], bw = b.q[3 * W + l];
    const double px = (aw * bx + ay * bz) - (az * by - ax * bw);
    const double py = (aw * by + ay * bw) + (az * bx - ax * bz);
    const double pz = (aw * bz - ay * bx) + (az * bw + ax * by);
    const double pw = (aw * bw - ay * by) - (az * bz + ax * bx);
    const double k = 0.5 * (3.0 - ((px * px + pz * pz) + (py * py + pw * pw)));
    const bool turn = (w2 > 0.0) & (h > 0.0);
    const bool taylor = turn & (h2 < 1e-4);
    b.q[l] = taylor ? px * k : bx;
    b.q[W + l] = taylor ? py * k : by;
    b.q[2 * W + l] = taylor ? pz * k : bz;
    b.q[3 * W + l] = taylor ? pw * k : bw;
    b.slow[l] = (turn & !taylor) ? 0.0 : 1.0;
  }
}

/// first_half_one on particles [lo, hi) over W lanes (engine/core/simd.hpp), with its bits. A block
/// with a prescribed particle runs particle by particle; a block none of whose particles spins
/// leaves the orientations unread (as first_half_one does: a settling bed's spheres mostly do not
/// spin); a lane spinning too fast for the Taylor series gets its rotation after the block.
template <int W>
[[gnu::always_inline]] inline void first_half_lanes(const FirstHalfArrays& a, std::int64_t lo, std::int64_t hi, double h) {
  FirstHalfBlock<W> b;
  std::int64_t i0 = lo;
  for (; i0 + W <= hi; i0 += W) {
    bool all_free = true;
    for (int l = 0; l < W; ++l) all_free &= a.fixed[i0 + l] == 0;
    if (!all_free) {
      for (int l = 0; l < W; ++l) first_half_one(a, i0 + l, h);
      continue;
    }
    double* X = a.x[i0].data();
    double* V = a.v[i0].data();
    double* Om = a.w[i0].data();
    for (int l = 0; l < W; ++l) {
      for (int c = 0; c < 3; ++c) {
        b.x[c * W + l] = X[3 * l + c];
        b.v[c * W + l] = V[3 * l + c];
        b.w[c * W + l] = Om[3 * l + c];
        b.f[c * W + l] = a.f[i0 + l][c];
        b.t[c * W + l] = a.t[i0 + l][c];
      }
      b.m[l] = a.m[i0 + l];
      b.in[l] = a.inertia[i0 + l];
    }
    kick_drift_lanes(b, h);
    bool turns = false;
    for (int l = 0; l < W; ++l) turns |= b.w2[l] > 0.0;
    for (int l = 0; l < W; ++l) {
      for (int c = 0; c < 3; ++c) {
        X[3 * l + c] = b.x[c * W + l];
        V[3 * l + c] = b.v[c * W + l];
        Om[3 * l + c] = b.w[c * W + l];
      }
      a.f[i0 + l].setZero();
      a.t[i0 + l].setZero();
    }
    if (!turns || !(h > 0.0)) continue;
    double* Q = a.q[i0].coeffs().data();
    for (int l = 0; l < W; ++l)
      for (int c = 0; c < 4; ++c) b.q[c * W + l] = Q[4 * l + c];
    rotate_lanes(b, h);
    for (int l = 0; l < W; ++l)
      for (int c = 0; c < 4; ++c) Q[4 * l + c] = b.q[c * W + l];
    for (int l = 0; l < W; ++l)
      if (b.slow[l] == 0.0) {
        const Vec3& wl = a.w[i0 + l];
        a.q[i0 + l] = renormalised(rotation_quaternion(wl, b.w2[l], h) * a.q[i0 + l]);
      }
  }
  for (; i0 < hi; ++i0) first_half_one(a, i0, h);
}

[[SPARKDEM_TARGET_AVX512]] inline void first_half_avx512(const FirstHalfArrays& a, std::int64_t lo, std::int64_t hi, double h) {
  first_half_lanes<8>(a, lo, hi, h);
}
[[SPARKDEM_TARGET_AVX2]] inline void first_half_avx2(const FirstHalfArrays& a, std::int64_t lo, std::int64_t hi, double h) {
  first_half_lanes<4>(a, lo, hi, h);
}

/// Half kick and drift, then the forces and torques cleared for the step's force passes (the
/// last read of the old ones is this kick; the plan's items between it and the pair pass, walls
/// and neighbours, read none: engine/schedule/scheduler.hpp). One pass over the particle arrays
/// instead of two, over SIMD lanes where the processor has them (the same bits either way).
inline void verlet_first_half(ParticleStore& p, double dt) {
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  constexpr std::int64_t kChunk = 512;  // particles per task: a multiple of every lane width
  const std::int64_t chunks = (n + kChunk - 1) / kChunk;
  const LaneIsa isa = lane_isa();
  par::region(par::worth(n, par::kLight), [&] {
    const FirstHalfArrays a{p.position.data(), p.velocity.data(), p.omega.data(), p.force.data(), p.torque.data(),
                            p.orientation.data(), p.mass.data(), p.inertia.data(), p.fixed.data()};
    const double h = dt;
#pragma omp for schedule(static) nowait
    for (std::int64_t c = 0; c < chunks; ++c) {
      const std::int64_t lo = c * kChunk, hi = std::min(n, lo + kChunk);
      if (isa == LaneIsa::avx512)
        first_half_avx512(a, lo, hi, h);
      else if (isa == LaneIsa::avx2)
        first_half_avx2(a, lo, hi, h);
      else
        for (std::int64_t i = lo; i < hi; ++i) first_half_one(a, i, h);
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
