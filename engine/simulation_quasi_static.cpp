// The inertia-free path of Simulation (StageConfig::quasi_static): one step = substeps of
// neighbours, solve, pair pass, drift, wall pass (the order is listed in engine/schedule/scheduler.hpp).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "engine/core/error.hpp"
#include "engine/integrate/velocity_verlet.hpp"
#include "engine/simulation.hpp"

namespace sparkdem {

namespace {
/// Each wall's slip field (quasi_static_slip_field), looked up once per substep.
template <class Fields>
auto slip_fields(Fields& fields, const std::vector<Wall>& walls) {
  std::vector<decltype(&fields.data(std::string()))> out;
  for (const Wall& w : walls) out.push_back(&fields.data(quasi_static_slip_field(w.name)));
  return out;
}

const char* const kSubstepMark = "quasi_static/substep";  ///< the last substep [s] (checkpointed with the marks)

std::string g6(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", x);
  return buf;
}
}  // namespace

/// What a quasi-static stage cannot take, refused before step 0 with what to change.
void Simulation::check_quasi_static(const StageConfig& cfg) const {
  const std::string where = "stage '" + cfg.name + "' (quasi_static): ";
  if (!law_.has_linear_contacts())
    throw SetupError(where + "the contact law '" + law_.name() + "' has no inertia-free form (linear_contact); run the stage explicit");
  if (cfg.time_scale != 1.0 || cfg.mass_scaling != 1.0 || cfg.mass_floor_radius > 0.0)
    throw SetupError(where + "time_scale, mass_scaling and mass_floor_radius scale inertia, which this path has none of; leave them at 1, 1, 0");
  if (!cfg.prescribed_sets.empty()) throw SetupError(where + "prescribed particle sets are not supported; run the stage explicit");
  for (const auto& w : s_.walls)
    if (w.motion.kind == WallMotion::Kind::Pressure && !w.is_plane())
      throw SetupError(where + "wall '" + w.name + "': a pressure-controlled wall must be a plane");
  const QuasiStaticConfig& q = cfg.quasi;
  if (!(q.max_strain_increment > 0.0) || !(q.max_approach_increment > 0.0) || q.max_mean_strain_increment < 0.0 || !(q.tolerance > 0.0) || q.max_iterations < 1 || q.friction_iterations < 1 || q.max_substeps < 1)
    throw SetupError(where + "max_strain_increment and tolerance must be positive, the iteration and substep counts at least 1");
}

/// The solve's input for a substep of length h ending at stage time t_end: the rows at the current
/// positions, the known walls' offset rates over the substep and the punches' loads at its end.
QuasiStaticProblem Simulation::quasi_static_problem(double t_end, double h, double t_area) const {
  QuasiStaticProblem prob;
  prob.particles = s_.particles.size();
  prob.dt = h;
  prob.step = s_.step + 1;
  prob.rows = law_.linear_rows(s_.particles, s_.contacts, s_.walls, s_.wall_candidates, s_.wall_history, h);
  prob.slip_guess.assign(prob.rows.size(), 0.0);
  const auto slip = slip_fields(s_.particles.fields, s_.walls);
  for (std::size_t q = 0; q < prob.rows.size(); ++q) {
    const LinearRow& r = prob.rows[q];
    if (r.j < 0) prob.slip_guess[q] = (*slip[static_cast<std::size_t>(-1 - r.j)])[r.i];
  }
  for (const Wall& w : s_.walls) {
    if (w.motion.kind == WallMotion::Kind::Pressure && !w.halted) {
      prob.wall_rate.push_back(std::numeric_limits<double>::quiet_NaN());
      prob.wall_load.push_back(pressure_load(w, t_end, t_area, time_scale_));
      continue;
    }
    Wall next = w;
    advance_wall(next, t_end, h, t_area, time_scale_);
    prob.wall_rate.push_back((next.u - w.u) / h);
    prob.wall_load.push_back(0.0);
  }
  for (std::size_t k = 0; k < s_.walls.size(); ++k) {
    if (!std::isnan(prob.wall_rate[k])) continue;
    const auto touches = [k](const LinearRow& r) { return r.j == -1 - static_cast<std::int64_t>(k); };
    if (std::none_of(prob.rows.begin(), prob.rows.end(), touches))
      throw PhysicsError(s_.step + 1, {}, "quasi-static step",
                         "the pressure-controlled wall '" + s_.walls[k].name +
                             "' touches no particle, so nothing balances its load: a quasi-static stage moves a punch by force "
                             "balance only; put it on the packing first (an explicit stage with its servo, or a generator that places it)");
  }
  return prob;
}

/// Apply a solved substep: the velocities; the pair pass over the substep (histories, forces at its
/// end) at the positions the rows were made at; the drift; the walls; the wall pass.
void Simulation::commit_quasi_static(const QuasiStaticSolution& sol, const QuasiStaticProblem& prob, double t_end, double t_area) {
  auto& p = s_.particles;
  const double h = prob.dt;
  const std::int64_t n = static_cast<std::int64_t>(p.size());
  for (std::int64_t i = 0; i < n; ++i) {
    p.velocity[i] = sol.v[i];
    p.omega[i] = sol.w[i];
  }
  zero_forces();
  pair_forces(h);
  par::for_each(n, par::kLight, [&](std::int64_t i) {
    p.position[i] += h * p.velocity[i];
    const double w2 = p.omega[i].squaredNorm();
    if (w2 > 0.0) p.orientation[i] = renormalised(rotation_quaternion(p.omega[i], w2, h) * p.orientation[i]);
  });
  for (std::size_t k = 0; k < s_.walls.size(); ++k) {
    Wall& w = s_.walls[k];
    const double u_old = w.u;
    if (std::isnan(prob.wall_rate[k])) {  // a punch: its solved rate, pressing with its load
      w.u_dot = sol.wall_rate[k];
      w.u += h * w.u_dot;
      w.work += prob.wall_load[k] * (w.u - u_old);
    } else {
      const double load = advance_wall(w, t_end, h, t_area, time_scale_);
      w.work += load * (w.u - u_old);
    }
  }
  wall_forces(h);
  const auto slip = slip_fields(p.fields, s_.walls);
  for (auto* f : slip) std::fill(f->begin(), f->end(), 0.0);
  for (std::size_t q = 0; q < prob.rows.size(); ++q) {
    const LinearRow& r = prob.rows[q];
    if (r.j < 0) (*slip[static_cast<std::size_t>(-1 - r.j)])[r.i] = sol.slip[q];
  }
}

/// Largest |net force| of a particle over the mean |force| of the live contact rows (0 without
/// contacts): the balance the solve imposed, measured on the law's own forces.
double Simulation::force_residual() const {
  const auto& p = s_.particles;
  double fmax = 0.0, sum = 0.0;
  std::size_t rows = 0;
  for (std::size_t i = 0; i < p.size(); ++i) fmax = std::max(fmax, p.force[i].norm());
  for (std::size_t r = 0; r < s_.contacts.size(); ++r) {
    const double f = s_.contacts.force()[r].norm();
    if (f > 0.0) {
      sum += f;
      ++rows;
    }
  }
  return rows > 0 && sum > 0.0 ? fmax / (sum / static_cast<double>(rows)) : 0.0;
}

/// A substep of dt / max_substeps still over a limit: the contact, its particles and its figures.
void Simulation::throw_increment_error(const QuasiStaticProblem& prob, const QuasiStaticSolution& sol, const QuasiStaticConfig& q,
                                       double hs) const {
  const bool flow = sol.strain_increment / q.max_strain_increment >= sol.approach_increment / q.max_approach_increment;
  const LinearRow& r = prob.rows[flow ? sol.strain_row : sol.approach_row];
  std::vector<Id> ids = {s_.particles.id[r.i]};
  if (r.j >= 0) ids.push_back(s_.particles.id[static_cast<std::size_t>(r.j)]);
  const std::string what = r.j >= 0 ? "the pair" : "the contact with wall '" + s_.walls[static_cast<std::size_t>(-1 - r.j)].name + "'";
  throw PhysicsError(s_.step + 1, ids, flow ? "strain increment" : "approach increment",
                     what + " (f0 " + g6(r.lc.f0) + " N, c " + g6(r.lc.c) + " N s/m, smaller radius " + g6(r.r_min) + " m): a substep of " +
                         g6(hs) + " s (dt / max_substeps) still " +
                         (flow ? "flows it by " + g6(sol.strain_increment) + " of its smaller radius, above max_strain_increment " +
                                     g6(q.max_strain_increment)
                               : "moves it by " + g6(sol.approach_increment) + " of its smaller radius, above max_approach_increment " +
                                     g6(q.max_approach_increment) + " (an elastic re-balancing that no shorter substep makes smaller)") +
                         " (mean flow over the contacts " + g6(sol.mean_strain_increment) + " of their smaller radii)" +
                         "; raise quasi_static.max_substeps or lower dt");
}

/// One step of dt ending at stage time t_new, in substeps no contact's approach exceeds
/// max_strain_increment x its smaller radius of viscous flow in. A substep too long is solved again shorter
/// (h x max(0.1, 0.8 limit / increment)); after an accepted one the next is h x min(1.5, 0.8 limit /
/// increment), also into the next step.
void Simulation::quasi_static_step(const StageConfig& cfg, double dt, double t_new, double t_area) {
  const QuasiStaticConfig& q = cfg.quasi;
  const double t0 = t_new - dt, h_min = dt / static_cast<double>(q.max_substeps);
  const auto mark = s_.marks.find(kSubstepMark);
  double h = mark == s_.marks.end() ? dt : std::min(dt, mark->second);
  double done = 0.0;
  Step substeps = 0;
  auto& st = stats_->quasi_static;
  while (dt - done > 1e-12 * dt) {
    const bool last = h >= dt - done;
    const double hs = last ? dt - done : h;
    const double t_end = last ? t_new : t0 + done + hs;
    update_neighbors(skin_, cfg.sort_every_rebuilds);
    const auto c0 = std::chrono::steady_clock::now();
    const QuasiStaticProblem prob = quasi_static_problem(t_end, hs, t_area);
    const QuasiStaticSolution sol = solve_quasi_static(prob, q);
    st.solve_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - c0).count();
    st.rounds += sol.rounds;
    st.max_rounds = std::max<Step>(st.max_rounds, sol.rounds);
    st.cg_iterations += sol.iterations;
    st.factorisations += sol.factorisations;
    st.unsettled += sol.converged ? 0 : 1;
    // The substep's largest ratio to its limits: viscous flow, and the whole approach.
    double over = std::max(sol.strain_increment / q.max_strain_increment, sol.approach_increment / q.max_approach_increment);
    if (q.max_mean_strain_increment > 0.0) over = std::max(over, sol.mean_strain_increment / q.max_mean_strain_increment);
    if (over > 1.0) {
      if (hs <= h_min * (1.0 + 1e-9)) throw_increment_error(prob, sol, q, hs);
      h = std::max(h_min, hs * std::max(0.1, 0.8 / over));
      ++st.rejected;
      continue;
    }
    commit_quasi_static(sol, prob, t_end, t_area);
    // The next substep from this one's margin: at most 1.5 x longer (a fresh neck that forced a
    // short substep relaxes within a few; without growth the rest of the step kept the short one,
    // 375 substeps of 1.6 ms where 4 had sufficed).
    if (!last) h = std::min(dt, hs * std::min(1.5, 0.8 / std::max(over, 1e-12)));
    st.max_strain_increment = std::max(st.max_strain_increment, sol.strain_increment);
    st.max_mean_strain_increment = std::max(st.max_mean_strain_increment, sol.mean_strain_increment);
    done += hs;
    ++substeps;
  }
  s_.marks[kSubstepMark] = substeps > 1 ? h : dt;
  st.substeps += substeps;
  st.max_substeps = std::max(st.max_substeps, substeps);
  st.last_residual = force_residual();
  st.max_residual = std::max(st.max_residual, st.last_residual);
}

}  // namespace sparkdem
