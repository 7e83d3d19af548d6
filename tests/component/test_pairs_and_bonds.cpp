// Persistent pairs and bonds (issue 3, contract 1), with mock laws that count their calls.
//
// Invariants under test:
//  * a pair whose law keeps it alive (a neck) stays in the contact table and keeps being
//    evaluated at negative overlap, beyond the neighbour cut-off; a non-persistent law drops it;
//  * a bond persists beyond the cut-off until it breaks, and its force is exactly the law's;
//  * bonded pairs are kept out of the contact pass (rule "exclude") or added to it ("add");
//  * a contact turned into a bond and back hands its state over both ways: the per-pair call
//    counter, carried by both laws under the same column name, equals the number of force
//    passes at the end (each pass evaluates the pair exactly once, through one table or the other);
//  * action = reaction for bond forces.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "engine/contact/bond_model.hpp"
#include "engine/contact/contact_model.hpp"
#include "engine/simulation.hpp"
#include "engine/state/pair_transfer.hpp"
#include "engine/state/particle_set.hpp"
#include "tests/support/scene.hpp"
#include "tests/support/tolerance.hpp"

namespace test_pairs_and_bonds {

using namespace sparkdem;

namespace {

constexpr double kR = 1e-3;      // sphere radius [m]
constexpr double kRho = 2500.0;  // [kg/m^3]
constexpr double kK = 1e3;       // spring constant of the mock laws [N/m]

/// Linear spring F = k * overlap * n (attractive at a gap while alive) and a neck that grows
/// while the spheres overlap. Column "calls" counts evaluations.
template <bool Persistent>
struct NeckMock {
  static constexpr std::string_view kName = "neck_mock";
  static constexpr bool kPersistent = Persistent;
  struct Params {};
  static std::vector<std::string> state_columns() { return {"neck_radius", "calls"}; }
  explicit NeckMock(const Params&) {}
  bool alive(const double* st) const { return st[0] > 0.0; }
  ContactForces operator()(const ContactGeometry& g, const RelativeMotion&, double, double* st) const {
    st[1] += 1.0;
    if (g.overlap > 0.0) st[0] = std::max(st[0], std::sqrt(g.r_eff * g.overlap));
    ContactForces f;
    f.force = kK * g.overlap * g.n;
    return f;
  }
  double normal_stiffness(const ContactGeometry&) const { return kK; }
  double tangential_stiffness(const ContactGeometry&) const { return 0.0; }
  double rayleigh_dt(double, double) const { return std::numeric_limits<double>::infinity(); }
};

/// Contact law counting its calls in column "calls".
struct CountingContact {
  static constexpr std::string_view kName = "counting_contact";
  struct Params {};
  static std::vector<std::string> state_columns() { return {"calls", "only_contact"}; }
  explicit CountingContact(const Params&) {}
  ContactForces operator()(const ContactGeometry& g, const RelativeMotion&, double, double* st) const {
    st[0] += 1.0;
    st[1] = 7.0;
    ContactForces f;
    f.force = kK * g.overlap * g.n;
    return f;
  }
  double normal_stiffness(const ContactGeometry&) const { return kK; }
  double tangential_stiffness(const ContactGeometry&) const { return 0.0; }
  double rayleigh_dt(double, double) const { return std::numeric_limits<double>::infinity(); }
};

/// Axial spring bond counting its calls in "calls"; breaks on the call that makes calls reach
/// `break_at` (never if 0).
struct CountingBond {
  static constexpr std::string_view kName = "counting_bond";
  struct Params {
    double break_at = 0.0;
  };
  static std::vector<std::string> state_columns() { return {"calls", "only_bond"}; }
  explicit CountingBond(const Params& p) : p_(p) {}
  BondForces operator()(const BondGeometry& g, const BondMotion&, double, double* st) const {
    st[0] += 1.0;
    st[1] = 3.0;
    BondForces f;
    f.force = -kK * (g.distance - g.length0) * g.n;
    f.broken = p_.break_at > 0.0 && st[0] >= p_.break_at;
    return f;
  }
  BondStiffness stiffness(const BondGeometry&) const { return {kK, 0.0, 0.0, 0.0}; }
  Params p_;
};

/// Coupling module: turns every contact row whose "calls" reached `at` into a bond, once.
class Bonder final : public Module {
 public:
  explicit Bonder(double at) : at_(at) {}
  std::string name() const override { return "bonder"; }
  Phase phase() const override { return Phase::Coupling; }
  void advance(State& s, const StepInfo& info) override {
    if (done_) return;
    std::vector<std::size_t> rows;
    const int c = s.contacts.column("calls");
    for (std::size_t r = 0; r < s.contacts.size(); ++r)
      if (s.contacts.state(r)[c] >= at_) rows.push_back(r);
    if (!rows.empty()) {
      bond_contacts(s, rows);
      done_ = true;
      bonded_step = info.step;
    }
  }
  Step bonded_step = -1;

