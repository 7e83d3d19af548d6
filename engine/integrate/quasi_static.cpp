#include "engine/integrate/quasi_static.hpp"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>

#include "engine/core/error.hpp"

namespace sparkdem {

namespace {

using SpMat = Eigen::SparseMatrix<double>;
using Triplet = Eigen::Triplet<double>;

/// How a row takes part in a round of the nonlinear iteration.
struct RowMode {
  bool open = false;       ///< unilateral and pulling: no force
  bool sliding = false;    ///< Coulomb-capped and at the cap: the force cap against the slip direction
  Vec3 dir = Vec3::Zero(); ///< slip direction of the last round (unit) if it held over two rounds, else zero (the secant form)
  Vec3 last = Vec3::Zero(); ///< slip direction of the last round (unit; equal to dir when dir is set)
  double cap = 0.0;        ///< mu F_n of the last round [N]
  double k = 0.0;          ///< cap / |slip| of the last round [N s/m] (the secant viscosity)
  double secant = -1.0;    ///< a Hertz row's secant stiffness over the step [N/m] (< 0: its tangent at the start)
  bool touch = false;      ///< a Hertz row on its chord to touching, F(d0) / d0 (predicted to separate)
};

/// A Hertz row's force at overlap d [N].
double hertz_force(const LinearContact& lc, double d) { return d > 0.0 ? lc.hertz * d * std::sqrt(d) : 0.0; }

/// One 3-component block of a row's velocity maps: a = h . u_blk, s = G u_blk (DOFs dof..dof+2).
struct Block {
  Eigen::Index dof;
  Eigen::RowVector3d h;
  Eigen::Matrix3d g;
};

/// The unknowns: 6 per particle (velocity, spin), then one per force-controlled wall.
struct DofMap {
  std::size_t particles = 0;
  std::vector<Eigen::Index> wall_dof;  ///< per wall: its unknown's index, or -1 (known rate)
  Eigen::Index size = 0;
};

DofMap map_dofs(const QuasiStaticProblem& prob) {
  DofMap m;
  m.particles = prob.particles;
  m.size = static_cast<Eigen::Index>(6 * prob.particles);
  for (double r : prob.wall_rate) m.wall_dof.push_back(std::isnan(r) ? m.size++ : -1);
  return m;
}

Eigen::Matrix3d cross_matrix(const Vec3& n) {
  Eigen::Matrix3d c;
  c << 0.0, -n.z(), n.y(), n.z(), 0.0, -n.x(), -n.y(), n.x(), 0.0;
  return c;
}

/// The row's blocks (a = sum h u + [wall unknown], s = sum G u) and its wall unknown (or -1).
int row_blocks(const LinearRow& r, const DofMap& m, Block (&b)[4], Eigen::Index& wall_dof) {
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - r.n * r.n.transpose();
  const Eigen::Matrix3d N = cross_matrix(r.n);
  const Eigen::Index bi = 6 * static_cast<Eigen::Index>(r.i);
  b[0] = {bi, -r.n.transpose(), P};
  b[1] = {bi + 3, Eigen::RowVector3d::Zero(), r.arm_i * N};
  wall_dof = -1;
  if (r.j >= 0) {
    const Eigen::Index bj = 6 * static_cast<Eigen::Index>(r.j);
    b[2] = {bj, r.n.transpose(), -P};
    b[3] = {bj + 3, Eigen::RowVector3d::Zero(), r.arm_j * N};
    return 4;
  }
  wall_dof = m.wall_dof[static_cast<std::size_t>(-1 - r.j)];
  return 2;
}

/// The row's coefficients in this round: normal {f0 (known wall rate folded in), c}, tangential
/// F_t = ft0 - Ct s. Sticking: {ft0, ct I}. Sliding in direction e with cap C = mu F_n and secant
/// k = C / |s_last| (RowMode), linearised about the last slip with a kept fraction eps of k along it:
///   F_t = -(1 - eps) C e - k (I - (1 - eps) e e^T) s
/// eps = 1 is the secant (Picard) form, F_t = -k s, whose rounds contract by C / (driving force)
/// per round (0.7 on the NiAl die); eps -> 0 is Newton's tangent (zero along the slip), which
/// diverged on a die wall with 130 contacts sliding at once. Any eps in (0, 1] has the same fixed
/// point F_t = -C e and keeps K definite (eigenvalues k, k, eps k).
struct RowCoeffs {
  double f0, c;
  Vec3 ft0;
  Eigen::Matrix3d ct;
};
RowCoeffs coeffs(const LinearRow& r, const RowMode& mode, const QuasiStaticProblem& prob, double eps) {
  if (mode.open) return {0.0, 0.0, Vec3::Zero(), Eigen::Matrix3d::Zero()};
  double f0 = r.lc.f0;
  double c = r.lc.c;
  if (r.lc.hertz > 0.0 && mode.secant >= 0.0) {  // F(d + a dt) = F(d) + S dt a
    f0 = hertz_force(r.lc, r.lc.overlap);
    c = mode.secant * prob.dt;
  }
  if (r.j < 0) {
    const double rate = prob.wall_rate[static_cast<std::size_t>(-1 - r.j)];
    if (!std::isnan(rate)) f0 += c * rate;
  }
  if (mode.sliding) {
    const double keep = 1.0 - eps;  // 1 - eps (a warm-started row has no direction yet: the secant)
    return {f0, c, -keep * mode.cap * mode.dir, mode.k * (Eigen::Matrix3d::Identity() - keep * mode.dir * mode.dir.transpose())};
  }
  // A Coulomb-capped row carries no stored tangential force into the solve (see update_modes).
  return {f0, c, std::isfinite(r.lc.mu) ? Vec3::Zero() : r.lc.ft0, r.lc.ct * Eigen::Matrix3d::Identity()};
}

/// A pair row's resistance to relative rotation, W = w_i - w_j: the potential W^T B W / 2 with
/// B = bend (I - n n^T) + twist n n^T, i.e. the blocks B on (w_i, w_i) and (w_j, w_j) and -B between.
template <class Emit>
void emit_neck_moments(const LinearRow& r, Emit& emit) {
  const Eigen::Matrix3d nn = r.n * r.n.transpose();
  const Eigen::Matrix3d B = r.lc.bend * (Eigen::Matrix3d::Identity() - nn) + r.lc.twist * nn;
  const Eigen::Index wi = 6 * static_cast<Eigen::Index>(r.i) + 3, wj = 6 * static_cast<Eigen::Index>(r.j) + 3;
  const Eigen::Index hi = std::max(wi, wj), lo = std::min(wi, wj);
  for (int x = 0; x < 3; ++x)
    for (int y = 0; y < 3; ++y) {
      if (x >= y) {
        emit(wi + x, wi + y, B(x, y));
        emit(wj + x, wj + y, B(x, y));
      }
      emit(hi + x, lo + y, -B(x, y));  // B is symmetric: the block below the diagonal
    }
}

/// Every entry of one round's K (lower triangle, as emit(row, col, value)) and its b. The entries
/// come in the same order every round (zeros kept), so the rounds share K's pattern.
template <class Emit>
void for_each_entry(const QuasiStaticProblem& prob, const DofMap& m, const std::vector<RowMode>& modes, double eps, Eigen::VectorXd& b,
                    Emit&& emit) {
  b = Eigen::VectorXd::Zero(m.size);
  for (std::size_t k = 0; k < m.wall_dof.size(); ++k)
    if (m.wall_dof[k] >= 0) b[m.wall_dof[k]] += prob.wall_load[k];
  Block blk[4];
  for (std::size_t q = 0; q < prob.rows.size(); ++q) {
    const LinearRow& r = prob.rows[q];
    const RowCoeffs co = coeffs(r, modes[q], prob, eps);
    Eigen::Index wd;
    const int nb = row_blocks(r, m, blk, wd);
    for (int p = 0; p < nb; ++p) {
      b.segment<3>(blk[p].dof) += -co.f0 * blk[p].h.transpose() + blk[p].g.transpose() * co.ft0;
      for (int s = 0; s < nb; ++s) {
        if (blk[s].dof > blk[p].dof) continue;  // lower triangle: row dof p >= column dof s
        const Eigen::Matrix3d kb = co.c * blk[p].h.transpose() * blk[s].h + blk[p].g.transpose() * co.ct * blk[s].g;
        for (int x = 0; x < 3; ++x)
          for (int y = 0; y < 3; ++y)
            if (blk[p].dof + x >= blk[s].dof + y) emit(blk[p].dof + x, blk[s].dof + y, kb(x, y));
      }
      if (wd >= 0)  // the wall unknown is numbered after every particle: its row is below
        for (int x = 0; x < 3; ++x) emit(wd, blk[p].dof + x, co.c * blk[p].h[x]);
    }
    if (wd >= 0) {
      emit(wd, wd, co.c);
      b[wd] += -co.f0;
    }
    if (r.j >= 0 && (r.lc.bend > 0.0 || r.lc.twist > 0.0)) emit_neck_moments(r, emit);
  }
  for (Eigen::Index i = 0; i < m.size; ++i) emit(i, i, 0.0);  // every diagonal stored: regularised in place
}

/// K of the rounds of one solve: the first round builds the pattern and remembers where each entry
/// lands in K's values; later rounds only refill the values.
class Assembly {
 public:
  void assemble(const QuasiStaticProblem& prob, const DofMap& m, const std::vector<RowMode>& modes, double eps, Eigen::VectorXd& b) {
    if (slot_.empty()) {
      std::vector<Triplet> trip;
      trip.reserve(prob.rows.size() * 80);
      for_each_entry(prob, m, modes, eps, b, [&](Eigen::Index i, Eigen::Index j, double v) { trip.emplace_back(i, j, v); });
      K.resize(m.size, m.size);
      K.setFromTriplets(trip.begin(), trip.end());
      K.makeCompressed();
      slot_.reserve(trip.size());
      for (const Triplet& t : trip) {
        const int* begin = K.innerIndexPtr() + K.outerIndexPtr()[t.col()];
        const int* end = K.innerIndexPtr() + K.outerIndexPtr()[t.col() + 1];
        slot_.push_back(static_cast<std::size_t>(std::lower_bound(begin, end, static_cast<int>(t.row())) - K.innerIndexPtr()));
      }
      return;
    }
    std::fill(K.valuePtr(), K.valuePtr() + K.nonZeros(), 0.0);
    std::size_t t = 0;
    double* values = K.valuePtr();
    for_each_entry(prob, m, modes, eps, b, [&](Eigen::Index, Eigen::Index, double v) { values[slot_[t++]] += v; });
  }
  SpMat K;  ///< lower triangle, compressed

