#pragma once
/// The ONE generic pair loop, instantiated per law (ContactModelT<Law>), and its type-erased
/// handle. One virtual call per pass; no per-contact branching on the law.
///
/// A Law provides:
///   struct Params; static ParamSpec<Params> spec();
///   static std::vector<std::string> state_columns();   // per-contact state (history)
///   explicit Law(const Params&);
///   ContactForces operator()(const ContactGeometry&, const RelativeMotion&, double dt, double* state) const;
///   double normal_stiffness(const ContactGeometry&) const;   // tangent dF/d(delta) [N/m]
///   double tangential_stiffness(const ContactGeometry&) const; // [N/m]
///   double rayleigh_dt(double radius, double density) const; // +inf if not applicable [s]
/// and optionally normal_stiffness(g, state) / tangential_stiffness(g, state) when the stiffness
/// of a pair depends on its state (used for the stable step of the contact table's pairs), and
/// damping(g, state) -> {c_n, c_t} [N s/m] when its dashpots are strong enough to limit the step
/// (explicit damping: dt <= (2/w)(sqrt(1 + z^2) - z) per Gershgorin row, z the row's damping ratio).
/// and optionally tangential_free() -> true when its tangential force is identically zero (a
/// Coulomb-capped law at mu = 0): the stable step then leaves the tangential springs out;
/// and optionally, for pairs whose life the law decides (a sintered neck outlives zero or
/// negative overlap):
///   static constexpr bool kPersistent = true;
///   bool alive(const double* state) const;   // keep the row and call the law at overlap <= 0
/// A law whose forces depend on temperature or on physical time (a sintering law) declares
///   static constexpr bool kThermal = true;
/// and then receives g.temperature (pair mean of the particle field "temperature", NaN when no
/// module provides it) and g.time_scale (physical seconds per mechanical second of the stage).
/// A persistent law is called with g.overlap <= 0 (a gap) while alive(state) holds; its row is
/// kept by the contact table even when the pair leaves the neighbour candidates.
#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "engine/contact/geometry.hpp"
#include "engine/contact/lanes.hpp"
#include "engine/state/contact_table.hpp"
#include "engine/state/particle_store.hpp"
#include "engine/state/wall_history.hpp"
#include "engine/walls/wall.hpp"
#include "engine/core/error.hpp"
#include "engine/core/numbers.hpp"
#include "engine/core/parallel.hpp"

