#pragma once
/// Contact rows over SIMD lanes (issue 63): a block of W rows in structure-of-arrays form, the pair
/// geometry and relative motion of every lane (the lane width is chosen at run time: engine/core/simd.hpp).
///
/// The lane code repeats the scalar path's operations in the scalar path's order (Eigen's Vec3
/// sums are left to right: (a0 b0 + a1 b1) + a2 b2; its norm is sqrt(squaredNorm); its division by
/// a scalar divides every component), and the build compiles without contraction into fused
/// multiply-adds (-ffp-contract=off), so every lane gives the scalar path's bits: a branch of the
/// scalar code becomes a select between the two results, each computed as the scalar code does.
/// Lanes beyond the end of a block carry a copy of its last row and are never written back.
///
/// A law with a lane path provides
///   template <int W> void lanes(PairLanes<W, S>& b, double dt) const;
/// (S = Law::kLaneState, its state columns; 3 when it declares none) reading the geometry and motion
/// fields of b (n, delta, r_eff, m_eff, vn, vt; a thermal law also temp, gbf and time_scale) and its
/// history (s), and writing the force on i (f), its tangential part (ft) and the new history (s);
/// the pair loop (ContactModelT) gathers, calls it and scatters in row order.
#include <cmath>
#include <cstdint>

#include "engine/core/simd.hpp"

namespace sparkdem {

/// A block of W contact rows (lane l = row r0 + l) with S state columns, every field an aligned
/// array over the lanes.
template <int W, int S = 3>
struct alignas(64) PairLanes {
  static constexpr int kState = S;
  // gathered inputs
  alignas(64) double dx[W], dy[W], dz[W];     ///< x_i - x_j [m]
  alignas(64) double ri[W], rj[W], mi[W], mj[W];
  alignas(64) double dvx[W], dvy[W], dvz[W];  ///< v_i - v_j [m/s]
  alignas(64) double wix[W], wiy[W], wiz[W], wjx[W], wjy[W], wjz[W];
  alignas(64) double s[S][W];                 ///< history in, new history out (the law's state columns)
  alignas(64) double temp[W];                 ///< thermal laws: the pair's mean temperature [K] (NaN without the field)
  alignas(64) double gbf[W];                  ///< thermal laws: the larger grain-boundary fraction of the pair (0 without)
  double time_scale = 1.0;                    ///< thermal laws: physical seconds per mechanical second
  // geometry and relative motion (pair_geometry_lanes)
  alignas(64) double dist[W];                 ///< centre distance [m]
  alignas(64) double delta[W];                ///< overlap [m]
  alignas(64) double live[W];                 ///< 1 when the pair touches (delta > 0 and dist > 0), else 0
  alignas(64) double nx[W], ny[W], nz[W];
  alignas(64) double r_eff[W], m_eff[W], arm_i[W], arm_j[W];
  alignas(64) double vn[W], vtx[W], vty[W], vtz[W];
  // law outputs
  alignas(64) double fx[W], fy[W], fz[W];     ///< force on i [N]
  alignas(64) double ftx[W], fty[W], ftz[W];  ///< its tangential part [N]
  // torques (pair_torque_lanes)
  alignas(64) double tix[W], tiy[W], tiz[W], tjx[W], tjy[W], tjz[W];
};

/// Geometry and relative motion of every lane, as pair_geometry and relative_motion compute them
/// for one row (engine/contact/contact_model.hpp, engine/contact/geometry.hpp):
///   dist = |x_i - x_j|, delta = (r_i + r_j) - dist, n = (x_i - x_j) / dist,
///   R* = r_i r_j / (r_i + r_j), m* = m_i m_j / (m_i + m_j) (0 when inertia-free),
///   arm_i = r_i - delta/2, arm_j = r_j - delta/2,
///   v = (v_i - v_j) - (arm_i w_i + arm_j w_j) x n, v_n = v . n, v_t = v - v_n n.
template <int W, int S>
[[gnu::always_inline]] inline void pair_geometry_lanes(PairLanes<W, S>& b, bool inertia_free) {
  const double inertia = inertia_free ? 0.0 : 1.0;  // m* x 1 is m* exactly: a product, not a branch, in the loop
#pragma omp simd
  for (int l = 0; l < W; ++l) {
    const double dist = std::sqrt((b.dx[l] * b.dx[l] + b.dy[l] * b.dy[l]) + b.dz[l] * b.dz[l]);
    const double delta = (b.ri[l] + b.rj[l]) - dist;
    b.dist[l] = dist;
    b.delta[l] = delta;
    b.live[l] = ((delta > 0.0) & (dist > 0.0)) ? 1.0 : 0.0;  // & not &&: no branch in the loop
    const double nx = b.dx[l] / dist, ny = b.dy[l] / dist, nz = b.dz[l] / dist;
    b.nx[l] = nx;
    b.ny[l] = ny;
    b.nz[l] = nz;
    b.r_eff[l] = b.ri[l] * b.rj[l] / (b.ri[l] + b.rj[l]);
    b.m_eff[l] = b.mi[l] * b.mj[l] / (b.mi[l] + b.mj[l]) * inertia;
    const double arm_i = b.ri[l] - 0.5 * delta, arm_j = b.rj[l] - 0.5 * delta;
    b.arm_i[l] = arm_i;
    b.arm_j[l] = arm_j;
    const double ax = arm_i * b.wix[l] + arm_j * b.wjx[l];
    const double ay = arm_i * b.wiy[l] + arm_j * b.wjy[l];
    const double az = arm_i * b.wiz[l] + arm_j * b.wjz[l];
    const double vx = b.dvx[l] - (ay * nz - az * ny);
    const double vy = b.dvy[l] - (az * nx - ax * nz);
    const double vz = b.dvz[l] - (ax * ny - ay * nx);
    const double vn = (vx * nx + vy * ny) + vz * nz;
    b.vn[l] = vn;
    b.vtx[l] = vx - vn * nx;
    b.vty[l] = vy - vn * ny;
    b.vtz[l] = vz - vn * nz;
  }
}

/// Torques of every lane from its tangential force: t_i = -arm_i (n x F_t), t_j = -arm_j (n x F_t).
template <int W, int S>
[[gnu::always_inline]] inline void pair_torque_lanes(PairLanes<W, S>& b) {
#pragma omp simd
  for (int l = 0; l < W; ++l) {
    const double cx = b.ny[l] * b.ftz[l] - b.nz[l] * b.fty[l];
    const double cy = b.nz[l] * b.ftx[l] - b.nx[l] * b.ftz[l];
    const double cz = b.nx[l] * b.fty[l] - b.ny[l] * b.ftx[l];
    const double ai = -b.arm_i[l], aj = -b.arm_j[l];
    b.tix[l] = ai * cx;
    b.tiy[l] = ai * cy;
    b.tiz[l] = ai * cz;
    b.tjx[l] = aj * cx;
    b.tjy[l] = aj * cy;
    b.tjz[l] = aj * cz;
  }
}

}  // namespace sparkdem