 private:
  std::vector<std::size_t> slot_;  ///< per emitted entry: its index in K's values
};

/// The diagonal regularisation (see the header) and the symmetric Jacobi scale D^-1/2 of the
/// first round's K (kept for the later rounds, whose solves it preconditions).
Eigen::VectorXd regularisation(const SpMat& K, const DofMap& m, Step step) {
  const Eigen::VectorXd d = K.diagonal();
  double mean[2] = {0.0, 0.0};
  double count[2] = {0.0, 0.0};
  for (std::size_t i = 0; i < m.particles; ++i)
    for (int c = 0; c < 6; ++c) {
      mean[c / 3] += d[6 * static_cast<Eigen::Index>(i) + c];
      count[c / 3] += 1.0;
    }
  for (int k = 0; k < 2; ++k) mean[k] = count[k] > 0.0 && mean[k] > 0.0 ? mean[k] / count[k] : 1.0;
  for (std::size_t k = 0; k < m.wall_dof.size(); ++k)
    if (m.wall_dof[k] >= 0 && !(d[m.wall_dof[k]] > 0.0))
      throw PhysicsError(step, {}, "quasi-static step",
                         "a force-controlled wall (wall index " + std::to_string(k) + ") touches no particle: nothing balances its load");
  Eigen::VectorXd reg = Eigen::VectorXd::Zero(m.size);
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(6 * m.particles); ++i) reg[i] = 1e-12 * mean[(i % 6) / 3];
  return reg;
}

/// K + diag(reg), scaled in place to S K S (S = diag(scale)).
void regularise_and_scale(SpMat& K, const Eigen::VectorXd& reg, const Eigen::VectorXd& scale) {
  for (Eigen::Index j = 0; j < K.outerSize(); ++j)
    for (SpMat::InnerIterator it(K, j); it; ++it) {
      if (it.row() == j) it.valueRef() += reg[j];
      it.valueRef() *= scale[it.row()] * scale[j];
    }
}

/// The linear solver of one solve_quasi_static call. The rounds change only the coefficients of
/// the capped and unilateral rows, so the first round factorises (sparse LDL^T, or incomplete
/// Cholesky for "cg") and the later rounds run conjugate gradients preconditioned by that factor,
/// from the last round's solution; a direct solver refactorises only when they do not reach the
/// tolerance within kStaleIterations (the NiAl compact: 63 % of its time was refactorising).
class RoundSolver {
 public:
  RoundSolver(const QuasiStaticConfig& cfg, Step step, Eigen::Index n)
      : cfg_(cfg), step_(step), direct_(cfg.solver == "direct" || (cfg.solver == "auto" && n <= 60000)) {}