namespace sparkdem {

/// Per-wall totals of one wall pass.
struct WallLoads {
  std::vector<Vec3> force;     ///< force of the particles on each wall [N]
  std::vector<double> normal;  ///< sum over contacts of the push against the inward normal [N]
};

/// One contact of the inertia-free step (engine/integrate/quasi_static.hpp): particles i and j
/// (j < 0: the wall of index -1 - j), the unit normal n (j -> i), the lever arms of the contact
/// point, the smaller radius (the strain-increment measure) and the law's affine forces.
struct LinearRow {
  Index i = 0;
  std::int64_t j = -1;
  Vec3 n = Vec3::UnitZ();
  double arm_i = 0.0, arm_j = 0.0;  ///< [m]
  double r_min = 0.0;               ///< [m]
  LinearContact lc;
};

class ContactModel {
 public:
  virtual ~ContactModel() = default;
  virtual std::string name() const = 0;
  virtual std::vector<std::string> state_columns() const = 0;
  /// For laws with persistent pairs: the rule that keeps a row alive (see ContactTable::rebuild);
  /// empty for laws whose pairs live only while the spheres overlap.
  virtual std::function<bool(const double*)> alive_rule() const { return {}; }
  /// Particle-particle pass: fills table.force/torque/overlap rows (does not gather).
  /// `time_scale` = physical seconds per mechanical second (used by kThermal laws only).
  /// `inertia_free` (a quasi-static stage): every geometry's m* is 0, so the laws' numerical
  /// dashpots, which scale with sqrt(m* k), vanish as the inertia they damp does.
  virtual void pair_pass(const ParticleStore& p, ContactTable& table, double dt, double time_scale = 1.0, bool inertia_free = false) const = 0;
  /// pair_pass followed by table.gather into p.force / p.torque. Bit-identical to them when the
  /// particles' forces and torques are zero on entry (as at the step's contact pass, after
  /// zero_forces): on one thread the rows are added as they are computed (see the definition).
  virtual void pair_forces(ParticleStore& p, ContactTable& table, double dt, double time_scale = 1.0, bool inertia_free = false) const = 0;
  /// Particle-wall pass over the candidate particles of each wall (those within r + skin at the
  /// last neighbour rebuild); adds forces and torques to the particles; returns wall loads.
  /// Wall history: row r of wall k in `history` (WallHistory, one row per candidate) is candidate r's.
  virtual WallLoads wall_pass(ParticleStore& p, const std::vector<Wall>& walls, const std::vector<std::vector<Index>>& candidates,
                              WallHistory& history,
                              double dt, double time_scale = 1.0, bool inertia_free = false) const = 0;
  /// Stable step estimate from the current state [s]: min of the law's a-priori step (Rayleigh
  /// for Hertz laws) and 2/omega_max, omega_max^2 the largest eigenvalue of the mass-weighted
  /// stiffness matrix K~ = M^-1/2 K M^-1/2 of the current contacts, bounded by the tighter of two
  /// bounds that both hold:
  ///  (a) block Gershgorin over each particle's 6 x 6 blocks (spectral norms):
  ///        omega^2 <= max_i sum_j [ k_n (1/m_i + 1/sqrt(m_i m_j))
  ///                               + k_t (1/m_i + r_i^2/I_i + 1/sqrt(m_i m_j) + r_i r_j/sqrt(I_i I_j)) ]
  ///      (for one contact between spheres the k_t term is the exact eigenvalue of its springs);
  ///  (b) Weyl, lambda_max(K~_n + K~_t) <= lambda_max(K~_n) + lambda_max(K~_t), with the normal
  ///      springs k_n n n^T (translations only) bounded by scalar Gershgorin rows, exact per axis c:
  ///        lambda_max(K~_n) <= max_{i,c} sum_j k_n |n_c| |n|_1 (1/m_i + 1/sqrt(m_i m_j))
  ///      (a contact along x adds nothing to the y and z rows: on a frictionless simple-cubic
  ///      lattice this is the exact 4 k_n / m of the lattice's highest mode, where (a) gives
  ///      12 k_n / m), and the tangential and extra rows by (a)'s k_t term.
  /// The tangential springs drop out of both when the law's tangential force is identically
  /// zero (optional Law::tangential_free(), a Coulomb cap at mu = 0).
  /// `extra_rows` (optional, per particle [1/s^2]) are other stiffness contributions to the same
  /// block rows, e.g. from bonds (BondModel::add_stiffness_rows).
  /// Laws with dashpots (damping(g, state) -> {c_n, c_t}): per row, dt <= (2/w)(sqrt(1 + z^2) - z),
  /// z = beta_i / (2 w), beta_i the damping row of the same block structure as (a).
  virtual double stable_dt(const ParticleStore& p, const ContactTable& table, const std::vector<Wall>& walls,
                           const std::vector<double>* extra_rows = nullptr) const = 0;
  /// The same estimate without the a-priori step: 2/omega_max of the current network alone [s]
  /// (+inf without springs). stable_dt = min(a-priori step, network_stable_dt).
  virtual double network_stable_dt(const ParticleStore& p, const ContactTable& table, const std::vector<Wall>& walls,
                                   const std::vector<double>* extra_rows = nullptr) const = 0;
  /// True when the law has an inertia-free form (Law::linear_contact): quasi-static stages.
  virtual bool has_linear_contacts() const { return false; }
  /// The inertia-free rows of the live pairs of the contact table and of the walls' candidate
  /// particles in contact, for a step of dt (state read only). Empty for a law without the form.
  virtual std::vector<LinearRow> linear_rows(const ParticleStore& p, const ContactTable& table, const std::vector<Wall>& walls,
                                             const std::vector<std::vector<Index>>& candidates, const WallHistory& history,
                                             double dt) const {
    (void)p, (void)table, (void)walls, (void)candidates, (void)history, (void)dt;
    return {};
  }
  /// The run watchdog's default bound on overlap / smaller radius (pairs) and overlap / radius
  /// (walls): kDefaultOverlapRatioBound, or the law's own `overlap_ratio_bound()` when it has one
  /// (a law whose healthy runs reach larger overlaps, e.g. sintering densification).
  virtual double overlap_ratio_bound() const;
};

/// Elastic contact laws (Hooke, Hertz) are models of small overlaps; at half the smaller radius
/// their force has long stopped meaning anything, and no healthy granular run gets near it (the
/// shipped scenes stay below 0.05; see README "Run watchdog").
inline constexpr double kDefaultOverlapRatioBound = 0.5;
inline double ContactModel::overlap_ratio_bound() const { return kDefaultOverlapRatioBound; }

/// True if Law declares kThermal (reads temperature and the time scale).
template <class Law>
constexpr bool is_thermal() {
  if constexpr (requires { Law::kThermal; })
    return Law::kThermal;
  else
    return false;
}

/// True if Law declares persistent pairs.
template <class Law>
constexpr bool is_persistent() {
  if constexpr (requires { Law::kPersistent; })
    return Law::kPersistent;
  else
    return false;
}

namespace detail {
constexpr std::size_t kBlock = 1024;  // fixed reduction blocks: results independent of thread count
}  // namespace detail

/// Grain-boundary fraction per particle (seed 000 Eq. 22), f_i = sum over its rows of
/// pi a^2 / (4 pi r_i^2), a = the row's state column `neck_column` (live rows with a > 0). Serial
/// in row order: the same sums on any thread count.
inline std::vector<double> grain_boundary_fractions(const ParticleStore& p, const ContactTable& t, int neck_column) {
  std::vector<double> f(p.size(), 0.0);
  const int w = t.state_width();
  if (neck_column < 0 || neck_column >= w) return f;
  for (std::size_t r = 0; r < t.size(); ++r) {
    const double a = t.state(r)[neck_column];
    if (!(a > 0.0)) continue;
    const Index i = t.i(r), j = t.j(r);
    f[i] += a * a / (4.0 * p.radius[i] * p.radius[i]);
    f[j] += a * a / (4.0 * p.radius[j] * p.radius[j]);
  }
  return f;
}

template <class Law>
class ContactModelT final : public ContactModel {
 public:
  explicit ContactModelT(const typename Law::Params& params) : law_(params) {}
  const Law& law() const { return law_; }
  std::string name() const override { return std::string(Law::kName); }
  std::vector<std::string> state_columns() const override { return Law::state_columns(); }
  double overlap_ratio_bound() const override {
    if constexpr (requires(const Law& l) { l.overlap_ratio_bound(); })
      return law_.overlap_ratio_bound();
    else
      return kDefaultOverlapRatioBound;
  }
  static constexpr bool kLinear = requires(const Law& l, const ContactGeometry& g, const double* st) { l.linear_contact(g, 0.0, st); };
  bool has_linear_contacts() const override { return kLinear; }
  std::vector<LinearRow> linear_rows(const ParticleStore& p, const ContactTable& t, const std::vector<Wall>& walls,
                                     const std::vector<std::vector<Index>>& cand, const WallHistory& history, double dt) const override {
    std::vector<LinearRow> out;
    if constexpr (kLinear) {
      const PassInputs in = pass_inputs(p, t, 1.0);
      out.reserve(t.size());
      for (std::size_t r = 0; r < t.size(); ++r) {
        const Index i = t.i(r), j = t.j(r);
        const Vec3 d = p.position[i] - p.position[j];
        const double dist = d.norm();
        const double delta = p.radius[i] + p.radius[j] - dist;
        const double* state = in.width > 0 ? t.state(r) : nullptr;
        bool active = delta > 0.0;
        if constexpr (is_persistent<Law>()) active = active || law_.alive(state);
        if (!active || dist <= 0.0) continue;
        const ContactGeometry g = pair_geometry(p, i, j, d / dist, delta, in);
        out.push_back({i, j, g.n, g.arm_i, g.arm_j, std::min(g.r_i, g.r_j), law_.linear_contact(g, dt, state)});
      }
      for (std::size_t k = 0; k < walls.size(); ++k) {
        const double* hist = history_rows(const_cast<WallHistory&>(history), k, walls, cand, in.width);
        for (std::size_t r = 0; r < cand[k].size(); ++r) {
          const Index i = cand[k][r];
          Vec3 nrm;
          double dist;
          walls[k].distance(p.position[i], nrm, dist);
          if (p.radius[i] - dist <= 0.0) continue;
          const ContactGeometry g = wall_geometry(p, i, nrm, dist, in.temp, 1.0);
          const double* st = hist ? hist + r * static_cast<std::size_t>(in.width) : nullptr;
          out.push_back({i, -1 - static_cast<std::int64_t>(k), nrm, dist, 0.0, p.radius[i], law_.linear_contact(g, dt, st)});
        }
      }
    }
    return out;
  }

