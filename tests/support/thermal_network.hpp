#pragma once
/// Closed-form time solutions of a linear heat network C dT/dt = -L T (no sources, no fixed
/// nodes) and the stiff scene of issue 6 ("Stability"), shared by the component tests and
/// benchmarks/thermal_convergence.
///
/// Modal solution: with A = C^-1/2 L C^-1/2 = Q diag(lambda_k) Q^T (symmetric, lambda_k >= 0),
///   T(t)       = C^-1/2 Q diag(exp(-lambda_k t))       Q^T C^1/2 T0   (exact)
///   T_n (FE)   = C^-1/2 Q diag((1 - lambda_k h)^n)     Q^T C^1/2 T0   (forward Euler, step h)
///   T_n (BE)   = C^-1/2 Q diag((1 + lambda_k h)^-n)    Q^T C^1/2 T0   (backward Euler)
/// so a module's output can be compared with the recurrence of its own scheme (round-off) and
/// with the exact solution (time-discretisation error).
///
/// Backward-Euler error bound: per mode |(1 + x)^-n - e^-(n x)| <= E_n = max_{x>=0} of that
/// (x = lambda h), so |T_i^BE(t) - T_i(t)| <= E_n sum_k |(C^-1/2 Q)_ik (Q^T C^1/2 T0)_k|
/// (the zero mode, x = 0, contributes nothing). E_n ~ 2 e^-2 / n = 0.27 / n for large n (at n x = 2);
/// `be_mode_error_bound` evaluates it numerically.
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <string>
#include <vector>

#include "engine/state/particle_set.hpp"
#include "engine/state/state.hpp"
#include "physics/thermal/heat_conduction.hpp"
#include "tests/support/scene.hpp"

namespace sparkdem::test {

class ModalSolution {
 public:
  /// L: the network Laplacian [W/K] (symmetric, zero row sums); C: heat capacities [J/K].
  ModalSolution(const Eigen::MatrixXd& L, const Eigen::VectorXd& C) : sqrtC_(C.cwiseSqrt()) {
    const Eigen::MatrixXd A = sqrtC_.cwiseInverse().asDiagonal() * L * sqrtC_.cwiseInverse().asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(0.5 * (A + A.transpose()));
    lambda_ = es.eigenvalues().cwiseMax(0.0);  // [1/s]
    Q_ = es.eigenvectors();
  }
  const Eigen::VectorXd& rates() const { return lambda_; }
  /// sum_k r(lambda_k) (C^-1/2 Q)_ik (Q^T C^1/2 T0)_k.
  Eigen::VectorXd apply(const Eigen::VectorXd& T0, const std::function<double(double)>& r) const {
    Eigen::VectorXd c = Q_.transpose() * sqrtC_.cwiseProduct(T0);
    for (Eigen::Index k = 0; k < c.size(); ++k) c[k] *= r(lambda_[k]);
    return sqrtC_.cwiseInverse().cwiseProduct(Q_ * c);
  }
  Eigen::VectorXd exact(const Eigen::VectorXd& T0, double t) const {
    return apply(T0, [t](double l) { return std::exp(-l * t); });
  }
  /// int_0^t T(t') dt' [K s] (per mode (1 - e^-lambda t) / lambda, t for lambda = 0).
  Eigen::VectorXd integral(const Eigen::VectorXd& T0, double t) const {
    return apply(T0, [t](double l) { return l * t > 1e-12 ? -std::expm1(-l * t) / l : t; });
  }
  Eigen::VectorXd forward_euler(const Eigen::VectorXd& T0, double h, double n) const {
    return apply(T0, [h, n](double l) { return std::pow(1.0 - l * h, n); });
  }
  Eigen::VectorXd backward_euler(const Eigen::VectorXd& T0, double h, double n) const {
    return apply(T0, [h, n](double l) { return std::pow(1.0 + l * h, -n); });
  }
  /// sum_k |(C^-1/2 Q)_ik (Q^T C^1/2 T0)_k| over the non-zero modes, per node [K].
  Eigen::VectorXd modal_amplitude(const Eigen::VectorXd& T0) const {
    const Eigen::VectorXd c = Q_.transpose() * sqrtC_.cwiseProduct(T0);
    const double lmax = lambda_.maxCoeff();
    Eigen::VectorXd out = Eigen::VectorXd::Zero(T0.size());
    for (Eigen::Index k = 0; k < c.size(); ++k) {
      if (lambda_[k] <= 1e-12 * lmax) continue;  // the conserved mean
      out += (sqrtC_.cwiseInverse().cwiseProduct(Q_.col(k)) * c[k]).cwiseAbs();
    }
    return out;
  }