  /// x of the scaled system A x = b (A lower triangle), from x (the last round's, or empty).
  void solve(const SpMat& A, const Eigen::VectorXd& b, Eigen::VectorXd& x, QuasiStaticSolution& sol) {
    if (x.size() != b.size()) x = Eigen::VectorXd::Zero(b.size());
    if (factored_ && pcg(A, b, x, direct_ ? kStaleIterations : cfg_.max_iterations, sol)) return;
    factor(A);
    if (direct_) {
      x = ldlt_.solve(b);
      sol.residual = b.norm() > 0.0 ? (A.selfadjointView<Eigen::Lower>() * x - b).norm() / b.norm() : 0.0;
    } else if (!pcg(A, b, x, cfg_.max_iterations, sol)) {
      throw PhysicsError(step_, {}, "quasi-static step",
                         "conjugate gradients reached a relative residual of " + std::to_string(sol.residual) + " after " +
                             std::to_string(cfg_.max_iterations) + " iterations (tolerance " + std::to_string(cfg_.tolerance) +
                             "); raise quasi_static.max_iterations or use solver \"direct\"");
    }
    if (!x.allFinite()) throw PhysicsError(step_, {}, "quasi-static step", "the solve returned a non-finite velocity");
  }

 private:
  static constexpr std::int64_t kStaleIterations = 50;