  std::function<bool(const double*)> alive_rule() const override {
    if constexpr (is_persistent<Law>())
      return [this](const double* st) { return law_.alive(st); };
    else
      return {};
  }

  void pair_pass(const ParticleStore& p, ContactTable& t, double dt, double time_scale = 1.0, bool inertia_free = false) const override {
    const std::int64_t rows = static_cast<std::int64_t>(t.size());
    PassInputs in = pass_inputs(p, t, time_scale);
    in.inertia_free = inertia_free;
    auto& Ti = t.torque_i();
    auto& Tj = t.torque_j();
    struct Sink {
      std::vector<Vec3>& Ti;
      std::vector<Vec3>& Tj;
      void dead(std::int64_t r) {
        Ti[r].setZero();
        Tj[r].setZero();
      }
      void live(std::int64_t r, Index, Index, const Vec3&, const Vec3& ti, const Vec3& tj) {
        Ti[r] = ti;
        Tj[r] = tj;
      }
    };
    const std::int64_t chunks = (rows + kPassChunk - 1) / kPassChunk;
    par::loop(par::worth(rows, par::kHeavy), chunks, [&](std::int64_t c) {
      Sink sink{Ti, Tj};
      row_range(p, t, c * kPassChunk, std::min(rows, (c + 1) * kPassChunk), dt, in, sink);
    });
  }

  void pair_forces(ParticleStore& p, ContactTable& t, double dt, double time_scale = 1.0, bool inertia_free = false) const override {
    const std::int64_t rows = static_cast<std::int64_t>(t.size());
    if (par::worth(rows, par::kHeavy) && par::threads() > 1) {
      pair_forces_split(p, t, dt, time_scale, inertia_free);
      return;
    }
    // One thread: each live row is added to its two particles as it is computed, in row order.
    // The sums start from the zeroed forces, so each takes the same operands in the same order as
    // the gather (bit-identical) without storing and re-reading the torque rows. Consecutive rows
    // often share i: its running sums stay in registers until i changes (a row never has j == i,
    // so no other row of the run touches them). The force rows are filled as by pair_pass; the
    // torque rows are not (only the gather reads them).
    PassInputs in = pass_inputs(p, t, time_scale);
    in.inertia_free = inertia_free;
    struct Sink {
      ParticleStore& p;
      Index cur = -1;
      Vec3 fi = Vec3::Zero(), ti = Vec3::Zero();
      void dead(std::int64_t) {}
      void live(std::int64_t, Index i, Index j, const Vec3& f, const Vec3& tri, const Vec3& trj) {
        if (i != cur) {
          if (cur >= 0) {
            p.force[cur] = fi;
            p.torque[cur] = ti;
          }
          cur = i;
          fi = p.force[i];
          ti = p.torque[i];
        }
        fi += f;
        ti += tri;
        p.force[j] -= f;
        p.torque[j] += trj;
      }
    } sink{p};
    row_range(p, t, 0, rows, dt, in, sink);
    if (sink.cur >= 0) {
      p.force[sink.cur] = sink.fi;
      p.torque[sink.cur] = sink.ti;
    }
  }

  /// pair_forces on a team of threads: each range of PairRows::row_split is walked in row order
  /// by one thread, which adds each live row straight into the particles its range owns (as the
  /// one-thread loop does) and stores the row's torques only for the boundary particles, gathered
  /// after the team joins. Every particle's sum takes its rows in row order from the zeroed force:
  /// bit-identical to the one-thread loop, with neither the torque rows of the whole table nor a
  /// second pass over it (the gather of every particle) in between.
  void pair_forces_split(ParticleStore& p, ContactTable& t, double dt, double time_scale, bool inertia_free) const {
    const int ranges = par::threads();
    // Ranges of equal expected work: a row whose spheres overlap now (or a persistent row kept
    // alive by its law) will most likely run the law at this step and the next ones.
    const auto& split = t.row_split(ranges, [&](std::int64_t r) {
      const Index i = t.i(r), j = t.j(r);
      const double reach = p.radius[i] + p.radius[j];
      bool live = (p.position[i] - p.position[j]).squaredNorm() < reach * reach;
      if constexpr (is_persistent<Law>()) live = live || (t.state_width() > 0 && law_.alive(t.state(r)));
      return live;
    }, lanes_run(t) ? PairRows::kLaneLiveRowCost : PairRows::kHeavyRowCost);
    PassInputs in = pass_inputs(p, t, time_scale);
    in.inertia_free = inertia_free;
    auto& Ti = t.torque_i();
    auto& Tj = t.torque_j();
    const std::int32_t* owner = split.owner.data();
    struct Sink {
      ParticleStore& p;
      std::vector<Vec3>& Ti;
      std::vector<Vec3>& Tj;
      const std::int32_t* owner;
      int range;
      void dead(std::int64_t r) {
        Ti[r].setZero();
        Tj[r].setZero();
      }
      void live(std::int64_t r, Index i, Index j, const Vec3& f, const Vec3& tri, const Vec3& trj) {
        if (owner[i] == range) {
          p.force[i] += f;
          p.torque[i] += tri;
        } else {
          Ti[r] = tri;
        }
        if (owner[j] == range) {
          p.force[j] -= f;
          p.torque[j] += trj;
        } else {
          Tj[r] = trj;
        }
      }
    };
#pragma omp parallel
    for (int range = par::thread_num(); range < ranges; range += par::team_size()) {
      Sink sink{p, Ti, Tj, owner, range};
      row_range(p, t, split.row_begin[range], split.row_begin[range + 1], dt, in, sink);
    }
    t.gather_particles(split.boundary, p.force, p.torque);
  }