 private:
  Eigen::VectorXd sqrtC_, lambda_;
  Eigen::MatrixXd Q_;
};

/// max over x >= 0 of |(1 + x)^-n - exp(-n x)| (scan of x on a log grid, refined): the largest
/// backward-Euler error of one decaying mode after n steps, per unit of its initial amplitude.
inline double be_mode_error_bound(double n) {
  double best = 0.0;
  for (double lx = -8.0; lx <= 4.0; lx += 1e-3) {
    const double x = std::pow(10.0, lx);
    best = std::max(best, std::abs(std::pow(1.0 + x, -n) - std::exp(-n * x)));
  }
  return best * 1.001;  // grid refinement margin
}

/// The stiff scene (issue 6, "Stability"): four steel spheres of radius R = 1 mm in a chain along
/// x (L0-L1-L2 pressed, overlap 20 um: Hertz a = sqrt(R/2 x 20 um) = 100 um), a tiny steel sphere
/// of radius 10 um pressed against L0 (overlap 1 um, a = 3.15 um), and L3, an insulating
/// inclusion (set "insulator", conductivity factor f), barely touching L2 (overlap 2 nm,
/// a = 1 um). Batchelor-O'Brien branches G = 4 a lambda_i lambda_j / (lambda_i + lambda_j):
///   G(L0-L1) = G(L1-L2) = 2 lambda 100 um = 3e-3 W/K (the largest),
///   G(L2-L3) = 2 lambda 1 um x 2f / (1 + f) = 3e-11 W/K with f = 1 / (2e6 - 1): contrast 1e8;
///   G(t-L0) = 2 lambda 3.15 um = 9.44e-5 W/K on C_t = 1.65e-8 J/K: the stiff node
/// (its rate G/C_t = 5.7e3 1/s against 0.18 1/s for the chain: the explicit step is set by it).
/// Initial temperatures: L0 at 500 K, the others at 300 K.
struct StiffScene {
  static constexpr double R = 1e-3, r = 1e-5;                      // [m]
  static constexpr double rho = 7900.0, c = 500.0, lambda = 15.0;  // steel 304L [SI]
  static constexpr double d_ll = 20e-6, d_t = 1e-6, d_ins = 2e-9;  // overlaps [m]
  static constexpr double factor = 1.0 / (2e6 - 1.0);              // insulator conductivity factor [-]
  /// Local indices (and ids) in the order added.
  enum : int { L0 = 0, L1 = 1, L2 = 2, L3 = 3, T = 4, N = 5 };

  /// heat_conduction parameters of the scene (Batchelor-O'Brien branches, the insulator's factor).
  static physics::HeatConduction::Params heat_params(const std::string& scheme) {
    physics::HeatConduction::Params p;
    p.model = "batchelor_obrien";
    p.contact_radius = "hertz";
    p.conductivity = lambda;
    p.density = rho;
    p.specific_heat = c;
    p.scheme = scheme;
    p.conductivity_sets = "insulator";
    p.conductivity_factors = {factor};
    return p;
  }

  static void build(State& s) {
    const double x1 = 2 * R - d_ll;
    add_sphere(s, Vec3(0, 0, 0), R, rho);
    add_sphere(s, Vec3(x1, 0, 0), R, rho);
    add_sphere(s, Vec3(2 * x1, 0, 0), R, rho);
    add_sphere(s, Vec3(2 * x1 + 2 * R - d_ins, 0, 0), R, rho);
    add_sphere(s, Vec3(-(R + r - d_t), 0, 0), r, rho);
    s.particles.fields.declare({"temperature", 1, "K", 0.0, true}, s.particles.size());
    s.particles.fields.data("temperature") = initial_std();
    SetSelector sel;
    sel.kind = SetSelector::Kind::Ids;
    sel.ids = {L3};
    assign_set(s, "insulator", sel);
  }
  static std::vector<double> initial_std() { return {500.0, 300.0, 300.0, 300.0, 300.0}; }
  static Eigen::VectorXd initial() {
    const auto v = initial_std();
    return Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
  }
  static double hertz_a(double ra, double rb, double overlap) { return std::sqrt(ra * rb / (ra + rb) * overlap); }
  /// Branch conductances [W/K] from the geometry (independent of the module's code).
  static double g_ll() { return 2.0 * lambda * hertz_a(R, R, d_ll); }
  static double g_t() { return 2.0 * lambda * hertz_a(R, r, d_t); }
  static double g_ins() { return 2.0 * lambda * hertz_a(R, R, d_ins) * 2.0 * factor / (1.0 + factor); }
  static double capacity(double radius) { return rho * c * 4.0 / 3.0 * std::numbers::pi * radius * radius * radius; }
  static Eigen::VectorXd capacities() {
    Eigen::VectorXd C(N);
    C << capacity(R), capacity(R), capacity(R), capacity(R), capacity(r);
    return C;
  }
  static Eigen::MatrixXd laplacian() {
    Eigen::MatrixXd L = Eigen::MatrixXd::Zero(N, N);
    auto edge = [&](int a, int b, double g) {
      L(a, a) += g;
      L(b, b) += g;
      L(a, b) -= g;
      L(b, a) -= g;
    };
    edge(L0, L1, g_ll());
    edge(L1, L2, g_ll());
    edge(L2, L3, g_ins());
    edge(T, L0, g_t());
    return L;
  }
  /// The explicit stable step of the module: safety x min_i C_i / sum_j G_ij (the tiny sphere).
  static double explicit_stable_dt(double safety = 0.9) {
    const Eigen::VectorXd C = capacities();
    const Eigen::MatrixXd L = laplacian();
    double m = 1e300;
    for (int i = 0; i < N; ++i) m = std::min(m, C[i] / L(i, i));
    return safety * m;
  }
};

}  // namespace sparkdem::test
