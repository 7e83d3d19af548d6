// Contact history: per-contact state is keyed by global ids, so it survives neighbour rebuilds
// with a different pair set and particle permutations; end to end, a frictional scene gives the
// same trajectory whether the list is rebuilt (and the particles re-sorted) every step or never.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <vector>

#include "engine/simulation.hpp"
#include "physics/body/gravity.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "tests/support/scene.hpp"

namespace test_history {

using namespace sparkdem;
using namespace sparkdem::physics;

namespace {

/// Recognisable state of the contact between ids a < b.
std::array<double, 2> tag(Id a, Id b) { return {100.0 * a + b, -1.0 * (a + 1) * (b + 1)}; }

/// Local index of each id.
std::vector<Index> locals(const ParticleStore& p) {
  std::vector<Index> l(p.size());
  for (std::size_t k = 0; k < p.size(); ++k) l[p.id[k]] = static_cast<Index>(k);
  return l;
}

}  // namespace

TEST_CASE("ContactTable::rebuild carries state by global id", "[history]") {
  ParticleStore p;
  for (int k = 0; k < 5; ++k) p.add(Vec3(k, 0, 0), 0.6, 1.0);
  ContactTable t;
  t.set_state_columns({"a", "b"});
  // Pairs given in either order: rows are keyed with id_i < id_j.
  t.rebuild({{{0, 1}}, {{2, 1}}, {{3, 4}}, {{4, 2}}}, p.id, p.size());
  REQUIRE(t.size() == 4);
  for (std::size_t r = 0; r < t.size(); ++r) {
    CHECK(t.id_i()[r] < t.id_j()[r]);
    const auto v = tag(t.id_i()[r], t.id_j()[r]);
    t.state(r)[0] = v[0];
    t.state(r)[1] = v[1];
  }
  // New pair set: (1,2) and (3,4) survive (given reversed / in another position), (0,1) and
  // (2,4) disappear, (0,3) and (1,4) are new.
  t.rebuild({{{0, 3}}, {{4, 3}}, {{1, 4}}, {{2, 1}}}, p.id, p.size());
  REQUIRE(t.size() == 4);
  std::map<std::pair<Id, Id>, std::array<double, 2>> got;
  for (std::size_t r = 0; r < t.size(); ++r) got[{t.id_i()[r], t.id_j()[r]}] = {t.state(r)[0], t.state(r)[1]};
  // Exact copies (the state is moved, not recomputed); new contacts start from zero.
  CHECK(got.at({1, 2}) == tag(1, 2));
  CHECK(got.at({3, 4}) == tag(3, 4));
  CHECK(got.at({0, 3}) == std::array<double, 2>{0.0, 0.0});
  CHECK(got.at({1, 4}) == std::array<double, 2>{0.0, 0.0});
  // A contact that disappears and comes back starts afresh.
  t.rebuild({{{0, 1}}}, p.id, p.size());
  CHECK(t.state(0)[0] == 0.0);
  CHECK(t.state(0)[1] == 0.0);
}

TEST_CASE("ContactTable::rebuild carries every row of a large table, whatever the ids", "[history]") {
  // 3000 particles with ids spread up to 2^32 (pair keys are unique below it), all multiples of
  // 4096 (keys alike in their low bits), 12,000 pairs: the rebuild's look-up table probes past
  // collisions and wraps around.
  const std::size_t n = 3000;
  std::vector<Id> ids(n);
  for (std::size_t k = 0; k < n; ++k) ids[k] = static_cast<Id>(k) * 4096 * 349;
  std::vector<std::array<Index, 2>> pairs;
  for (std::size_t k = 0; k < 12000; ++k)
    pairs.push_back({static_cast<Index>((7 * k) % n), static_cast<Index>((7 * k + 1 + k % 17) % n)});
  ContactTable t;
  t.set_state_columns({"a", "b"});
  t.rebuild(pairs, ids, n);
  REQUIRE(t.size() == pairs.size());
  const auto mark = [](Id a, Id b) { return std::array<double, 2>{static_cast<double>(a % 100003) + 1.0, static_cast<double>(b % 65521) + 1.0}; };
  for (std::size_t r = 0; r < t.size(); ++r) {
    const auto v = mark(t.id_i()[r], t.id_j()[r]);
    std::copy(v.begin(), v.end(), t.state(r));
  }
  // The next pair set: every other old pair, reversed and in reverse order, plus 2000 new ones.
  std::vector<std::array<Index, 2>> next;
  for (std::size_t k = pairs.size(); k-- > 0;)
    if (k % 2 == 0) next.push_back({pairs[k][1], pairs[k][0]});
  const std::size_t carried = next.size();
  for (std::size_t k = 0; k < 2000; ++k) next.push_back({static_cast<Index>(k), static_cast<Index>(k + 2500 <= n - 1 ? k + 2500 : k + 1)});
  std::map<std::uint64_t, std::size_t> old_rows;
  for (std::size_t k = 0; k < pairs.size(); ++k) old_rows.emplace(pair_key(ids[pairs[k][0]], ids[pairs[k][1]]), k);
  t.rebuild(next, ids, n);
  REQUIRE(t.size() == next.size());
  std::size_t kept = 0;
  for (std::size_t r = 0; r < t.size(); ++r) {
    const bool was = old_rows.count(t.key(r)) != 0;
    const auto want = was ? mark(t.id_i()[r], t.id_j()[r]) : std::array<double, 2>{0.0, 0.0};
    CHECK(t.state(r)[0] == want[0]);
    CHECK(t.state(r)[1] == want[1]);
    kept += was;
  }
  CHECK(kept >= carried);
}

TEST_CASE("Contact state and particle fields follow a permutation", "[history]") {
  ParticleStore p;
  for (int k = 0; k < 6; ++k) p.add(Vec3(k, 0.1 * k, 0), 0.6, 1.0 + k);
  p.fields.declare({"heat", 2, "J", 0.0, true}, p.size());
  for (std::size_t k = 0; k < p.size(); ++k) {
    p.fields.data("heat")[2 * k] = 10.0 * p.id[k];
    p.fields.data("heat")[2 * k + 1] = -1.0 * p.id[k];
  }
  ContactTable t;
  t.set_state_columns({"a", "b"});
  t.rebuild({{{0, 1}}, {{1, 2}}, {{3, 5}}, {{4, 0}}}, p.id, p.size());
  for (std::size_t r = 0; r < t.size(); ++r) {
    const auto v = tag(t.id_i()[r], t.id_j()[r]);
    t.state(r)[0] = v[0];
    t.state(r)[1] = v[1];
    t.force()[r] = Vec3(1.0 + r, 2.0 * r, -3.0);  // per-row force on i
  }
  std::vector<Vec3> f_before(p.size(), Vec3::Zero()), q_before(p.size(), Vec3::Zero());
  t.gather(f_before, q_before);
  std::map<Id, Vec3> by_id;
  for (std::size_t k = 0; k < p.size(); ++k) by_id[p.id[k]] = f_before[k];

  const std::vector<Index> perm{4, 2, 5, 0, 3, 1};  // new[k] = old[perm[k]]
  p.permute(perm);
  t.remap_after_permutation(p.id);
  for (std::size_t k = 0; k < p.size(); ++k) {
    CHECK(p.id[k] == static_cast<Id>(perm[k]));
    CHECK(p.mass[k] == 1.0 + perm[k]);                      // core arrays follow
    CHECK(p.fields.data("heat")[2 * k] == 10.0 * p.id[k]);  // declared fields follow (exact)
    CHECK(p.fields.data("heat")[2 * k + 1] == -1.0 * p.id[k]);
  }
  // Rows still refer to the same particles, with unchanged state.
  for (std::size_t r = 0; r < t.size(); ++r) {
    CHECK(p.id[t.i(r)] == t.id_i()[r]);
    CHECK(p.id[t.j(r)] == t.id_j()[r]);
    CHECK(t.state(r)[0] == tag(t.id_i()[r], t.id_j()[r])[0]);
  }
  // The gather (rebuilt incidence) gives every particle the same force as before (exact: the
  // same rows are summed in the same order).
  std::vector<Vec3> f_after(p.size(), Vec3::Zero()), q_after(p.size(), Vec3::Zero());
  t.gather(f_after, q_after);
  for (std::size_t k = 0; k < p.size(); ++k) CHECK(f_after[k] == by_id.at(p.id[k]));
  // A rebuild with the same pairs expressed in the new local indices keeps every state.
  const auto l = locals(p);
  t.rebuild({{{l[1], l[0]}}, {{l[2], l[1]}}, {{l[5], l[3]}}, {{l[0], l[4]}}}, p.id, p.size());
  for (std::size_t r = 0; r < t.size(); ++r) {
    CHECK(t.state(r)[0] == tag(t.id_i()[r], t.id_j()[r])[0]);
    CHECK(t.state(r)[1] == tag(t.id_i()[r], t.id_j()[r])[1]);
  }
}

namespace {

/// Constant horizontal pull on the particle with global id `target` (shears its contacts).
class Pull final : public Module {
 public:
  Pull(Id target, Vec3 f) : target_(target), f_(std::move(f)) {}
  std::string name() const override { return "pull"; }
  void declare(Declarations& d) const override { d.writes = {"force"}; }
  void advance(State& s, const StepInfo&) override {
    const Index i = test::local_index(s.particles, target_);
    s.particles.force[i] += f_;
  }