  /// Particle-wall rows, wall by wall in candidate order: each row's force and torque are added to
  /// its particle, and to the wall's load in fixed blocks of kBlock rows. On a team of threads
  /// (wall_pass_team) each thread takes the rows of its own particles, so results do not depend on
  /// the thread count.
  WallLoads wall_pass(ParticleStore& p, const std::vector<Wall>& walls, const std::vector<std::vector<Index>>& cand, WallHistory& history,
                      double dt, double time_scale = 1.0, bool inertia_free = false) const override {
    const double* temp = nullptr;
    if constexpr (is_thermal<Law>())
      if (p.fields.has("temperature")) temp = p.fields.data("temperature").data();
    const int w = static_cast<int>(Law::state_columns().size());
    std::vector<double*> hist(walls.size(), nullptr);
    std::int64_t rows = 0;
    for (std::size_t k = 0; k < walls.size(); ++k) {
      hist[k] = history_rows(history, k, walls, cand, w);
      rows += static_cast<std::int64_t>(cand[k].size());
    }
    const WallPassInputs in{walls, cand, hist, w, temp, dt, time_scale, inertia_free};
    if (par::threads() > 1 && par::worth(rows, par::kHeavy)) return wall_pass_team(p, in);
    std::vector<WallLoadFold> fold(walls.size());
    for (std::size_t k = 0; k < walls.size(); ++k)
      wall_rows(p, in, k, 0, cand[k].size(), [&](std::size_t r, const WallLoadRow& row) { fold[k].add(r, row); });
    return wall_loads(fold, cand);
  }

  double stable_dt(const ParticleStore& p, const ContactTable& t, const std::vector<Wall>& walls,
                   const std::vector<double>* extra_rows = nullptr) const override {
    double dt = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double vol = 4.0 / 3.0 * kPi * p.radius[i] * p.radius[i] * p.radius[i];
      dt = std::min(dt, law_.rayleigh_dt(p.radius[i], p.mass[i] / vol));
    }
    return std::min(dt, network_stable_dt(p, t, walls, extra_rows));
  }