  void factor(const SpMat& A) {
    ++factorisations;
    factored_ = true;
    if (direct_) {
      if (!analysed_) ldlt_.analyzePattern(A);
      analysed_ = true;
      ldlt_.factorize(A);
      if (ldlt_.info() != Eigen::Success) throw PhysicsError(step_, {}, "quasi-static step", "the sparse LDL^T factorisation failed");
    } else {
      ic_.compute(A);
      if (ic_.info() != Eigen::Success) throw PhysicsError(step_, {}, "quasi-static step", "the incomplete Cholesky preconditioner failed");
    }
  }
  /// z = M^-1 r with the factor of the first round (into z's storage).
  void precondition(const Eigen::VectorXd& r, Eigen::VectorXd& z) const {
    if (direct_)
      z = ldlt_.solve(r);
    else
      z = ic_.solve(r);
  }

  /// Preconditioned conjugate gradients to |b - A x| <= tolerance |b|; false if not within max_it.
  bool pcg(const SpMat& A, const Eigen::VectorXd& b, Eigen::VectorXd& x, std::int64_t max_it, QuasiStaticSolution& sol) {
    const auto Asym = A.selfadjointView<Eigen::Lower>();
    const double bn = b.norm(), target = cfg_.tolerance * bn;
    Eigen::VectorXd r = b - Asym * x, z(b.size()), Ap(b.size());
    sol.residual = bn > 0.0 ? r.norm() / bn : 0.0;
    if (r.norm() <= target) return true;
    precondition(r, z);
    Eigen::VectorXd p = z;
    double rz = r.dot(z);
    for (std::int64_t it = 0; it < max_it; ++it) {
      Ap.noalias() = Asym * p;
      const double alpha = rz / p.dot(Ap);
      x += alpha * p;
      r -= alpha * Ap;
      ++sol.iterations;
      const double rn = r.norm();
      sol.residual = bn > 0.0 ? rn / bn : 0.0;
      if (rn <= target) return x.allFinite();
      precondition(r, z);
      const double rz_new = r.dot(z);
      p = z + (rz_new / rz) * p;
      rz = rz_new;
    }
    return false;
  }