 private:
  Id target_;
  Vec3 f_;
};

/// Control: forgets all tangential history after every force pass (what a rebuild that failed
/// to carry the state over would do).
class Amnesia final : public Module {
 public:
  std::string name() const override { return "amnesia"; }
  void advance(State& s, const StepInfo&) override {
    std::fill(s.contacts.state_data().begin(), s.contacts.state_data().end(), 0.0);
    for (auto& w : s.wall_history.rows) std::fill(w.begin(), w.end(), 0.0);
  }
};

struct Sample {
  std::vector<Vec3> x, v, w;  // by global id
};

/// Three spheres pressed together by gravity on a floor and sheared by a sideways pull on the
/// top one: a frictional, sticking-and-slipping scene with tangential history on two pair
/// contacts and two wall contacts. Particles are added top first so that the spatial sort
/// really permutes them. Returns per-step samples by id.
std::vector<Sample> sheared_stack(double skin, Step sort_every, State& s, double& max_shear, bool forget = false) {
  const double r = 1e-3, rho = 2500.0, d0 = 2.0 * r - 1e-6;  // pair overlaps of 1 um
  const Vec3 x1(0.0, 0.0, r - 1e-6);                         // on the floor, 1 um overlap
  const Vec3 top_offset(0.3e-3, 0.1e-3, 0.0);
  const Vec3 x0 = x1 + top_offset + Vec3(0, 0, std::sqrt(d0 * d0 - top_offset.squaredNorm()));
  test::add_sphere(s, x0, r, rho);                        // id 0: on top of 1, off-centre
  test::add_sphere(s, x1, r, rho);                        // id 1
  test::add_sphere(s, x1 + Vec3(-d0, 0.0, 0.0), r, rho);  // id 2: on the floor, left of 1
  s.particles.velocity[2] = Vec3(0.01, 0.02, 0.0);        // pushes into 1 and slides along y
  s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
  const ContactModelT<HertzMindlin> law({1e7, 0.3, 0.5, 0.4});
  Gravity gravity({Vec3(0, 0, -9.81)});
  Pull pull(0, Vec3(3e-5, 1.5e-5, 0.0));  // ~0.3 m g sideways on the top sphere
  Simulation sim(s, law);
  sim.add_module(&gravity);
  sim.add_module(&pull);
  Amnesia amnesia;
  if (forget) sim.add_module(&amnesia);
  std::vector<Sample> out;
  max_shear = 0.0;
  test::StepObserver obs([&](const State& st, Step) {
    const auto& p = st.particles;
    Sample smp;
    smp.x.resize(p.size());
    smp.v.resize(p.size());
    smp.w.resize(p.size());
    for (std::size_t k = 0; k < p.size(); ++k) {
      smp.x[p.id[k]] = p.position[k];
      smp.v[p.id[k]] = p.velocity[k];
      smp.w[p.id[k]] = p.omega[k];
    }
    out.push_back(std::move(smp));
    auto& c = s.contacts;  // the same State, non-const access for state()
    for (std::size_t q = 0; q < c.size(); ++q) max_shear = std::max(max_shear, Vec3(c.state(q)[0], c.state(q)[1], c.state(q)[2]).norm());
  });
  StageConfig cfg = test::stage(2e-6, 4000, skin);
  cfg.sort_every_rebuilds = sort_every;
  sim.run_stage(cfg, obs);
  return out;
}

}  // namespace

TEST_CASE("Tangential history survives rebuilds and spatial sorts (end to end)", "[history]") {
  State a, b;
  double shear_a = 0.0, shear_b = 0.0;
  // a: skin of 2 radii, the list is built once and never re-sorted.
  const auto ra = sheared_stack(2e-3, 0, a, shear_a);
  // b: skin 1e-15 m, rebuild on every step, spatial sort on every rebuild.
  const auto rb = sheared_stack(1e-15, 1, b, shear_b);
  REQUIRE(ra.size() == rb.size());
  CHECK(a.rebuilds == 1);
  CHECK(b.rebuilds >= 3900);                          // (nearly) every one of the 4000 steps rebuilt the list
  CHECK(b.particles.id != std::vector<Id>{0, 1, 2});  // the sort did permute the particles
  CHECK(shear_a > 1e-9);                              // the tangential springs were loaded (the test is not empty)
  CHECK(shear_b == Approx(shear_a).epsilon(1e-12));
  // The trajectories agree to 1e-12 relative (scale: the largest value of each quantity).
  double xs = 0.0, vs = 0.0, ws = 0.0, dx = 0.0, dv = 0.0, dw = 0.0;
  for (std::size_t k = 0; k < ra.size(); ++k)
    for (std::size_t q = 0; q < 3; ++q) {
      xs = std::max(xs, ra[k].x[q].norm());
      vs = std::max(vs, ra[k].v[q].norm());
      ws = std::max(ws, ra[k].w[q].norm());
      dx = std::max(dx, (ra[k].x[q] - rb[k].x[q]).norm());
      dv = std::max(dv, (ra[k].v[q] - rb[k].v[q]).norm());
      dw = std::max(dw, (ra[k].w[q] - rb[k].w[q]).norm());
    }
  REQUIRE(vs > 0.0);
  REQUIRE(ws > 0.0);
  WARN("history: max rel. deviation x " << dx / xs << ", v " << dv / vs << ", omega " << dw / ws << "; rebuilds " << b.rebuilds
                                        << "; max |xi| " << shear_a << " m");
  CHECK(dx <= 1e-12 * xs);
  CHECK(dv <= 1e-12 * vs);
  CHECK(dw <= 1e-12 * ws);
  // Control: the comparison is sensitive to lost history. Forgetting it every step changes the
  // velocities by far more than the 1e-12 bound (here by more than 1e-3 of their scale).
  State c;
  double shear_c = 0.0;
  const auto rc = sheared_stack(2e-3, 0, c, shear_c, true);
  double dv_lost = 0.0;
  for (std::size_t k = 0; k < ra.size(); ++k)
    for (std::size_t q = 0; q < 3; ++q) dv_lost = std::max(dv_lost, (ra[k].v[q] - rc[k].v[q]).norm());
  WARN("history: without history the velocities deviate by " << dv_lost / vs << " of their scale");
  CHECK(dv_lost > 1e-3 * vs);
  // The wall history (a row per floor candidate, with its particle's id) followed the particles
  // too: same value per id, zero for a particle that is no candidate.
  REQUIRE(a.walls.size() == 1);
  const auto wall_row = [](const State& s, Id id, int c) {
    const auto& ids = s.wall_history.ids.at(0);
    const auto it = std::find(ids.begin(), ids.end(), id);
    return it == ids.end() ? 0.0 : s.wall_history.rows.at(0)[3 * static_cast<std::size_t>(it - ids.begin()) + c];
  };
  double wall_hist = 0.0;
  for (Id id = 0; id < 3; ++id)
    for (int c = 0; c < 3; ++c) {
      const double ha = wall_row(a, id, c), hb = wall_row(b, id, c);
      wall_hist = std::max(wall_hist, std::abs(ha));
      CHECK(hb == Approx(ha).margin(1e-12 * std::max(1e-9, std::abs(ha))));
    }
  CHECK(wall_hist > 1e-10);
}

}  // namespace test_history