 private:
  double at_;
  bool done_ = false;
};

/// Two spheres on the x axis at centre distance d; sets "left" and "right" for prescribing.
void two_spheres(State& s, double d) {
  test::add_sphere(s, Vec3(-0.5 * d, 0, 0), kR, kRho);
  test::add_sphere(s, Vec3(0.5 * d, 0, 0), kR, kRho);
  test::id_set(s, "left", {s.particles.id[0]});
  test::id_set(s, "right", {s.particles.id[1]});
}

/// Rows of the table holding the pair of particles 0 and 1.
template <class Table>
std::vector<std::size_t> rows_of_pair(const State& s, const Table& t) {
  std::vector<std::size_t> out;
  const auto k = pair_key(s.particles.id[0], s.particles.id[1]);
  for (std::size_t r = 0; r < t.size(); ++r)
    if (t.key(r) == k) out.push_back(r);
  return out;
}

/// Pull the two spheres apart at relative speed 2v for `steps` steps of dt.
StageConfig pulling(double v, Step steps, double dt = 1e-6, double skin = 0.3 * kR) {
  StageConfig c = test::stage(dt, steps, skin);
  c.prescribed_sets["left"] = Vec3(-v, 0, 0);
  c.prescribed_sets["right"] = Vec3(v, 0, 0);
  return c;
}

}  // namespace

TEST_CASE("a persistent neck stays in the contact table at negative overlap beyond the cut-off", "[pairs][contracts]") {
  State s;
  two_spheres(s, 1.9 * kR);  // overlap 0.1 R
  ContactModelT<NeckMock<true>> law{{}};
  Simulation sim(s, law);
  test::NullObserver obs;
  const Step steps = 1000;
  sim.run_stage(pulling(0.5, steps), obs);  // separates by 1 mm = R: gap 0.9 R > skin 0.3 R
  const double d = (s.particles.position[1] - s.particles.position[0]).norm();
  REQUIRE(d - 2.0 * kR > 0.3 * kR * 2.0);  // well beyond r_i + r_j + skin
  const auto rows = rows_of_pair(s, s.contacts);
  REQUIRE(rows.size() == 1);
  const double* st = s.contacts.state(rows[0]);
  CHECK(st[0] > 0.0);                                                 // the neck is alive
  CHECK(st[1] == Approx(static_cast<double>(steps + 1)).epsilon(0));  // evaluated at every pass (+ set-up)
  // Force on particle i (the one with the smaller id, at -x) = k * overlap * n, n = j -> i = -x:
  // attractive, towards +x.
  const double overlap = 2.0 * kR - d;
  CHECK(test::relative_error(s.contacts.force()[rows[0]].x(), -kK * overlap) < 1e-12);
  CHECK(s.particles.force[0].x() > 0.0);
}

TEST_CASE("a non-persistent law drops the pair once it leaves the neighbour candidates", "[pairs][contracts]") {
  State s;
  two_spheres(s, 1.9 * kR);
  ContactModelT<NeckMock<false>> law{{}};
  Simulation sim(s, law);
  test::NullObserver obs;
  sim.run_stage(pulling(0.5, 1000), obs);
  CHECK(rows_of_pair(s, s.contacts).empty());
  CHECK(s.particles.force[0].norm() == 0.0);
}

TEST_CASE("a bond persists beyond the cut-off until it breaks, with the law's force and action = reaction", "[bonds][contracts]") {
  State s;
  two_spheres(s, 1.95 * kR);
  ContactModelT<CountingContact> law{{}};
  BondModelT<CountingBond> bond_law{{0.0}};
  s.bonds.set_state_columns(bond_law.state_columns());
  bond_particles(s, 0, 1);
  const double L0 = 1.95 * kR;
  Simulation sim(s, law, &bond_law);
  test::NullObserver obs;
  const Step steps = 1000;
  sim.run_stage(pulling(0.5, steps), obs);
  const double d = (s.particles.position[1] - s.particles.position[0]).norm();
  REQUIRE(d - 2.0 * kR > 2.0 * 0.3 * kR);
  REQUIRE(s.bonds.size() == 1);
  CHECK_FALSE(s.bonds.broken(0));
  CHECK(s.bonds.state(0)[0] == Approx(static_cast<double>(steps + 1)).epsilon(0));
  // Force on i (at -x) = -k (d - L0) n with n = -x: pulls i towards +x.
  CHECK(test::relative_error(s.bonds.force()[0].x(), kK * (d - L0)) < 1e-12);
  // Bonded pairs are excluded from the contact pass: the pair was overlapping at the start.
  CHECK(rows_of_pair(s, s.contacts).empty());
  // Action = reaction: the prescribed particles carry exactly opposite forces.
  CHECK((s.particles.force[0] + s.particles.force[1]).norm() <= 1e-15 * s.particles.force[0].norm());
}

TEST_CASE("bond and contact forces add up under the 'add' rule and exclude each other otherwise", "[bonds][contracts]") {
  for (const bool add : {false, true}) {
    DYNAMIC_SECTION("contact rule " << (add ? "add" : "exclude")) {
      State s;
      two_spheres(s, 1.9 * kR);
      ContactModelT<CountingContact> law{{}};
      BondModelT<CountingBond> bond_law{{0.0}};
      s.bonds.set_state_columns(bond_law.state_columns());
      s.bonds.contact_rule = add ? BondTable::ContactRule::Add : BondTable::ContactRule::Exclude;
      bond_particles(s, 0, 1);
      Simulation sim(s, law, &bond_law);
      test::NullObserver obs;
      StageConfig c = test::stage(1e-6, 10, 0.3 * kR);
      c.prescribed_sets["left"] = PrescribedMotion{};
      c.prescribed_sets["right"] = PrescribedMotion{};
      sim.run_stage(c, obs);
      // At rest at the bonding length: the bond force is zero, the contact force k * 0.1 R.
      const double expected = add ? kK * 0.1 * kR : 0.0;
      CHECK(std::abs(s.particles.force[0].x() + expected) <= 1e-12 * kK * kR);
      CHECK(rows_of_pair(s, s.contacts).size() == (add ? 1u : 0u));
    }
  }
}

TEST_CASE("a contact turned into a bond and back hands its state over both ways", "[bonds][contracts]") {
  State s;
  two_spheres(s, 1.9 * kR);
  ContactModelT<CountingContact> law{{}};
  BondModelT<CountingBond> bond_law{{12.0}};  // breaks on its pass that brings "calls" to 12
  Bonder bonder(5.0);                         // bonds once the contact was evaluated 5 times
  Simulation sim(s, law, &bond_law);
  sim.add_module(&bonder);
  test::NullObserver obs;
  StageConfig c = test::stage(1e-6, 30, 0.3 * kR);
  c.prescribed_sets["left"] = PrescribedMotion{};
  c.prescribed_sets["right"] = PrescribedMotion{};
  sim.run_stage(c, obs);
  // Passes: 1 at set-up + 30 steps = 31 evaluations of the pair, by one law or the other.
  // Contact calls 1..5 (set-up + steps 1-4) -> bonded at the end of step 4 with calls = 5;
  // bond calls 6..12 (steps 5-11) -> broken in step 11; contact again from step 12: calls 13..31.
  CHECK(bonder.bonded_step == 4);
  REQUIRE(s.bonds.size() == 1);
  CHECK(s.bonds.broken(0));
  CHECK(s.bonds.broken_step(0) == 11);
  CHECK(s.bonds.state(0)[0] == 12.0);
  CHECK(s.bonds.state(0)[1] == 3.0);  // a bond-only column keeps its own value
  const auto rows = rows_of_pair(s, s.contacts);
  REQUIRE(rows.size() == 1);
  CHECK(s.contacts.state(rows[0])[0] == 31.0);
  CHECK(s.contacts.state(rows[0])[1] == 7.0);
  CHECK(s.bonds.intact_count() == 0);
  CHECK(s.bonds.broken_count() == 1);
}

TEST_CASE("an event clock fires when a bond breaks", "[bonds][scheduler][contracts]") {
  /// Records the steps at which it runs.
  class Watcher final : public Module {
   public:
    std::string name() const override { return "crack_watcher"; }
    Phase phase() const override { return Phase::Coupling; }
    Clock clock() const override {
      Clock c;
      c.kind = Clock::Kind::OnEvent;
      c.trigger.bond_broke = true;
      return c;
    }
    void advance(State&, const StepInfo& info) override { steps.push_back(info.step); }
    std::vector<Step> steps;
  };
  State s;
  two_spheres(s, 1.9 * kR);
  ContactModelT<CountingContact> law{{}};
  BondModelT<CountingBond> bond_law{{9.0}};  // set-up pass = call 1, so it breaks in step 8
  s.bonds.set_state_columns(bond_law.state_columns());
  bond_particles(s, 0, 1);
  Watcher w;
  Simulation sim(s, law, &bond_law);
  sim.add_module(&w);
  test::NullObserver obs;
  StageConfig c = test::stage(1e-6, 20, 0.3 * kR);
  c.prescribed_sets["left"] = PrescribedMotion{};
  c.prescribed_sets["right"] = PrescribedMotion{};
  sim.run_stage(c, obs);
  CHECK(s.bonds.broken_step(0) == 8);
  CHECK(w.steps == std::vector<Step>{0, 8});
}

}  // namespace test_pairs_and_bonds
