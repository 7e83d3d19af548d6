// fv::solve, compiled once (library sparkdem_reference, tools/CMakeLists.txt): Eigen's SimplicialLDLT is
// instantiated here only, not in every test and tool that includes the header.
#include "support/fv_notched_bar.hpp"

#include <Eigen/Sparse>
#include <Eigen/SparseCholesky>
#include <chrono>

namespace sparkdem::fv {

Result solve(const NotchedBar& g, const Material& m, const Loading& ld, const Numerics& num) {
  using SpMat = Eigen::SparseMatrix<double>;
  using Trip = Eigen::Triplet<double>;
  const auto t_start = std::chrono::steady_clock::now();
  const double h = num.h;
  if (!(h > 0.0)) throw std::invalid_argument("fv: cell size h must be > 0");
  const double lx_solved = num.use_x_symmetry ? 0.5 * g.lx : g.lx;
  for (double len : {lx_solved, g.lz})
    if (!detail::divides(len, h)) throw std::invalid_argument("fv: h = " + std::to_string(h) + " m does not divide the bar dimensions");
  if (g.notched)
    for (double len : {g.notch_depth, g.notch_z_lo, g.notch_z_hi})
      if (!detail::divides(len, h)) throw std::invalid_argument("fv: h = " + std::to_string(h) + " m does not resolve the slots");
  if (!(0.0 <= ld.z_lo && ld.z_lo < ld.z_hi && ld.z_hi <= g.lz)) throw std::invalid_argument("fv: need 0 <= z_lo < z_hi <= lz");
  if (num.steps < 2) throw std::invalid_argument("fv: steps must be >= 2");
  if (g.notched && !(g.notch_depth < lx_solved)) throw std::invalid_argument("fv: the slots cut through the bar");

  Result res;
  const int nx = static_cast<int>(std::lround(lx_solved / h)), nz = static_cast<int>(std::lround(g.lz / h));
  res.nx = nx;
  res.nz = nz;
  res.h = h;
  res.steps = num.steps;
  res.dt = ld.t_end / num.steps;
  const double mirror = num.use_x_symmetry ? 2.0 : 1.0;  // extensive quantities of the whole bar
  const double A = h * g.depth, Vc = h * h * g.depth;
  const double sigma = 1.0 / m.resistivity;
  auto xc = [&](int i) { return (i + 0.5) * h; };
  auto zc = [&](int k) { return (k + 0.5) * h; };
  const std::size_t ncell = static_cast<std::size_t>(nx) * nz;
  std::vector<char> solid(ncell, 1);
  if (g.notched)
    for (int k = 0; k < nz; ++k)
      for (int i = 0; i < nx; ++i) {
        const double x = xc(i), z = zc(k);
        const bool in_z = z > g.notch_z_lo && z < g.notch_z_hi;
        const bool in_x = x < g.notch_depth || x > g.lx - g.notch_depth;
        if (in_z && in_x) solid[i + static_cast<std::size_t>(nx) * k] = 0;
      }
  auto cell = [&](int i, int k) { return static_cast<std::size_t>(i) + static_cast<std::size_t>(nx) * k; };

  // ---- potential ----
  // region: -1 beyond z_lo (phi = 0), +1 beyond z_hi (phi = V), 0 unknown
  auto region = [&](int k) {
    const double z = zc(k);
    return z <= ld.z_lo ? -1 : (z >= ld.z_hi ? 1 : 0);
  };
  std::vector<long> pidx(ncell, -1);
  long np = 0;
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i)
      if (solid[cell(i, k)] && region(k) == 0) pidx[cell(i, k)] = np++;
  res.potential_unknowns = static_cast<std::size_t>(np);
  std::vector<Trip> tp;
  tp.reserve(static_cast<std::size_t>(np) * 5);
  Eigen::VectorXd bp = Eigen::VectorXd::Zero(np);
  // Faces: visit each (cell, +x neighbour) and (cell, +z neighbour) once.
  // fixed_side: 0 both unknown; 1: b is beyond a plane, -1: a is; plane: -1 z_lo, +1 z_hi, 0 none.
  // frac_a: share of the face's Joule power deposited in cell a.
  struct Face {
    std::size_t a, b;
    double G;
    double frac_a;
    double phi_fixed;
    int fixed_side;
    int plane;
  };
  std::vector<Face> faces;
  faces.reserve(2 * ncell);
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i) {
      const std::size_t a = cell(i, k);
      if (!solid[a]) continue;
      for (int dir = 0; dir < 2; ++dir) {
        const int i2 = i + (dir == 0), k2 = k + (dir == 1);
        if (i2 >= nx || k2 >= nz) continue;
        const std::size_t b = cell(i2, k2);
        if (!solid[b]) continue;
        const int ra = region(k), rb = region(k2);
        if (ra != 0 && rb != 0) continue;  // both equipotential: no current
        if (ra == 0 && rb == 0) {
          faces.push_back({a, b, sigma * A / h, 0.5, 0.0, 0, 0});
          continue;
        }
        // one unknown, one beyond a plane (only across z faces)
        const bool a_unknown = ra == 0;
        const int rf = a_unknown ? rb : ra;
        const double zp = rf < 0 ? ld.z_lo : ld.z_hi;
        const double zu = a_unknown ? zc(k) : zc(k2);
        const double d = std::abs(zu - zp);
        const double frac_unknown = std::min(d, 0.5 * h) / d;
        const double vfix = rf < 0 ? 0.0 : ld.voltage;
        faces.push_back({a, b, sigma * A / d, a_unknown ? frac_unknown : 1.0 - frac_unknown, vfix, a_unknown ? 1 : -1, rf});
      }
    }
  for (const Face& f : faces) {
    if (f.fixed_side == 0) {
      const long pa = pidx[f.a], pb = pidx[f.b];
      tp.emplace_back(pa, pa, f.G);
      tp.emplace_back(pb, pb, f.G);
      tp.emplace_back(pa, pb, -f.G);
      tp.emplace_back(pb, pa, -f.G);
    } else {
      const long pu = pidx[f.fixed_side == 1 ? f.a : f.b];
      tp.emplace_back(pu, pu, f.G);
      bp[pu] += f.G * f.phi_fixed;
    }
  }
  SpMat Kp(np, np);
  Kp.setFromTriplets(tp.begin(), tp.end());
  Eigen::SimplicialLDLT<SpMat> ldlt_p(Kp);
  if (ldlt_p.info() != Eigen::Success) throw std::runtime_error("fv: potential matrix factorisation failed");
  const Eigen::VectorXd phi_u = ldlt_p.solve(bp);
  std::vector<double> phi(ncell, std::numeric_limits<double>::quiet_NaN());
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = cell(i, k);
      if (!solid[c]) continue;
      phi[c] = region(k) < 0 ? 0.0 : region(k) > 0 ? ld.voltage : phi_u[pidx[c]];
    }
  // currents, Joule sources
  std::vector<double> q(ncell, 0.0);  // W per cell
  double I_lo = 0.0, I_hi = 0.0;
  for (const Face& f : faces) {
    const double dphi = f.fixed_side == 0 ? phi[f.a] - phi[f.b] : f.fixed_side == 1 ? phi[f.a] - f.phi_fixed : f.phi_fixed - phi[f.b];
    const double P = f.G * dphi * dphi;
    q[f.a] += f.frac_a * P;
    q[f.b] += (1.0 - f.frac_a) * P;
    const double phi_u = f.fixed_side == 1 ? phi[f.a] : phi[f.b];
    if (f.plane < 0) I_lo += f.G * (phi_u - f.phi_fixed);  // out of the bar into z_lo
    if (f.plane > 0) I_hi += f.G * (f.phi_fixed - phi_u);  // from z_hi into the bar
  }
  res.current = mirror * I_lo;
  res.current_high = mirror * I_hi;
  res.resistance = ld.voltage / res.current;
  res.power_vi = ld.voltage * res.current;
  double Psum = 0.0;
  for (double x : q) Psum += x;
  res.power_joule = mirror * Psum;

  // ---- heat ----
  std::vector<long> tidx(ncell, -1);
  long nt = 0;
  for (std::size_t c = 0; c < ncell; ++c)
    if (solid[c]) tidx[c] = nt++;
  res.solid_cells = static_cast<std::size_t>(nt) * (num.use_x_symmetry ? 2 : 1);
  std::vector<Trip> tk;
  tk.reserve(static_cast<std::size_t>(nt) * 5);
  const double kface = m.conductivity * A / h;
  for (int k = 0; k < nz; ++k)
    for (int i = 0; i < nx; ++i) {
      const std::size_t a = cell(i, k);
      if (!solid[a]) continue;
      for (int dir = 0; dir < 2; ++dir) {
        const int i2 = i + (dir == 0), k2 = k + (dir == 1);
        if (i2 >= nx || k2 >= nz) continue;
        const std::size_t b = cell(i2, k2);
        if (!solid[b]) continue;
        const long ta = tidx[a], tb = tidx[b];
        tk.emplace_back(ta, ta, kface);
        tk.emplace_back(tb, tb, kface);
        tk.emplace_back(ta, tb, -kface);
        tk.emplace_back(tb, ta, -kface);
      }
    }
  SpMat K(nt, nt);
  K.setFromTriplets(tk.begin(), tk.end());
  const double mc = m.density * m.heat_capacity * Vc;  // J/K per cell
  Eigen::VectorXd P(nt);
  for (std::size_t c = 0; c < ncell; ++c)
    if (solid[c]) P[tidx[c]] = q[c];
  SpMat I_n(nt, nt);
  I_n.setIdentity();
  const double dt = res.dt, dtq = 0.5 * dt;
  // Backward Euler half steps (Rannacher: four of them replace the first two CN steps):
  // (mc/dtq I + K) T' = mc/dtq T + P
  SpMat Abe = (mc / dtq) * I_n + K;
  Eigen::SimplicialLDLT<SpMat> ldlt_be(Abe);
  // Crank-Nicolson: (mc/dt I + K/2) T' = (mc/dt I - K/2) T + P
  SpMat Acn = (mc / dt) * I_n + 0.5 * K;
  Eigen::SimplicialLDLT<SpMat> ldlt_cn(Acn);
  if (ldlt_be.info() != Eigen::Success || ldlt_cn.info() != Eigen::Success)
    throw std::runtime_error("fv: heat matrix factorisation failed");
  // Solve for the rise theta = T - T0 (better conditioned sums).
  Eigen::VectorXd th = Eigen::VectorXd::Zero(nt);
  // (The right-hand side goes through its own vector: solve() may write its result while still
  // reading an expression that refers to th.)
  Eigen::VectorXd rhs(nt);
  for (int s = 0; s < 4; ++s) {
    rhs = (mc / dtq) * th + P;
    th = ldlt_be.solve(rhs);
  }
  for (int s = 2; s < num.steps; ++s) {
    rhs = (mc / dt) * th - 0.5 * (K * th) + P;
    th = ldlt_cn.solve(rhs);
  }

  // ---- outputs ----
  double stored = 0.0, tsum = 0.0, tmax = -std::numeric_limits<double>::infinity();
  double slab_w = 0.0, slab_t = 0.0;
  const double zm = g.notch_z_mid();
  for (int k = 0; k < nz; ++k) {
    const double z0 = k * h, z1 = (k + 1) * h;
    const double ov = std::max(0.0, std::min(z1, zm + ld.slab_half_width) - std::max(z0, zm - ld.slab_half_width)) / h;
    for (int i = 0; i < nx; ++i) {
      const std::size_t c = cell(i, k);
      if (!solid[c]) continue;
      const double t = th[tidx[c]];
      stored += mc * t;
      tsum += t;
      tmax = std::max(tmax, t);
      slab_w += ov;
      slab_t += ov * t;
    }
  }
  res.heat_stored = mirror * stored;
  res.heat_input = res.power_joule * ld.t_end;
  res.T_mean = ld.T0 + tsum / static_cast<double>(nt);
  res.T_max = ld.T0 + tmax;
  res.T_slab_mean = ld.T0 + slab_t / slab_w;
  res.slab_volume = mirror * slab_w * Vc;
  res.solid_volume = mirror * static_cast<double>(nt) * Vc;
  {
    // point (lx/2, zm): with the symmetric half grid it lies on the mirror plane, between the
    // last column's cells k and k-1 (zm is a cell boundary when h resolves the slots).
    const int kk = static_cast<int>(std::lround(zm / h));
    double acc = 0.0;
    int cnt = 0;
    auto add = [&](int i, int k) {
      if (i < 0 || i >= nx || k < 0 || k >= nz || !solid[cell(i, k)]) return;
      acc += th[tidx[cell(i, k)]];
      ++cnt;
    };
    const double xm = 0.5 * g.lx;
    const int ii = static_cast<int>(std::lround(xm / h));  // cell boundary index (or nx with symmetry)
    if (detail::divides(xm, h)) {
      add(ii - 1, kk - 1);
      add(ii - 1, kk);
      add(ii, kk - 1);
      add(ii, kk);
    } else {
      const int ic = static_cast<int>(std::floor(xm / h));
      add(ic, kk - 1);
      add(ic, kk);
    }
    res.T_notch_centre = ld.T0 + acc / std::max(cnt, 1);
  }
  if (num.keep_fields) {
    res.phi = phi;
    res.T.assign(ncell, std::numeric_limits<double>::quiet_NaN());
    for (std::size_t c = 0; c < ncell; ++c)
      if (solid[c]) res.T[c] = ld.T0 + th[tidx[c]];
  }
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return res;
}

}  // namespace sparkdem::fv