namespace test_history {

TEST_CASE("PairRows::row_split cuts at equal expected work and marks the particles of two ranges", "[history]") {
  // A chain of 1,001 particles, rows (k, k + 1). Rows in contact (the caller's `heavy`) cost
  // kHeavyRowCost, the others 1; the two ranges' costs must differ by at most one row's cost, and
  // the one particle whose two rows straddle the cut is the only boundary particle.
  ParticleStore p;
  const int n = 1001;
  for (int k = 0; k < n; ++k) p.add(Vec3(k, 0, 0), 0.6, 1.0);
  std::vector<std::array<Index, 2>> pairs;
  for (int k = 0; k + 1 < n; ++k) pairs.push_back({k, k + 1});
  ContactTable t;
  t.rebuild(pairs, p.id, p.size());
  const std::int64_t rows = static_cast<std::int64_t>(t.size());
  REQUIRE(rows == n - 1);
  const auto cut_of = [&](const PairRows::RowSplit& s) {
    REQUIRE(s.row_begin.size() == 3);
    CHECK(s.row_begin[0] == 0);
    CHECK(s.row_begin[2] == rows);
    return s.row_begin[1];
  };
  SECTION("without costs: equal row counts") { CHECK(cut_of(t.row_split(2)) == rows / 2); }
  SECTION("the first quarter in contact") {
    const auto heavy = [&](std::int64_t r) { return r < rows / 4; };
    const PairRows::RowSplit& s = t.row_split(2, heavy);
    const std::int64_t c = cut_of(s);
    double a = 0.0, b = 0.0;
    for (std::int64_t r = 0; r < rows; ++r) (r < c ? a : b) += heavy(r) ? PairRows::kHeavyRowCost : 1.0;
    CHECK(std::abs(a - b) <= PairRows::kHeavyRowCost);
    CHECK(c < rows / 4);  // the heavy quarter alone is more than half the work
    // Particle c is row c - 1's j and row c's i: the only one touched by both ranges.
    REQUIRE(s.boundary.size() == 1);
    CHECK(s.boundary[0] == c);
    for (int k = 0; k < n; ++k)
      if (k != c) CHECK(s.owner[k] == (k < c ? 0 : 1));
  }
}

}  // namespace test_history