  const QuasiStaticConfig& cfg_;
  Step step_;
  bool direct_;
  bool factored_ = false, analysed_ = false;
  Eigen::SimplicialLDLT<SpMat, Eigen::Lower> ldlt_;
  Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>> ic_;

 public:
  int factorisations = 0;
};

/// The row's approach rate a and sliding velocity s at the solution u.
void row_motion(const LinearRow& r, const DofMap& m, const QuasiStaticProblem& prob, const Eigen::VectorXd& u, double& a, Vec3& s) {
  Block blk[4];
  Eigen::Index wd;
  const int nb = row_blocks(r, m, blk, wd);
  a = 0.0;
  s.setZero();
  for (int p = 0; p < nb; ++p) {
    const Vec3 x = u.segment<3>(blk[p].dof);
    a += blk[p].h.dot(x);
    s += blk[p].g * x;
  }
  if (wd >= 0) a += u[wd];
  if (r.j < 0 && wd < 0) a += prob.wall_rate[static_cast<std::size_t>(-1 - r.j)];
}

/// The next round's modes from the solution; true when they are the same as this round's.
bool update_modes(const QuasiStaticProblem& prob, const DofMap& m, const Eigen::VectorXd& u,
                  std::vector<RowMode>& modes, QuasiStaticSolution& sol) {
  bool same = true;
  sol.sliding = sol.open = 0;
  sol.strain_increment = sol.approach_increment = sol.mean_strain_increment = 0.0;
  std::size_t counted = 0;
  for (std::size_t q = 0; q < prob.rows.size(); ++q) {
    const LinearRow& r = prob.rows[q];
    double a;
    Vec3 s;
    row_motion(r, m, prob, u, a, s);
    if (r.r_min > 0.0 && std::abs(a) * prob.dt / r.r_min > sol.approach_increment) {
      sol.approach_increment = std::abs(a) * prob.dt / r.r_min;
      sol.approach_row = q;
    }
    const double flow = std::abs(r.lc.flow0 + r.lc.flow1 * a);
    if (r.r_min > 0.0) {
      sol.mean_strain_increment += flow / r.r_min;
      ++counted;
    }
    if (r.r_min > 0.0 && flow / r.r_min > sol.strain_increment) {
      sol.strain_increment = flow / r.r_min;
      sol.strain_row = q;
    }
    if (!r.lc.unilateral && !std::isfinite(r.lc.mu)) continue;
    const RowMode& cur = modes[q];
    RowMode next;
    double fn = r.lc.f0 + r.lc.c * a;  // (a includes a known wall rate)
    if (r.lc.hertz > 0.0) {
      // The Hertz force at the predicted overlap and the secant over the step (Picard). A contact
      // predicted to separate first takes the chord to touching, F = F(d0) d / d0, and opens only if
      // that chord would pull: a particle free to roll about its one neck, pushed by a punch it
      // barely touches, then rolls exactly off it (its rounds had alternated between a closed
      // round, moving it at 29 m/s, and an open one, leaving it at rest).
      const double d0 = r.lc.overlap, d1 = d0 + a * prob.dt, dd = d1 - d0;
      fn = hertz_force(r.lc, d1);
      if (d1 > 0.0) {
        next.secant = std::abs(dd) > 1e-12 * std::max(d0, 1e-30) ? (fn - hertz_force(r.lc, d0)) / dd : 1.5 * r.lc.hertz * std::sqrt(std::max(d0, 0.0));
      } else if (d0 > 0.0 && !cur.open && (!cur.touch || d1 > -1e-6 * d0)) {
        next.touch = true;
        next.secant = hertz_force(r.lc, d0) / d0;
      } else {
        next.open = true;
      }
    } else {
      next.open = r.lc.unilateral && fn < 0.0;
    }
    if (!next.open && std::isfinite(r.lc.mu)) {
      // Coulomb regularised by the stick viscosity: F_t = -min(ct, cap / |s|) s, continuous and
      // monotone in s (a stick/slip switch on the trial force ft0 - ct s chattered: 110 of 150 die
      // contacts flipped back every 27 rounds).
      next.cap = r.lc.mu * std::max(fn, 0.0);
      const double sn = s.norm();
      if (sn * r.lc.ct > next.cap) {
        next.sliding = true;
        next.k = next.cap / sn;  // the secant viscosity
        // The slip's direction, once it held (within 25 deg) over two rounds: the relaxed Newton form
        // then applies (coeffs); a row turning or starting to slide takes the secant form.
        const Vec3 e = s / sn;
        if (cur.sliding && e.dot(cur.last) > 0.9) next.dir = e;
        next.last = e;
      }
    }
    if (next.open != cur.open) same = false;
    sol.open += next.open;
    sol.sliding += next.sliding;
    modes[q] = next;
  }
  if (counted > 0) sol.mean_strain_increment /= static_cast<double>(counted);
  return same;
}

}  // namespace

