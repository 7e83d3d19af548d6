#pragma once
/// # The inertia-free step (issue 36 item 1): particle velocities from the balance of the forces
///
/// A sintering compact creeps for minutes; its inertia never matters, and the explicit path could
/// reach the hold only by scaling mass and time (which changed the microstructure). Here each step
/// solves for the velocities v_i, spins w_i and the rates W_k of force-controlled walls that make
/// every particle's net force zero at the END of the step, given each contact's forces as affine
/// functions of its motion over the step (LinearContact, provided by the law):
///   normal on i:      F_n = f0 + c a,    a = -(v_i - v_j) . n            (+ W_k for a wall k)
///   tangential on i:  F_t = ft0 - ct s,  s = P (v_i - v_j) + n x (arm_i w_i + arm_j w_j)
/// The balance is the stationary point of the rate potential
///   Phi(u) = sum [c a^2/2 + f0 a] + sum [ct |s|^2/2 - ft0 . s] - sum_k L_k W_k,
/// so the system K u = b is symmetric positive semi-definite: K = sum c H^T H + ct G^T G with
/// a = H u, s = G u; b = -sum f0 H^T + sum G^T ft0 + L. A force-controlled wall (a punch held at the
/// load L_k = p(t) A) is one more unknown, its equation sum over its contacts F_n = L_k.
/// Formulation: Parhami & McMeeking, Mech. Mater. 27 (1998) 111 (a viscous contact network solved
/// for the velocities); Jagota & Dawson, Acta Metall. 36 (1988) 2551 (the same for sintering
/// spheres with rotations). Neither scales mass or time.
///
/// Nonlinear parts, iterated within the step (rounds of the linear solve, at most
/// friction_iterations): a unilateral contact (a wall, a contact without a neck) that would pull
/// (F_n < 0) is dropped from the round; a contact with a Coulomb cap whose trial tangential force
/// exceeds mu F_n slides, with the secant viscosity ct = mu F_n / |s| and ft0 = 0 (the force
/// mu F_n against the sliding), until the set of sliding and open contacts repeats and every secant
/// viscosity moved less than friction_tolerance.
///
/// Unknowns without any contact (a rattler) get a regularising drag of 1e-12 times the mean
/// diagonal of their kind (translation or rotation), so K is definite; their right-hand side is
/// zero, so they stay at rest. A neck resists the relative rotation of its particles (rolling and
/// twisting, LinearContact::bend and twist), so a particle hanging by one neck has no free mode.
///
/// A Hertz row (a wall, a contact without a neck) predicted to separate first takes its chord to
/// touching, F = F(d0) d / d0, and opens only if that chord would pull: a particle pushed along a
/// near-free mode then moves exactly off the contact.
///
/// The rounds share K's pattern and differ only in the coefficients of the capped and unilateral
/// rows: the first round factorises, the later ones run conjugate gradients preconditioned by that
/// factor (a direct solver refactorises if they do not converge within 50 iterations).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "engine/contact/contact_model.hpp"

namespace sparkdem {

struct QuasiStaticConfig {
  double max_strain_increment = 2e-3;  ///< largest viscous flow of a contact over a substep / its smaller radius
  double max_approach_increment = 0.05; ///< largest approach (elastic + viscous) of a contact over a substep / its smaller radius
  double max_mean_strain_increment = 0.0; ///< mean over the contacts of flow / smaller radius per substep (0: no limit): the compact's densification increment
  double tolerance = 1e-10;            ///< relative residual |K u - b| / |b| of the iterative solve
  std::int64_t max_iterations = 20000;        ///< conjugate-gradient iterations
  std::int64_t friction_iterations = 30;      ///< rounds of the nonlinear contacts (slip, opening)
  double slip_relaxation = 0.1;        ///< eps: the fraction of a sliding row's secant viscosity kept along its slip (1: secant rounds; -> 0: Newton)
  double friction_tolerance = 1e-3;    ///< change of the motion between rounds / its largest component that ends the rounds
  std::string solver = "auto";         ///< direct (sparse LDL^T), cg (IC-preconditioned), auto (direct below 60,000 unknowns)
  std::int64_t max_substeps = 1000000;           ///< substeps a step may be split into by max_strain_increment
};

/// What one solve is given: the rows, and per wall its known offset rate [m/s] (NaN: the rate is
/// an unknown of the solve, a force-controlled wall) and the load [N] it presses with (used for
/// unknown rates).
struct QuasiStaticProblem {
  std::size_t particles = 0;
  std::vector<LinearRow> rows;
  std::vector<double> wall_rate;
  std::vector<double> wall_load;
  double dt = 0.0;  ///< [s] the step the rows were made for
  Step step = 0;    ///< the step being computed (error messages)
  /// Optional, per row: the slip viscosity a capped row ended its last solve with [N s/m] (0:
  /// sticking): the first round starts from it (the rounds converge linearly, ~0.7 per round).
  std::vector<double> slip_guess;
};

struct QuasiStaticSolution {
  std::vector<Vec3> v, w;          ///< [m/s], [rad/s] per particle
  std::vector<double> wall_rate;   ///< [m/s] per wall (the known ones copied)
  std::vector<double> slip;        ///< [N s/m] per row: its slip viscosity in the last round (0: sticking or uncapped)
  double strain_increment = 0.0;   ///< max over contacts of |flow over the step| / r_min (LinearContact::flow0, flow1)
  std::size_t strain_row = 0;      ///< the row of that maximum
  double mean_strain_increment = 0.0;  ///< mean over the contacts of |flow over the step| / r_min
  double approach_increment = 0.0; ///< max over contacts of |a| dt / r_min (the whole approach, elastic part included)
  std::size_t approach_row = 0;    ///< the row of that maximum
  int rounds = 0;                  ///< linear solves (nonlinear rounds)
  int iterations = 0;              ///< CG iterations, summed over rounds (rounds after the first reuse the first one's factor as CG's preconditioner)
  int factorisations = 0;          ///< factorisations (LDL^T or incomplete Cholesky) of this solve
  double residual = 0.0;           ///< relative residual of the last linear solve
  std::size_t sliding = 0;         ///< contacts sliding in the last round
  std::size_t open = 0;            ///< unilateral contacts dropped in the last round
  bool converged = true;           ///< the nonlinear rounds settled within friction_iterations
};

/// The particle field holding, per particle, the slip viscosity of its contact with `wall` at the
/// last solve [N s/m] (0: sticking or none): the next solve's first guess (QuasiStaticProblem::slip_guess).
inline std::string quasi_static_slip_field(const std::string& wall) { return "quasi_static/slip/" + wall; }

/// Solve one inertia-free step (see the file comment). Throws PhysicsError if the linear solve
/// fails (a singular or indefinite system, or CG not reaching the tolerance).
QuasiStaticSolution solve_quasi_static(const QuasiStaticProblem& prob, const QuasiStaticConfig& cfg);

}  // namespace sparkdem