  double network_stable_dt(const ParticleStore& p, const ContactTable& t, const std::vector<Wall>& walls,
                           const std::vector<double>* extra_rows = nullptr) const override {
    double dt = std::numeric_limits<double>::infinity();
    StiffnessRows rows = stiffness_rows(p, t, walls, extra_rows);
    // The tighter of the two bounds on omega_max^2 (both hold; see the declaration).
    double split = 0.0, spring = 0.0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      split = std::max(split, std::max({rows.axis[3 * i], rows.axis[3 * i + 1], rows.axis[3 * i + 2]}));
      spring = std::max(spring, rows.other[i]);
    }
    split += spring;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const double w2 = std::min(rows.block[i], split);
      if (!(w2 > 0.0)) continue;
      const double w = std::sqrt(w2);
      if (rows.beta.empty()) {
        dt = std::min(dt, 2.0 / w);
      } else {
        // Velocity Verlet with explicit damping: stable for dt <= (2/w)(sqrt(1 + z^2) - z),
        // z = beta / (2 w) the damping ratio of the row (-> 2/beta when damping dominates).
        const double z = 0.5 * rows.beta[i] / w;
        dt = std::min(dt, 2.0 / w * (std::sqrt(1.0 + z * z) - z));
      }
    }
    return dt;
  }

 private:
  /// One wall row: the force on particle i, its torque and the force's normal component, or
  /// false (and the row's history cleared) when the particle does not touch the wall.
  struct WallRow {
    Vec3 force, torque;
    double normal;
  };
  bool wall_row(const ParticleStore& p, const Wall& wall, Index i, double* state, int width, const double* temp, double dt,
                double time_scale, bool inertia_free, WallRow& row) const {
    Vec3 nrm;
    double dist;
    wall.distance(p.position[i], nrm, dist);
    if (p.radius[i] - dist <= 0.0) {
      for (int c = 0; c < width; ++c) state[c] = 0.0;
      return false;
    }
    ContactGeometry g = wall_geometry(p, i, nrm, dist, temp, time_scale);
    if (inertia_free) g.m_eff = 0.0;
    const Vec3 vw = wall.u_dot * nrm;
    const RelativeMotion m = relative_motion(g, p.velocity[i], vw, p.omega[i], Vec3::Zero());
    const ContactForces f = law_(g, m, dt, state);
    row = {f.force, -g.arm_i * g.n.cross(f.tangential), f.force.dot(g.n)};
    return true;
  }

  /// What a wall pass reads besides the particles: the walls, their candidate lists (ascending
  /// particle indices, as wall_candidates builds them), each wall's history columns.
  struct WallPassInputs {
    const std::vector<Wall>& walls;
    const std::vector<std::vector<Index>>& cand;
    const std::vector<double*>& hist;
    int w;
    const double* temp;
    double dt, time_scale;
    bool inertia_free;
  };
  /// Candidate row r's history in a wall's rows (w values per candidate), or none for a law without state.
  static double* wall_state(double* columns, std::size_t r, int w) { return w > 0 ? columns + r * static_cast<std::size_t>(w) : nullptr; }
  /// Wall k's history rows (one per candidate; nullptr for a law without state).
  static double* history_rows(WallHistory& h, std::size_t k, const std::vector<Wall>& walls, const std::vector<std::vector<Index>>& cand, int w) {
    if (w == 0) return nullptr;
    if (h.width != w || !h.aligned(k, cand[k]))
      throw SetupError("wall '" + walls[k].name + "': its history does not hold one row of " + std::to_string(w) +
                       " values per candidate particle (the stage was not prepared for this contact law)");
    return h.rows[k].data();
  }

  /// One wall row's share of its wall's load.
  struct WallLoadRow {
    Vec3 force;  ///< the row's force on its particle
    double normal;
    bool touching;
  };
  /// The running sums of a wall's load over its rows in candidate order, in fixed blocks of
  /// kBlock rows: `block` over the current block, added to `total` when the next block starts and
  /// once at the end (close) - the one-thread pass's sums, row by row.
  struct WallLoadFold {
    Vec3 total = Vec3::Zero(), block = Vec3::Zero();
    double total_n = 0.0, block_n = 0.0;
    void add(std::size_t r, const WallLoadRow& row) {
      if (r > 0 && r % detail::kBlock == 0) close();
      if (!row.touching) return;
      block -= row.force;
      block_n += row.normal;
    }
    void close() {
      total += block;
      total_n += block_n;
      block.setZero();
      block_n = 0.0;
    }
  };
  /// The wall loads of each wall's closed fold (a wall without candidates: zero).
  static WallLoads wall_loads(std::vector<WallLoadFold>& fold, const std::vector<std::vector<Index>>& cand) {
    WallLoads loads;
    loads.force.assign(fold.size(), Vec3::Zero());
    loads.normal.assign(fold.size(), 0.0);
    for (std::size_t k = 0; k < fold.size(); ++k) {
      if (cand[k].empty()) continue;
      fold[k].close();
      loads.force[k] = fold[k].total;
      loads.normal[k] = fold[k].total_n;
    }
    return loads;
  }
  /// Rows [first, last) of wall k's candidates in order: each touching row is added to its
  /// particle, and every row goes to sink(r, row).
  template <class Sink>
  void wall_rows(ParticleStore& p, const WallPassInputs& in, std::size_t k, std::size_t first, std::size_t last, Sink&& sink) const {
    const std::vector<Index>& list = in.cand[k];
    for (std::size_t r = first; r < last; ++r) {
      const Index i = list[r];
      WallRow row;
      WallLoadRow o{Vec3::Zero(), 0.0, false};
      o.touching = wall_row(p, in.walls[k], i, wall_state(in.hist[k], r, in.w), in.w, in.temp, in.dt, in.time_scale, in.inertia_free, row);
      if (o.touching) {
        p.force[i] += row.force;
        p.torque[i] += row.torque;
        o.force = row.force;
        o.normal = row.normal;
      }
      sink(r, o);
    }
  }
  /// A thread's run of one wall's candidate rows: its first row and the rows' loads.
  struct WallRun {
    std::size_t first = 0;
    std::vector<WallLoadRow> rows;
  };
  /// The wall pass on a team of threads. Thread t of T takes the particles of its static share of
  /// the index range (the share the Verlet halves and the other `schedule(static)` particle loops
  /// give it, so the particles' lines stay in that core's cache) and, wall by wall, the candidate
  /// rows of those particles (a contiguous run of each ascending list): it adds each row to its
  /// particle, in wall order as the one-thread pass does, and keeps the row's load in its own
  /// buffer. The wall loads are then folded thread after thread, each continuing the previous
  /// one's running sums over its own rows (WallLoadFold: the one-thread pass's blocks and order),
  /// so a thread reads only its own rows: bit-identical to one thread.
  /// Measured on the dense bed (27,000 spheres, 5,400 wall rows, 2 threads; issue 63): tasks of
  /// 128 rows handed out dynamically with every row added after the join on the calling thread,
  /// 0.39-0.42 s of 3,000 steps against 0.32 s on one thread, and the Verlet halves 1.6x slower
  /// from the particles' lines moving between the cores; rows by particle share but loads summed
  /// by the calling thread from every row, 0.45 s (the other thread's rows cost ~50 ns a cache
  /// line); this fold, see benchmarks/README.md.
  WallLoads wall_pass_team(ParticleStore& p, const WallPassInputs& in) const {
    const std::size_t nw = in.walls.size();
    std::vector<WallLoadFold> fold(nw);
    const std::int64_t n = static_cast<std::int64_t>(p.size());
    par::region(true, [&] {
      const std::int64_t T = par::team_size(), t = par::thread_num();
      // libgomp's schedule(static) share: the first n % T threads take one particle more
      const std::int64_t q = n / T, rem = n % T;
      const Index lo = static_cast<Index>(t * q + std::min(t, rem)), hi = static_cast<Index>((t + 1) * q + std::min(t + 1, rem));
      // This thread's runs, kept (never shrunk) between steps: no reallocation once grown.
      thread_local std::vector<WallRun> mine;
      mine.resize(nw);
      for (std::size_t k = 0; k < nw; ++k) {
        const std::vector<Index>& list = in.cand[k];
        WallRun& run = mine[k];
        run.first = static_cast<std::size_t>(std::lower_bound(list.begin(), list.end(), lo) - list.begin());
        const auto last = static_cast<std::size_t>(std::lower_bound(list.begin(), list.end(), hi) - list.begin());
        run.rows.resize(last - run.first);
        wall_rows(p, in, k, run.first, last, [&](std::size_t r, const WallLoadRow& row) { run.rows[r - run.first] = row; });
      }
      for (std::int64_t s = 0; s < T; ++s) {  // the folds, thread after thread in particle order
        if (s == t)
          for (std::size_t k = 0; k < nw; ++k)
            for (std::size_t r = 0; r < mine[k].rows.size(); ++r) fold[k].add(mine[k].first + r, mine[k].rows[r]);
#pragma omp barrier
      }
    });
    return wall_loads(fold, in.cand);
  }

  /// Per-particle Gershgorin rows of the mass-weighted stiffness [1/s^2] and damping [1/s]
  /// matrices (stable_dt): block = every spring's block-norm row; axis (3 per particle) = the
  /// normal springs' exact scalar rows per translation axis; other = the tangential springs'
  /// and extra (bond) rows; beta = the damping rows (laws that report their dashpots).
  struct StiffnessRows {
    std::vector<double> block, axis, other, beta;
  };
  StiffnessRows stiffness_rows(const ParticleStore& p, const ContactTable& t, const std::vector<Wall>& walls,
                               const std::vector<double>* extra_rows) const {
    const std::size_t n = p.size();
    StiffnessRows rows;
    rows.other = extra_rows ? *extra_rows : std::vector<double>(n, 0.0);
    rows.block = rows.other;
    rows.axis.assign(3 * n, 0.0);
    bool tangential = true;
    if constexpr (requires(const Law& l) { l.tangential_free(); }) tangential = !law_.tangential_free();
    constexpr bool damped = requires(const Law& l, const ContactGeometry& g, const double* st) { l.damping(g, st); };
    if (damped) rows.beta.assign(n, 0.0);
    // One spring pair (k_n, k_t) on particle i [N/m]; cross = 1/sqrt(m_i m_j) and
    // rot = r_i r_j / sqrt(I_i I_j) for a pair, 0 for a wall; nrm the unit normal.
    auto add = [&](std::size_t i, const Vec3& nrm, double kn, double kt, double cross, double rot) {
      const double tr = 1.0 / p.mass[i] + cross;
      const double tt = tangential ? kt * (tr + p.radius[i] * p.radius[i] / p.inertia[i] + rot) : 0.0;
      const double l1 = std::abs(nrm[0]) + std::abs(nrm[1]) + std::abs(nrm[2]);
      for (int c = 0; c < 3; ++c) rows.axis[3 * i + c] += kn * tr * std::abs(nrm[c]) * l1;
      rows.other[i] += tt;
      rows.block[i] += kn * tr + tt;
    };
    for (std::size_t r = 0; r < t.size(); ++r) {
      const Index i = t.i(r), j = t.j(r);
      const double delta = p.radius[i] + p.radius[j] - (p.position[i] - p.position[j]).norm();
      bool active = delta > 0.0;
      if constexpr (is_persistent<Law>()) active = active || law_.alive(t.state(r));
      if (!active) continue;
      ContactGeometry g;
      g.overlap = delta;
      g.r_eff = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
      g.m_eff = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
      g.r_i = p.radius[i];
      g.r_j = p.radius[j];
      double kn, kt;
      if constexpr (requires { law_.normal_stiffness(g, t.state(r)); }) {
        kn = law_.normal_stiffness(g, t.state(r));  // laws whose stiffness depends on pair state
        kt = law_.tangential_stiffness(g, t.state(r));
      } else {
        kn = law_.normal_stiffness(g);
        kt = law_.tangential_stiffness(g);
      }
      const double mij = 1.0 / std::sqrt(p.mass[i] * p.mass[j]);
      const double iij = p.radius[i] * p.radius[j] / std::sqrt(p.inertia[i] * p.inertia[j]);
      const Vec3 nrm = (p.position[i] - p.position[j]).normalized();
      add(i, nrm, kn, kt, mij, iij);
      add(j, nrm, kn, kt, mij, iij);
      if constexpr (damped) {
        const auto [cn, ct] = law_.damping(g, t.state(r));
        rows.beta[i] += cn * (1.0 / p.mass[i] + mij) + ct * (1.0 / p.mass[i] + p.radius[i] * p.radius[i] / p.inertia[i] + mij + iij);
        rows.beta[j] += cn * (1.0 / p.mass[j] + mij) + ct * (1.0 / p.mass[j] + p.radius[j] * p.radius[j] / p.inertia[j] + mij + iij);
      }
    }
    for (std::size_t i = 0; i < n; ++i)
      for (const Wall& w : walls) {
        Vec3 nrm;
        double dist;
        w.distance(p.position[i], nrm, dist);
        if (p.radius[i] - dist <= 0.0) continue;
        ContactGeometry g;
        g.overlap = p.radius[i] - dist;
        g.r_eff = p.radius[i];
        g.m_eff = p.mass[i];
        g.wall = true;
        g.r_i = p.radius[i];
        g.r_j = std::numeric_limits<double>::infinity();
        add(i, nrm, law_.normal_stiffness(g), law_.tangential_stiffness(g), 0.0, 0.0);
      }
    return rows;
  }
  /// What every row of one pass reads besides the particles: the temperature field (thermal
  /// laws), the grain-boundary fractions (laws that ask for them) and the stage's time scale.
  struct PassInputs {
    const double* temp = nullptr;
    std::vector<double> gbf;
    double time_scale = 1.0;
    int width = 0;
    bool inertia_free = false;  ///< m* = 0 (ContactModel::pair_pass)
  };
  PassInputs pass_inputs(const ParticleStore& p, const ContactTable& t, double time_scale) const {
    PassInputs in;
    in.time_scale = time_scale;
    in.width = t.state_width();
    if constexpr (is_thermal<Law>())
      if (p.fields.has("temperature")) in.temp = p.fields.data("temperature").data();
    if constexpr (requires(const Law& l) { l.grain_boundary_fraction_column(); })
      if (law_.grain_boundary_fraction_column() >= 0) in.gbf = grain_boundary_fractions(p, t, law_.grain_boundary_fraction_column());
    if constexpr (requires(const Law& l) { l.grain_boundary_fraction_field(); })
      if (const std::string f = law_.grain_boundary_fraction_field(); !f.empty()) {
        if (!p.fields.has(f))
          throw SetupError("contact law " + std::string(Law::kName) + ": its creep stop reads the particle field '" + f +
                           "', which no module of the stage writes (add the module that does)");
        in.gbf = p.fields.data(f);
      }
    return in;
  }

  /// The geometry of the pair (i, j) with unit normal n (j -> i) and overlap delta.
  [[gnu::always_inline]] ContactGeometry pair_geometry(const ParticleStore& p, Index i, Index j, const Vec3& n, double delta,
                                                       const PassInputs& in) const {
    ContactGeometry g;
    g.n = n;
    g.overlap = delta;
    g.r_eff = p.radius[i] * p.radius[j] / (p.radius[i] + p.radius[j]);
    g.m_eff = p.mass[i] * p.mass[j] / (p.mass[i] + p.mass[j]);
    g.arm_i = p.radius[i] - 0.5 * delta;
    g.arm_j = p.radius[j] - 0.5 * delta;
    g.r_i = p.radius[i];
    g.r_j = p.radius[j];
    if constexpr (is_thermal<Law>()) {
      g.temperature = in.temp ? 0.5 * (in.temp[i] + in.temp[j]) : std::numeric_limits<double>::quiet_NaN();
      g.time_scale = in.time_scale;
    }
    if (!in.gbf.empty()) g.gb_fraction = std::max(in.gbf[i], in.gbf[j]);
    if (in.inertia_free) g.m_eff = 0.0;
    return g;
  }
  /// The geometry of particle i against a wall: inward normal nrm, centre-to-wall distance dist.
  ContactGeometry wall_geometry(const ParticleStore& p, Index i, const Vec3& nrm, double dist, const double* temp, double time_scale) const {
    ContactGeometry g;
    g.n = nrm;
    g.overlap = p.radius[i] - dist;
    g.r_eff = p.radius[i];
    g.m_eff = p.mass[i];
    g.arm_i = dist;
    g.arm_j = 0.0;
    g.wall = true;
    g.r_i = p.radius[i];
    g.r_j = std::numeric_limits<double>::infinity();
    if constexpr (is_thermal<Law>()) {
      g.temperature = temp ? temp[i] : std::numeric_limits<double>::quiet_NaN();
      g.time_scale = time_scale;
    } else {
      (void)temp, (void)time_scale;
    }
    return g;
  }

  /// Rows per task of pair_pass's parallel loop (a multiple of every lane width).
  static constexpr std::int64_t kPassChunk = 256;
  /// The state columns of the law's lane path: Law::kLaneState, or 3 (a contact law's tangential history).
  static constexpr int lane_state() {
    if constexpr (requires { Law::kLaneState; })
      return Law::kLaneState;
    else
      return 3;
  }
  /// True when the law evaluates blocks of rows over SIMD lanes (Law::lanes, engine/contact/lanes.hpp).
  static constexpr bool kLanes = requires(const Law& l, PairLanes<8, lane_state()>& b) { l.template lanes<8>(b, 0.0); };
  /// True when the law's parameters allow its lane path (Law::lanes_enabled(); a law without it: always).
  bool law_lanes_enabled() const {
    if constexpr (requires(const Law& l) { l.lanes_enabled(); })
      return law_.lanes_enabled();
    else
      return true;
  }
  /// True when row_range runs table t's rows over SIMD lanes.
  bool lanes_run(const ContactTable& t) const {
    return kLanes && t.state_width() == lane_state() && lane_isa() != LaneIsa::scalar && law_lanes_enabled();
  }

  /// The law on rows [lo, hi) in row order: each row's overlap, force, state written as row_forces
  /// does, then sink.dead(r) for a row out of contact or sink.live(r, i, j, F, T_i, T_j) for a live
  /// one. Over SIMD lanes when the law has them and lane_isa() allows (the same bits either way).
  template <class Sink>
  void row_range(const ParticleStore& p, ContactTable& t, std::int64_t lo, std::int64_t hi, double dt, const PassInputs& in,
                 Sink& sink) const {
    if constexpr (kLanes) {
      if (lanes_run(t)) switch (lane_isa()) {
        case LaneIsa::avx512: return rows_avx512(p, t, lo, hi, dt, in, sink);
        case LaneIsa::avx2: return rows_avx2(p, t, lo, hi, dt, in, sink);
        case LaneIsa::scalar: break;
      }
    }
    auto& F = t.force();
    Vec3 tri, trj;
    for (std::int64_t r = lo; r < hi; ++r) {
      if (!row_forces(p, t, r, dt, in, F[r], tri, trj))
        sink.dead(r);
      else
        sink.live(r, t.i(r), t.j(r), F[r], tri, trj);
    }
  }
  // One instantiation per instruction set, chosen at run time (row_range): the build stays on the
  // x86-64 baseline and each function's loops are vectorised for its own target.
  template <class Sink>
  [[SPARKDEM_TARGET_AVX512]] void rows_avx512(const ParticleStore& p, ContactTable& t, std::int64_t lo, std::int64_t hi, double dt,
                                              const PassInputs& in, Sink& sink) const {
    lane_rows<8>(p, t, lo, hi, dt, in, sink);
  }
  template <class Sink>
  [[SPARKDEM_TARGET_AVX2]] void rows_avx2(const ParticleStore& p, ContactTable& t, std::int64_t lo, std::int64_t hi, double dt,
                                         const PassInputs& in, Sink& sink) const {
    lane_rows<4>(p, t, lo, hi, dt, in, sink);
  }

  /// Rows [lo, hi) over W lanes, in spans of kSpan rows. First every row of a span: its overlap
  /// (overlap_lanes) and whether it is live as in row_forces - touching (or, for a persistent law,
  /// kept alive by its state before the step) at a distance above zero - written to a live and a
  /// dead list without a branch per row (in a bed with a Verlet skin, live and dead rows
  /// interleave at random: the branch was the pass's hottest instruction); a dead row has its
  /// state and force cleared and goes to sink.dead. Then the span's live rows, packed, in blocks
  /// of W lanes: gather their inputs, the geometry, the law and the torques over the lanes, write
  /// back and call sink.live in row order. Packing keeps rows of the Verlet skin out of the lanes
  /// (a row runs the whole law in its lane, masked or not); every lane computes only its own row,
  /// so the bits are those of row_forces whatever the packing.
  template <int W, class Sink>
  [[gnu::always_inline]] void lane_rows(const ParticleStore& p, ContactTable& t, std::int64_t lo, std::int64_t hi, double dt,
                                        const PassInputs& in, Sink& sink) const {
    constexpr int S = lane_state();
    PairLanes<W, S> b;
    b.time_scale = in.time_scale;
    alignas(64) double dist[kSpan];
    alignas(64) std::int64_t rows[kSpan], dead[kSpan];
    Vec3* force = t.force().data();
    for (std::int64_t s0 = lo; s0 < hi; s0 += kSpan) {
      const int span = static_cast<int>(std::min<std::int64_t>(kSpan, hi - s0));
      overlap_lanes(p, t, s0, span, dist);
      const double* overlap = t.overlap().data() + s0;
      int live_rows = 0, dead_rows = 0;
      for (int k = 0; k < span; ++k) {  // without a branch per row: live and dead rows interleave at random
        const std::int64_t r = s0 + k;
        bool live = overlap[k] > 0.0;
        if constexpr (is_persistent<Law>()) live = live | law_.alive(t.state(r));
        live = live & !(dist[k] <= 0.0);
        rows[live_rows] = r;
        dead[dead_rows] = r;
        live_rows += live;
        dead_rows += !live;
      }
      for (int k = 0; k < dead_rows; ++k) {
        const std::int64_t r = dead[k];
        double* st = t.state(r);
        for (int c = 0; c < S; ++c) st[c] = 0.0;
        force[r].setZero();
        sink.dead(r);
      }
      for (int k0 = 0; k0 < live_rows; k0 += W) {
        const int n = std::min(W, live_rows - k0);
        gather_lanes(p, t, rows + k0, n, in, b);
        pair_geometry_lanes(b, in.inertia_free);
        law_.template lanes<W>(b, dt);
        pair_torque_lanes(b);
        for (int l = 0; l < n; ++l) {
          const std::int64_t r = rows[k0 + l];
          double* st = t.state(r);
          for (int c = 0; c < S; ++c) st[c] = b.s[c][l];
          force[r] = Vec3(b.fx[l], b.fy[l], b.fz[l]);
          sink.live(r, t.i(r), t.j(r), force[r], Vec3(b.tix[l], b.tiy[l], b.tiz[l]), Vec3(b.tjx[l], b.tjy[l], b.tjz[l]));
        }
      }
    }
  }
  /// Rows a span of lane_rows packs at most.
  static constexpr int kSpan = 256;
  /// Centre distance and overlap of rows s0 .. s0 + n - 1, as pair_geometry_lanes computes them
  /// (dist = |x_i - x_j|, delta = (r_i + r_j) - dist): the overlaps into the table, the distances into dist.
  [[gnu::always_inline]] static void overlap_lanes(const ParticleStore& p, ContactTable& t, std::int64_t s0, int n, double* dist) {
    const Index* ii = t.i_list().data() + s0;
    const Index* jj = t.j_list().data() + s0;
    const double* x = p.position.data()->data();
    const double* rad = p.radius.data();
    double* overlap = t.overlap().data() + s0;
#pragma omp simd
    for (int k = 0; k < n; ++k) {
      const std::int64_t i = ii[k], j = jj[k];
      const double dx = x[3 * i] - x[3 * j], dy = x[3 * i + 1] - x[3 * j + 1], dz = x[3 * i + 2] - x[3 * j + 2];
      const double d = std::sqrt((dx * dx + dy * dy) + dz * dz);
      dist[k] = d;
      overlap[k] = (rad[i] + rad[j]) - d;
    }
  }
  /// The inputs of rows rows[0 .. n - 1] into lanes 0 .. n - 1 (lanes n .. W - 1 repeat the last row), as
  /// loops over the lanes that the vectoriser turns into gathers; a thermal law's temperature and
  /// grain-boundary fraction as pair_geometry forms them.
  template <int W, int S>
  [[gnu::always_inline]] static void gather_lanes(const ParticleStore& p, const ContactTable& t, const std::int64_t* rows, int n,
                                                  const PassInputs& in, PairLanes<W, S>& b) {
    static_assert(sizeof(Vec3) == 3 * sizeof(double), "the particles' vectors are read as arrays of doubles");
    alignas(64) std::int64_t I[W], J[W], SI[W];
    const Index* ii = t.i_list().data();
    const Index* jj = t.j_list().data();
    for (int l = 0; l < W; ++l) {
      const std::int64_t r = rows[std::min(l, n - 1)];
      I[l] = ii[r];
      J[l] = jj[r];
      SI[l] = S * r;
    }
    const double* x = p.position.data()->data();
    const double* v = p.velocity.data()->data();
    const double* w = p.omega.data()->data();
    const double* rad = p.radius.data();
    const double* m = p.mass.data();
    const double* st = t.state(0);
#pragma omp simd
    for (int l = 0; l < W; ++l) {
      const std::int64_t i = 3 * I[l], j = 3 * J[l];
      b.dx[l] = x[i] - x[j];
      b.dy[l] = x[i + 1] - x[j + 1];
      b.dz[l] = x[i + 2] - x[j + 2];
      b.dvx[l] = v[i] - v[j];
      b.dvy[l] = v[i + 1] - v[j + 1];
      b.dvz[l] = v[i + 2] - v[j + 2];
      b.wix[l] = w[i];
      b.wiy[l] = w[i + 1];
      b.wiz[l] = w[i + 2];
      b.wjx[l] = w[j];
      b.wjy[l] = w[j + 1];
      b.wjz[l] = w[j + 2];
      b.ri[l] = rad[I[l]];
      b.rj[l] = rad[J[l]];
      b.mi[l] = m[I[l]];
      b.mj[l] = m[J[l]];
      for (int c = 0; c < S; ++c) b.s[c][l] = st[SI[l] + c];
    }
    if constexpr (is_thermal<Law>()) {
      const double* temp = in.temp;
      const double* gbf = in.gbf.empty() ? nullptr : in.gbf.data();
      for (int l = 0; l < W; ++l) {
        b.temp[l] = temp ? 0.5 * (temp[I[l]] + temp[J[l]]) : std::numeric_limits<double>::quiet_NaN();
        b.gbf[l] = gbf ? std::max(gbf[I[l]], gbf[J[l]]) : 0.0;
      }
    } else {
      (void)in;
    }
  }

  /// The law on row r: writes its overlap, and, for a live pair, the force on i and the torques
  /// on i and j and returns true; a pair out of contact (and not kept alive by its law) has its
  /// state cleared and returns false.
  [[gnu::always_inline]] bool row_forces(const ParticleStore& p, ContactTable& t, std::int64_t r, double dt, const PassInputs& in, Vec3& F,
                                         Vec3& Ti, Vec3& Tj) const {
    const Index i = t.i(r), j = t.j(r);
    const Vec3 d = p.position[i] - p.position[j];
    const double dist = d.norm();
    const double delta = p.radius[i] + p.radius[j] - dist;
    t.overlap()[r] = delta;
    double* state = in.width > 0 ? t.state(r) : nullptr;
    bool active = delta > 0.0;
    if constexpr (is_persistent<Law>()) active = active || law_.alive(state);
    if (!active || dist <= 0.0) {
      for (int k = 0; k < in.width; ++k) state[k] = 0.0;
      F.setZero();  // the row forces are part of the state file and the frame output
      return false;
    }
    const ContactGeometry g = pair_geometry(p, i, j, d / dist, delta, in);
    const RelativeMotion m = relative_motion(g, p.velocity[i], p.velocity[j], p.omega[i], p.omega[j]);
    const ContactForces f = law_(g, m, dt, state);
    F = f.force;
    const Vec3 nxt = g.n.cross(f.tangential);
    Ti = -g.arm_i * nxt;
    Tj = -g.arm_j * nxt;
    return true;
  }

  Law law_;
};

}  // namespace sparkdem