namespace test_history {

TEST_CASE("WallHistory::follow keeps each candidate's row by particle id", "[history]") {
  WallHistory h;
  h.reset(2, 2);
  const std::vector<Id> id0{10, 11, 12, 13};
  h.follow({{0, 2}, {1}}, id0);  // fresh: zero rows, one per candidate
  REQUIRE(h.aligned(0, {0, 2}));
  CHECK(h.rows[0] == std::vector<double>{0, 0, 0, 0});
  h.rows[0] = {1, 2, 3, 4};  // ids 10, 12
  h.rows[1] = {5, 6};        // id 11
  // The particles permuted (ids 12, 13, 10, 11 at rows 0-3); wall 0's candidates now ids 12, 13
  // and 10 (13 new), id 11 leaves wall 1 for wall 0 and id 13 joins wall 1.
  const std::vector<Id> id1{12, 13, 10, 11};
  h.follow({{0, 1, 2, 3}, {1}}, id1);
  CHECK(h.ids[0] == std::vector<Id>{12, 13, 10, 11});
  CHECK(h.rows[0] == std::vector<double>{3, 4, 0, 0, 1, 2, 0, 0});
  CHECK(h.ids[1] == std::vector<Id>{13});
  CHECK(h.rows[1] == std::vector<double>{0, 0});
}

/// One sphere pulled sideways on a floor (sticking, then slipping: wall history in use), `steps`
/// steps from `s` (built when empty).
void sliding_sphere(State& s, Step steps) {
  if (s.particles.size() == 0) {
    test::add_sphere(s, Vec3(0.0, 0.0, 1e-3 - 1e-6), 1e-3, 2500.0);
    s.walls.push_back(test::plane_wall("floor", Vec3::Zero(), Vec3::UnitZ()));
  }
  const ContactModelT<HertzMindlin> law({1e7, 0.3, 0.5, 0.4});
  Gravity gravity({Vec3(0, 0, -9.81)});
  Pull pull(0, Vec3(2e-5, 1e-5, 0.0));
  Simulation sim(s, law);
  sim.add_module(&gravity);
  sim.add_module(&pull);
  test::StepObserver obs([](const State&, Step) {});
  sim.run_stage(test::stage(2e-6, steps, 2e-4), obs);
}

TEST_CASE("Wall history kept as per-particle fields (checkpoints before its rows) is taken over", "[history]") {
  State a;
  sliding_sphere(a, 300);
  REQUIRE(a.wall_history.width == 3);
  REQUIRE(a.wall_history.ids.at(0) == std::vector<Id>{0});
  REQUIRE(Vec3(a.wall_history.rows[0][0], a.wall_history.rows[0][1], a.wall_history.rows[0][2]).norm() > 0.0);
  // The same state as an older checkpoint held it: a field of 3 values per particle, no rows.
  State b = a;
  b.particles.fields.declare({"wall_state/floor", 3, "m", 0.0, false}, b.particles.size());
  std::copy_n(a.wall_history.rows[0].begin(), 3, b.particles.fields.data("wall_state/floor").begin());
  b.wall_history = WallHistory{};
  sliding_sphere(a, 300);
  sliding_sphere(b, 300);
  CHECK_FALSE(b.particles.fields.has("wall_state/floor"));
  CHECK(b.wall_history.rows == a.wall_history.rows);  // bit for bit
  CHECK(b.particles.position[0] == a.particles.position[0]);
  CHECK(b.particles.velocity[0] == a.particles.velocity[0]);
  // Control: without the taken-over history the sphere moves otherwise.
  State c = a;
  c.wall_history = WallHistory{};
  sliding_sphere(c, 300);
  sliding_sphere(a, 300);
  CHECK(c.particles.velocity[0] != a.particles.velocity[0]);
}

}  // namespace test_history