QuasiStaticSolution solve_quasi_static(const QuasiStaticProblem& prob, const QuasiStaticConfig& cfg) {
  const DofMap m = map_dofs(prob);
  QuasiStaticSolution sol;
  std::vector<RowMode> modes(prob.rows.size());
  if (prob.slip_guess.size() == prob.rows.size())
    for (std::size_t q = 0; q < modes.size(); ++q)
      if (prob.slip_guess[q] > 0.0 && std::isfinite(prob.rows[q].lc.mu)) {
        modes[q].sliding = true;
        modes[q].k = prob.slip_guess[q];
      }
  Eigen::VectorXd u, u_last, x;
  Assembly asm_;
  RoundSolver solver(cfg, prob.step, m.size);
  Eigen::VectorXd reg, scale;
  const bool warm = std::any_of(modes.begin(), modes.end(), [](const RowMode& r) { return r.sliding; });
  sol.converged = false;
  for (std::int64_t round = 0; round < std::max<std::int64_t>(1, cfg.friction_iterations); ++round) {
    Eigen::VectorXd b;
    asm_.assemble(prob, m, modes, cfg.slip_relaxation, b);
    if (round == 0) {
      reg = regularisation(asm_.K, m, prob.step);
      scale = (asm_.K.diagonal() + reg).cwiseSqrt().cwiseInverse();
    }
    regularise_and_scale(asm_.K, reg, scale);
    solver.solve(asm_.K, scale.cwiseProduct(b), x, sol);
    u = scale.cwiseProduct(x);
    ++sol.rounds;
    const bool same_set = update_modes(prob, m, u, modes, sol);
    // Settled: the same open contacts, and the motion moved less than friction_tolerance (of its
    // largest component) since the last round.
    const bool settled = same_set && (round == 0 ? sol.sliding == 0 && !warm
                                                 : (u - u_last).lpNorm<Eigen::Infinity>() <= cfg.friction_tolerance * u.lpNorm<Eigen::Infinity>());
    u_last = u;
    if (settled) {
      sol.converged = true;
      break;
    }
  }
  sol.factorisations = solver.factorisations;
  sol.v.resize(prob.particles);
  sol.w.resize(prob.particles);
  for (std::size_t i = 0; i < prob.particles; ++i) {
    sol.v[i] = u.segment<3>(6 * static_cast<Eigen::Index>(i));
    sol.w[i] = u.segment<3>(6 * static_cast<Eigen::Index>(i) + 3);
  }
  sol.slip.assign(prob.rows.size(), 0.0);
  for (std::size_t q = 0; q < modes.size(); ++q)
    if (modes[q].sliding) sol.slip[q] = modes[q].k;
  sol.wall_rate = prob.wall_rate;
  for (std::size_t k = 0; k < m.wall_dof.size(); ++k)
    if (m.wall_dof[k] >= 0) sol.wall_rate[k] = u[m.wall_dof[k]];
  return sol;
}

}  // namespace sparkdem
