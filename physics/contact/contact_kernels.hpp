#pragma once
/// Pure contact kernels shared by the contact laws (LAMMPS granular sub-model style).
/// Every function is stateless; state (tangential history) is passed explicitly.
#include <cmath>
#include <map>
#include <mutex>

#include "engine/contact/geometry.hpp"
#include "engine/contact/lanes.hpp"
#include "engine/core/numbers.hpp"

namespace sparkdem::physics::kernel {

/// Effective Young's modulus of two identical elastic bodies [Pa]:
///   1/E* = (1 - nu^2)/E + (1 - nu^2)/E   (Johnson, Contact Mechanics, eq. 4.22)
inline double effective_modulus(double E, double nu) { return E / (2.0 * (1.0 - nu * nu)); }

/// Effective shear modulus for Mindlin's tangential stiffness [Pa]:
///   1/G* = (2 - nu)/G + (2 - nu)/G,  G = E / (2 (1 + nu))
inline double effective_shear_modulus(double E, double nu) {
  const double G = E / (2.0 * (1.0 + nu));
  return G / (2.0 * (2.0 - nu));
}

/// Hertz normal force [N]: F = 4/3 E* sqrt(R* delta) delta   (Hertz 1882; Johnson eq. 4.23)
inline double hertz_force(double e_star, double r_eff, double delta) { return 4.0 / 3.0 * e_star * std::sqrt(r_eff * delta) * delta; }
/// Tangent stiffness dF/d(delta) of the Hertz law [N/m]: k = 2 E* sqrt(R* delta).
inline double hertz_stiffness(double e_star, double r_eff, double delta) { return 2.0 * e_star * std::sqrt(r_eff * delta); }

/// Tsuji et al. (Powder Technol. 71, 1992) damping coefficient polynomial alpha(e) as used by
/// LAMMPS `damping tsuji`: F_d = -alpha sqrt(m* k_nfac) v_n, with k_nfac = 4/3 E* sqrt(R* delta).
inline double tsuji_alpha_polynomial(double e) {
  return 1.2728 - 4.2783 * e + 11.087 * e * e - 22.348 * e * e * e + 27.467 * e * e * e * e - 18.022 * e * e * e * e * e +
         4.8218 * e * e * e * e * e * e;
}

/// Restitution coefficient of the Hertz law with Tsuji-form damping, from the dimensionless
/// equation of the normal impact (velocity independent):
///   x'' = -x^{3/2} - alpha x^{1/4} x',  x(0) = 0, x'(0) = 1,  e = -x'(tau_end) at x(tau_end) = 0
/// obtained from m d'' = -k d^{3/2} - alpha sqrt(m k) d^{1/4} d' with d = X x, t = T tau,
/// T^2 X^{1/2} = m/k, X = v0 T. Integrated with RK4 (h = 2e-4): e is accurate to ~1e-6.
/// Also returns the dimensionless contact duration tau_end.
inline double hertz_tsuji_restitution(double alpha, double* duration = nullptr) {
  double x = 0.0, v = 1.0, t = 0.0;
  const double h = 2e-4;
  auto acc = [alpha](double xx, double vv) {
    const double xp = xx > 0.0 ? xx : 0.0;
    return -xp * std::sqrt(xp) - alpha * std::sqrt(std::sqrt(xp)) * vv;
  };
  for (int k = 0; k < 2000000; ++k) {
    const double k1x = v, k1v = acc(x, v);
    const double k2x = v + 0.5 * h * k1v, k2v = acc(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
    const double k3x = v + 0.5 * h * k2v, k3v = acc(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
    const double k4x = v + h * k3v, k4v = acc(x + h * k3x, v + h * k3v);
    const double xn = x + h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x);
    const double vn = v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
    if (xn <= 0.0 && t > 0.0) {
      const double s = x / (x - xn);  // linear crossing
      if (duration) *duration = t + s * h;
      return -(v + s * (vn - v));
    }
    x = xn;
    v = vn;
    t += h;
  }
  if (duration) *duration = t;
  return 0.0;  // did not separate: fully damped
}

/// Inverse of hertz_tsuji_restitution by bisection: alpha such that e(alpha) = e_target.
/// The bisection integrates ~60 impacts (~50 ms), so results are memoised per e_target (every
/// scenario load builds its laws; the value is a pure function of e_target).
inline double hertz_tsuji_alpha_for_restitution(double e_target) {
  if (e_target >= 1.0) return 0.0;
  static std::mutex mutex;
  static std::map<double, double> memo;
  const bool memoise = !std::isnan(e_target);  // NaN keys would break the map's ordering
  if (memoise) {
    const std::lock_guard<std::mutex> lock(mutex);
    if (const auto it = memo.find(e_target); it != memo.end()) return it->second;
  }
  double lo = 0.0, hi = 1.0;
  while (hertz_tsuji_restitution(hi) > e_target) hi *= 2.0;
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (hertz_tsuji_restitution(mid) > e_target)
      lo = mid;
    else
      hi = mid;
  }
  const double alpha = 0.5 * (lo + hi);
  if (memoise) {
    const std::lock_guard<std::mutex> lock(mutex);
    memo.emplace(e_target, alpha);
  }
  return alpha;
}

/// Linear spring-dashpot damping coefficient for an exact restitution e [kg/s]:
///   gamma = 2 sqrt(m* k) (-ln e) / sqrt(pi^2 + ln^2 e)
inline double linear_damping_for_restitution(double e, double m_eff, double k) {
  if (e >= 1.0) return 0.0;
  const double l = std::log(e);
  return 2.0 * std::sqrt(m_eff * k) * (-l) / std::sqrt(kPi * kPi + l * l);
}

/// Tangential spring with history and Coulomb limit (Cundall & Strack 1979; LAMMPS
/// linear_history). The stored displacement xi is first rotated into the current tangent plane
/// (keeping its length), then xi += v_t dt, F_t = -k_t xi - gamma_t v_t; if |F_t| > mu |F_n|
/// the force is scaled to the cone and xi reset to -(F_t + gamma_t v_t)/k_t.
/// `frame_epsilon` > 0 is LAMMPS's frame-update rule (pair_granular.cpp, EPSILON = 1e-10): the
/// rotation is skipped when the normal component of xi would contribute less than that fraction
/// of the friction limit, |xi . n| k_t <= frame_epsilon mu |F_n| (two square roots and a division
/// saved on most rows of a bed at rest); 0 rotates on every call.
/// @param[in,out] xi tangential displacement history [m] (3 values)
/// @return tangential force on i [N]
[[gnu::always_inline]] inline Vec3 tangential_history(const Vec3& n, const Vec3& vt, double k_t, double gamma_t, double mu, double fn_abs, double dt, double* xi,
                               double frame_epsilon = 0.0) {
  Vec3 s(xi[0], xi[1], xi[2]);
  const double fcrit = mu * fn_abs;
  const double rsht = s.dot(n);
  if (frame_epsilon <= 0.0 || std::abs(rsht) * k_t > frame_epsilon * fcrit) {
    const double mag = s.norm();
    s -= rsht * n;
    const double proj = s.norm();
    if (proj > 0.0) s *= mag / proj;
  }
  s += vt * dt;
  Vec3 ft = -k_t * s - gamma_t * vt;
  // |F_t| > mu |F_n| compared squared: the square root only for a sliding row.
  if (ft.squaredNorm() > fcrit * fcrit) {
    const double fmag = ft.norm();
    if (k_t > 0.0 && fmag > 0.0) {
      ft *= fcrit / fmag;
      s = -(ft + gamma_t * vt) / k_t;
    } else {
      ft.setZero();
    }
  }
  xi[0] = s[0];
  xi[1] = s[1];
  xi[2] = s[2];
  return ft;
}

/// tangential_history on every lane of a block (engine/contact/lanes.hpp): the same operations in
/// the same order, each branch a select, so every lane gives the scalar function's bits.
/// Reads b.n, b.vt, b.s; writes b.ft and the new history b.s. k_t, gamma_t, |F_n| per lane.
template <int W, int S>
[[gnu::always_inline]] inline void tangential_history_lanes(PairLanes<W, S>& b, const double* k_t, const double* gamma_t, double mu,
                                                            const double* fn_abs, double dt, double frame_epsilon = 0.0) {
#pragma omp simd
  for (int l = 0; l < W; ++l) {
    const double nx = b.nx[l], ny = b.ny[l], nz = b.nz[l];
    const double kt = k_t[l], gt = gamma_t[l];
    double sx = b.s[0][l], sy = b.s[1][l], sz = b.s[2][l];
    const double fcrit = mu * fn_abs[l];
    const double rsht = (sx * nx + sy * ny) + sz * nz;
    // frame update into the tangent plane, keeping the length
    const bool rotate = (frame_epsilon <= 0.0) | (std::abs(rsht) * kt > frame_epsilon * fcrit);  // | and &: no branch in the loop
    const double mag = std::sqrt((sx * sx + sy * sy) + sz * sz);
    double px = sx - rsht * nx, py = sy - rsht * ny, pz = sz - rsht * nz;
    const double proj = std::sqrt((px * px + py * py) + pz * pz);
    const double k = mag / proj;
    px = proj > 0.0 ? px * k : px;
    py = proj > 0.0 ? py * k : py;
    pz = proj > 0.0 ? pz * k : pz;
    sx = rotate ? px : sx;
    sy = rotate ? py : sy;
    sz = rotate ? pz : sz;
    const double vx = b.vtx[l], vy = b.vty[l], vz = b.vtz[l];
    sx = sx + vx * dt;
    sy = sy + vy * dt;
    sz = sz + vz * dt;
    double fx = -kt * sx - gt * vx, fy = -kt * sy - gt * vy, fz = -kt * sz - gt * vz;
    // Coulomb cap: scale to the cone and reset the history to the capped force
    const double f2 = (fx * fx + fy * fy) + fz * fz;
    const bool slide = f2 > fcrit * fcrit;
    const double fmag = std::sqrt(f2);
    const bool scalable = (kt > 0.0) & (fmag > 0.0);
    const double scale = fcrit / fmag;
    const double cx = scalable ? fx * scale : 0.0, cy = scalable ? fy * scale : 0.0, cz = scalable ? fz * scale : 0.0;
    const bool reset = slide & scalable;
    b.s[0][l] = reset ? -(cx + gt * vx) / kt : sx;
    b.s[1][l] = reset ? -(cy + gt * vy) / kt : sy;
    b.s[2][l] = reset ? -(cz + gt * vz) / kt : sz;
    b.ftx[l] = slide ? cx : fx;
    b.fty[l] = slide ? cy : fy;
    b.ftz[l] = slide ? cz : fz;
  }
}

/// The force on i of every lane, F = F_n n + F_t, from the normal force the law left in b.fx.
template <int W, int S>
[[gnu::always_inline]] inline void assemble_force_lanes(PairLanes<W, S>& b) {
#pragma omp simd
  for (int l = 0; l < W; ++l) {
    const double fn = b.fx[l];
    b.fx[l] = fn * b.nx[l] + b.ftx[l];
    b.fy[l] = fn * b.ny[l] + b.fty[l];
    b.fz[l] = fn * b.nz[l] + b.ftz[l];
  }
}

/// Rayleigh critical step of a sphere [s] (Li et al. 2005; Thornton):
///   dt_R = pi r sqrt(rho / G) / (0.1631 nu + 0.8766)
inline double rayleigh_step(double radius, double density, double E, double nu) {
  const double G = E / (2.0 * (1.0 + nu));
  return kPi * radius * std::sqrt(density / G) / (0.1631 * nu + 0.8766);
}

}  // namespace sparkdem::physics::kernel
