/// The run watchdog (engine/watchdog.hpp) through the pipeline (io/scenario/pipeline.cpp).
///
/// One scene per trigger, each with a closed form for when and how it fires:
///  - speed: one sphere falling from rest, v_n = n g dt, against watchdog.max_speed;
///  - overlap: two spheres driven into each other at a prescribed speed, overlap_n = h0 + n v dt,
///    against the contact law's bound 0.5;
///  - kinetic-energy growth: a bonded pair (linear spring) stepped at h = omega dt = 2.0049, above
///    the velocity-Verlet limit 2: the relative motion grows by |lambda| per step, lambda the root
///    of lambda^2 - (2 - h^2) lambda + 1 = 0 of largest modulus, so the kinetic energy grows by
///    lambda^(2 n) (checked against the reported growth);
///  - non-finite values: a test module writes NaN or Inf into a checked field at a given step.
/// For each: the PhysicsError's step, quantity, ids, value and bound; the summary's failure
/// entry; OUTDIR/checkpoint_before_failure.h5 passes its checksum, holds a finite state from
/// before the failure, and a --restart from it fails again at the same step with the same
/// particles. Negative cases: a NaN in the electric potential (a floating particle) is legitimate,
/// and the frictional pour of the crash-safety test runs to its end with the default watchdog.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "engine/contact/contact_model.hpp"
#include "engine/core/error.hpp"
#include "engine/model/param_spec.hpp"
#include "engine/model/module.hpp"
#include "engine/model/registry.hpp"
#include "io/restart/checkpoint_file.hpp"
#include "io/restart/hdf5_archive.hpp"
#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "physics/register_all.hpp"
#include "support/h5compare.hpp"
#include "support/scratch.hpp"

namespace test_watchdog {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

/// Test-only module: at global step `step` writes `value` ("nan" or "inf") into its field at the
/// particle `id`; declares the field with the watchdog check `check` as a real module would.
class Injector final : public Module {
 public:
  struct Params {
    std::string field = "temperature";
    std::string check = "finite";
    std::string value = "nan";
    std::int64_t step = 0;
    std::int64_t id = 0;
  };
  static ParamSpec<Params> spec() {
    ParamSpec<Params> s("test_injector", "module", "writes NaN or Inf into a field at one step (watchdog tests)");
    s.add("field", &Params::field).doc("field name");
    s.add("check", &Params::check).choices({"finite", "not_infinite"}).doc("the field's watchdog check");
    s.add("value", &Params::value).choices({"nan", "inf"}).doc("value written");
    s.add("step", &Params::step).min(0).doc("global step at which it is written");
    s.add("id", &Params::id).min(0).doc("particle id");
    return s;
  }
  explicit Injector(const Params& p) : p_(p) {}
  std::string name() const override { return "test_injector"; }
  Phase phase() const override { return Phase::Coupling; }
  void declare(Declarations& d) const override {
    d.particle_fields.push_back({p_.field, 1, "1", 300.0, true, p_.check == "finite" ? FieldCheck::Finite : FieldCheck::NotInfinite});
    d.reads = {"position"};
    d.writes = {p_.field};
  }
  void advance(State& s, const StepInfo& info) override {
    if (info.step != p_.step) return;
    auto& f = s.particles.fields.data(p_.field);
    for (std::size_t i = 0; i < s.particles.size(); ++i)
      if (s.particles.id[i] == p_.id)
        f[i] = p_.value == "nan" ? std::numeric_limits<double>::quiet_NaN() : std::numeric_limits<double>::infinity();
  }

 private:
  Params p_;
};

const Registry& registry() {
  static const Registry reg = [] {
    Registry r;
    physics::register_all(r);
    r.module<Injector>();
    return r;
  }();
  return reg;
}

json run(const json& scene, const fs::path& out, const std::optional<fs::path>& restart = {}) {
  io::Scenario sc = io::load_scenario(scene, registry(), fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data");
  io::RunOptions opt;
  opt.outdir = out;
  opt.restart = restart;
  opt.quiet = true;
  opt.threads = 1;
  return io::run_scenario(sc, opt);
}

/// Runs a scene that must fail with a PhysicsError; returns it.
PhysicsError run_failing(const json& scene, const fs::path& out, const std::optional<fs::path>& restart = {}) {
  try {
    run(scene, out, restart);
  } catch (const PhysicsError& e) {
    INFO(e.what());
    return e;
  }
  FAIL("the run was not stopped by the watchdog");
  throw std::logic_error("unreachable");
}

json summary_of(const fs::path& dir) {
  std::ifstream in(dir / "summary.json");
  return json::parse(in);
}

/// checkpoint_before_failure.h5 of `dir`: it passes its checksum, holds a state of step < `failed`
/// whose particle quantities are finite, and the error names it. Returns its step.
Step check_pre_failure_checkpoint(const fs::path& dir, const PhysicsError& e) {
  const fs::path f = dir / "checkpoint_before_failure.h5";
  REQUIRE(fs::exists(f));
  REQUIRE_NOTHROW(io::read_verified_checkpoint(f));
  CHECK(std::string(e.what()).find(f.string()) != std::string::npos);
  CHECK(e.detail().checkpoint == f.string());
  State s;
  io::read_checkpoint(f, s);
  CHECK(s.step < e.step());
  CHECK(s.step == e.detail().checkpoint_step);
  const auto& p = s.particles;
  REQUIRE(p.size() > 0);
  bool finite = true;
  for (std::size_t i = 0; i < p.size(); ++i)
    finite = finite && p.position[i].allFinite() && p.velocity[i].allFinite() && p.omega[i].allFinite() && p.force[i].allFinite();
  for (const auto& name : p.fields.names())
    if (name == "temperature")
      for (double x : p.fields.data(name)) finite = finite && std::isfinite(x);
  CHECK(finite);
  const json fs_ = summary_of(dir)["failure"];
  CHECK(fs_["step"] == e.step());
  CHECK(fs_["quantity"] == e.quantity());
  CHECK(fs_["checkpoint_before_failure"]["step"] == s.step);
  return s.step;
}

/// Restarting from the pre-failure checkpoint fails again at the same step, in the same quantity,
/// with the same particles.
void check_restart_reproduces(const json& scene, const fs::path& dir, const PhysicsError& e, const fs::path& again) {
  const PhysicsError r = run_failing(scene, again, dir / "checkpoint_before_failure.h5");
  CHECK(r.step() == e.step());
  CHECK(r.quantity() == e.quantity());
  CHECK(r.ids() == e.ids());
  if (std::isfinite(e.detail().value)) CHECK(r.detail().value == e.detail().value);
}

json material() { return json::array({{{"name", "glass"}, {"density", 2500}}}); }
json hooke(double kn) { return {{"law", "linear_spring_dashpot"}, {"params", {{"normal_stiffness", kn}, {"restitution", 0.5}}}}; }

/// One sphere falling from rest under g = 10 m/s^2 at dt = 1e-4 s for `steps` steps, watched by
/// `watchdog`.
json falling_sphere(const json& watchdog, std::int64_t steps) {
  return {{"name", "fall"},
          {"materials", material()},
          {"contact", hooke(1.0)},
          {"stages",
           {{{"name", "create"},
             {"type", "lattice"},
             {"generator", {{"lo", {0, 0, 0}}, {"hi", {0, 0, 0}}, {"spacing", 0.002}, {"diameter", 0.002}}}},
            {{"name", "fall"},
             {"type", "dynamics"},
             {"dt", 1e-4},
             {"modules", {{"gravity", {{"acceleration", {0, 0, -10}}}}}},
             {"watchdog", watchdog},
             {"stop", {{"steps", steps}}}}}}};
}

}  // namespace

TEST_CASE("watchdog speed: a sphere falling from rest is stopped at the first check after n g dt > max_speed", "[watchdog]") {
  test::ScratchDir tmp("sparkdem_watchdog");
  // g = 10 m/s^2, dt = 1e-4 s: v_n = n 1e-3 m/s passes 0.0505 m/s at n = 51; checks every 10 steps.
  const json scene = falling_sphere({{"max_speed", 0.0505}, {"snapshot_every_checks", 1}}, 200);
  const PhysicsError e = run_failing(scene, tmp.path / "a");
  CHECK(e.step() == 60);
  CHECK(e.quantity() == "velocity");
  CHECK(e.ids() == std::vector<Id>{0});
  CHECK(e.detail().value == Approx(0.06).epsilon(1e-9));
  CHECK(e.detail().bound == 0.0505);
  CHECK(e.detail().time == Approx(6e-3).epsilon(1e-12));
  CHECK(e.detail().hint.find("watchdog.max_speed") != std::string::npos);
  CHECK(check_pre_failure_checkpoint(tmp.path / "a", e) == 50);
  check_restart_reproduces(scene, tmp.path / "a", e, tmp.path / "b");
}

TEST_CASE("watchdog copies: a copy above snapshot_memory_max_bytes goes to a scratch file and gives the same checkpoint", "[watchdog]") {
  test::ScratchDir tmp("sparkdem_watchdog");
  // The falling sphere above, copied every check: in memory (default limit, the state is about
  // 2 KB) and as the scratch file (limit 0). Both checkpoints must hold the same state at step 50.
  auto scene = [](std::int64_t limit, std::int64_t steps) {
    return falling_sphere({{"max_speed", 0.0505}, {"snapshot_every_checks", 1}, {"snapshot_memory_max_bytes", limit}}, steps);
  };
  const PhysicsError m = run_failing(scene(1 << 20, 200), tmp.path / "memory");
  const PhysicsError f = run_failing(scene(0, 200), tmp.path / "file");
  CHECK(f.step() == m.step());
  CHECK(check_pre_failure_checkpoint(tmp.path / "memory", m) == 50);
  CHECK(check_pre_failure_checkpoint(tmp.path / "file", f) == 50);
  CHECK(!fs::exists(tmp.path / "file" / ".healthy_state.h5"));  // renamed to the checkpoint
  // run.log says where the copies went: the file for limit 0 only.
  const auto log_has_file_copies = [](const fs::path& dir) {
    std::ifstream in(dir / "run.log");
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return text.find("copies of the last healthy state go to .healthy_state.h5") != std::string::npos;
  };
  CHECK_FALSE(log_has_file_copies(tmp.path / "memory"));
  CHECK(log_has_file_copies(tmp.path / "file"));
  // The two checkpoints hold the same state (every dataset but the run record's paths).
  test::require_identical_state(tmp.path / "memory" / "checkpoint_before_failure.h5", tmp.path / "file" / "checkpoint_before_failure.h5",
                                {"pipeline/record"});
  check_restart_reproduces(scene(0, 200), tmp.path / "file", f, tmp.path / "again");
  // A stage that ends well removes its scratch copy; a killed run's leftovers go at the start.
  fs::create_directories(tmp.path / "ok");
  std::ofstream(tmp.path / "ok" / ".healthy_state.h5.tmp") << "left by a killed run";
  const json ok = run(scene(0, 40), tmp.path / "ok");
  CHECK(ok["status"] == "completed");
  CHECK(!fs::exists(tmp.path / "ok" / ".healthy_state.h5"));
  CHECK(!fs::exists(tmp.path / "ok" / ".healthy_state.h5.tmp"));
  CHECK(!fs::exists(tmp.path / "ok" / "checkpoint_before_failure.h5"));
}

TEST_CASE("watchdog overlap: two spheres driven into each other are stopped past half the smaller radius, naming both", "[watchdog]") {
  test::ScratchDir tmp("sparkdem_watchdog");
  // r = 1.0025 mm at 2 mm spacing: h0 = 5e-6 m; sphere 1 driven at 0.1 m/s, dt = 1e-5 s:
  // h_n = 5e-6 + n 1e-6 m, h_n / r > 0.5 from n = 497; the check at step 500 sees 505e-6 / 1.0025e-3.
  json scene = {{"name", "squeeze"},
                {"materials", material()},
                {"contact", hooke(1e3)},
                {"particle_sets", {{"left", {{"type", "ids"}, {"ids", {0}}}}, {"right", {{"type", "ids"}, {"ids", {1}}}}}},
                {"stages",
                 {{{"name", "create"},
                   {"type", "lattice"},
                   {"generator", {{"lo", {0, 0, 0}}, {"hi", {0.002, 0, 0}}, {"spacing", 0.002}, {"diameter", 0.002005}}}},
                  {{"name", "squeeze"},
                   {"type", "dynamics"},
                   {"dt", 1e-5},
                   {"sets", {"left", "right"}},
                   {"prescribe", {{"left", {0, 0, 0}}, {"right", {-0.1, 0, 0}}}},
                   {"watchdog", {{"snapshot_every_checks", 10}}},
                   {"stop", {{"steps", 1000}}}}}}};
  const PhysicsError e = run_failing(scene, tmp.path / "a");
  CHECK(e.step() == 500);
  CHECK(e.quantity() == "overlap");
  CHECK(e.ids() == std::vector<Id>{0, 1});
  CHECK(e.detail().value == Approx(505e-6 / 1.0025e-3).epsilon(1e-6));
  CHECK(e.detail().bound == 0.5);  // the elastic law's default bound
  CHECK(e.detail().hint.find("watchdog.max_overlap_ratio") != std::string::npos);
  // Default snapshots every 10 checks: the last healthy copy is the one at step 400.
  CHECK(check_pre_failure_checkpoint(tmp.path / "a", e) == 400);
  check_restart_reproduces(scene, tmp.path / "a", e, tmp.path / "b");
  // The bound is a parameter: raised to 0.6, the same drive fails at the check after h_n / r > 0.6.
  scene["stages"][1]["watchdog"] = {{"max_overlap_ratio", 0.6}};
  const PhysicsError e6 = run_failing(scene, tmp.path / "c");
  CHECK(e6.step() == 600);  // h_600 / r = 605e-6 / 1.0025e-3 = 0.6035; h_590 / r = 0.5935
  CHECK(e6.detail().bound == 0.6);
}

namespace {
/// Two 1 mm spheres 2 mm apart, bonded by an unbreakable linear spring (k = 100 N/m, contacts of
/// bonded pairs excluded); sphere 0 starts at 1e-10 m/s along the bond (a one-step kick stage),
/// then the pair is stepped at h = omega dt = 2.0049 (omega^2 = 2 k / m).
struct BondedPair {
  static constexpr double k = 100.0, r = 1e-3, rho = 2500.0, h = 2.0049;
  static double mass() { return rho * 4.0 / 3.0 * 3.14159265358979323846 * r * r * r; }
  static double omega() { return std::sqrt(2.0 * k / mass()); }
  static double dt() { return h / omega(); }
  /// |lambda|: the largest root of lambda^2 - (2 - h^2) lambda + 1 = 0.
  static double amplification() {
    const double b = 2.0 - h * h;
    return std::abs((b - std::sqrt(b * b - 4.0)) / 2.0);
  }
  static json scene() {
    return {{"name", "bonded_pair"},
            {"materials", material()},
            {"contact", hooke(1e3)},
            {"bonds", {{"law", "spring_bond"}, {"params", {{"normal_stiffness", k}}}}},
            {"particle_sets", {{"kicked", {{"type", "ids"}, {"ids", {0}}}}}},
            {"stages",
             {{{"name", "create"},
               {"type", "lattice"},
               {"generator", {{"lo", {0, 0, 0}}, {"hi", {0.002, 0, 0}}, {"spacing", 0.002}, {"diameter", 0.002}}}},
              {{"name", "kick"},
               {"type", "dynamics"},
               {"dt", 1e-9},
               {"sets", {"kicked"}},
               {"prescribe", {{"kicked", {1e-10, 0, 0}}}},
               {"stop", {{"steps", 1}}}},
              {{"name", "unstable"},
               {"type", "dynamics"},
               {"dt", dt()},
               {"allow_unstable_dt", true},
               {"create_bonds", {{"gap_tolerance", 1e-6}}},
               {"stop", {{"steps", 2000}}}}}}};
  }
};
}  // namespace

TEST_CASE(
    "watchdog energy: a bonded pair stepped above the stable step is stopped by its kinetic-energy growth "
    "before any sphere moves its radius in a step",
    "[watchdog]") {
  test::ScratchDir tmp("sparkdem_watchdog");
  json scene = BondedPair::scene();
  scene["stages"][2]["watchdog"] = {{"snapshot_every_checks", 10}};
  const PhysicsError e = run_failing(scene, tmp.path / "a");
  INFO(e.what());
  CHECK(e.quantity() == "kinetic energy");
  const Step k = e.step() - 1;  // stage steps (the kick stage took one)
  CHECK(k % 10 == 0);
  CHECK(k > 60);  // a full window of 5 checks with a positive first sample
  // The growth over the window of 50 steps is |lambda|^100 (the decaying root is gone by then).
  const double lambda = BondedPair::amplification();
  CHECK(lambda == Approx(1.15).epsilon(0.01));
  CHECK(e.detail().value == Approx(std::pow(lambda, 100)).epsilon(0.01));
  CHECK(e.detail().bound == 1e4);
  REQUIRE(e.ids().size() == 2);
  CHECK(std::min(e.ids()[0], e.ids()[1]) == 0);
  CHECK(std::max(e.ids()[0], e.ids()[1]) == 1);
  CHECK(e.detail().hint.find("reduce dt below the stable step") != std::string::npos);
  const Step before = check_pre_failure_checkpoint(tmp.path / "a", e);
  CHECK(before == 1 + 100);  // stage step 100: the last of the snapshots every 10 checks
  check_restart_reproduces(scene, tmp.path / "a", e, tmp.path / "b");
  // Without the energy check the speed check (r / dt) stops the same run, but later.
  json off = scene;
  off["stages"][2]["watchdog"] = {{"energy_growth_factor", 0}};
  const PhysicsError v = run_failing(off, tmp.path / "c");
  CHECK(v.quantity() == "velocity");
  CHECK(v.step() > e.step());
}

TEST_CASE(
    "watchdog non-finite: NaN or Inf in a checked field stops the run naming the field and the particle; "
    "NaN in the electric potential (floating) does not",
    "[watchdog]") {
  test::ScratchDir tmp("sparkdem_watchdog");
  auto scene = [](const std::string& field, const std::string& check, const std::string& value) {
    return json{{"name", "inject"},
                {"materials", material()},
                {"contact", hooke(1e3)},
                {"stages",
                 {{{"name", "create"},
                   {"type", "lattice"},
                   {"generator", {{"lo", {0, 0, 0}}, {"hi", {0.002, 0.002, 0}}, {"spacing", 0.002}, {"diameter", 0.002}}}},
                  {{"name", "run"},
                   {"type", "dynamics"},
                   {"dt", 1e-5},
                   {"modules",
                    {{"gravity", {{"acceleration", {0, 0, -9.81}}}},
                     {"test_injector", {{"field", field}, {"check", check}, {"value", value}, {"step", 33}, {"id", 2}}}}},
                   {"watchdog", {{"snapshot_every_checks", 1}}},
                   {"stop", {{"steps", 100}}}}}}};
  };
  const json t_nan = scene("temperature", "finite", "nan");
  const PhysicsError e = run_failing(t_nan, tmp.path / "a");
  CHECK(e.step() == 40);
  CHECK(e.quantity() == "temperature");
  CHECK(e.ids() == std::vector<Id>{2});
  CHECK(check_pre_failure_checkpoint(tmp.path / "a", e) == 30);
  check_restart_reproduces(t_nan, tmp.path / "a", e, tmp.path / "b");

  const PhysicsError inf = run_failing(scene("electric_potential", "not_infinite", "inf"), tmp.path / "c");
  CHECK(inf.step() == 40);
  CHECK(inf.quantity() == "electric_potential");
  CHECK(inf.ids() == std::vector<Id>{2});

  const json ok = run(scene("electric_potential", "not_infinite", "nan"), tmp.path / "d");
  CHECK(ok["status"] == "completed");
  CHECK(ok["steps"] == 100);
  CHECK(!fs::exists(tmp.path / "d" / "checkpoint_before_failure.h5"));
}

TEST_CASE("watchdog: a state that fails it at the stage start is refused before step 0", "[watchdog]") {
  test::ScratchDir tmp("sparkdem_watchdog");
  // Two spheres of radius 1.6 mm created 2 mm apart: overlap 1.2 mm = 75 % of the radius.
  json scene = {{"name", "refused"},
                {"materials", material()},
                {"contact", hooke(1e3)},
                {"stages",
                 {{{"name", "create"},
                   {"type", "lattice"},
                   {"generator", {{"lo", {0, 0, 0}}, {"hi", {0.002, 0, 0}}, {"spacing", 0.002}, {"diameter", 0.0032}}}},
                  {{"name", "run"}, {"type", "dynamics"}, {"dt", 1e-6}, {"stop", {{"steps", 100}}}}}}};
  const PhysicsError e = run_failing(scene, tmp.path / "a");
  CHECK(e.step() == 0);
  CHECK(e.quantity() == "overlap");
  CHECK(e.ids() == std::vector<Id>{0, 1});
  CHECK(e.detail().value == Approx(0.0012 / 0.0016).epsilon(1e-9));
  CHECK(std::string(e.what()).find("refused before its first step") != std::string::npos);
  CHECK(!fs::exists(tmp.path / "a" / "checkpoint_before_failure.h5"));
}

TEST_CASE("watchdog negative: the frictional pour runs to its end with the default watchdog, well inside its bounds", "[watchdog]") {
  test::ScratchDir tmp("sparkdem_watchdog");
  json scene = test::load_data("crash_pour.json");
  scene["stages"][1]["output"] = {{"timeseries_every", 10}};
  const json s = run(scene, tmp.path / "a");
  CHECK(s["status"] == "completed");
  CHECK(s["steps"] == 2000);
  CHECK(!s.contains("failure"));
  CHECK(!fs::exists(tmp.path / "a" / "checkpoint_before_failure.h5"));
  // The margins: the largest overlap ratio and speed per step over radius seen in the time series.
  std::ifstream in(tmp.path / "a" / "timeseries.csv");
  std::string header, line;
  std::getline(in, header);
  std::vector<std::string> cols;
  for (std::size_t a = 0, b; a <= header.size(); a = b + 1) {
    b = header.find(',', a);
    if (b == std::string::npos) b = header.size();
    cols.push_back(header.substr(a, b - a));
  }
  const auto col = [&](const std::string& n) { return static_cast<std::size_t>(std::find(cols.begin(), cols.end(), n) - cols.begin()); };
  const std::size_t c_ov = col("max_overlap_ratio"), c_v = col("max_speed");
  REQUIRE(c_ov < cols.size());
  REQUIRE(c_v < cols.size());
  double ov = 0.0, v = 0.0;
  while (std::getline(in, line)) {
    std::vector<double> x;
    for (std::size_t a = 0, b; a <= line.size(); a = b + 1) {
      b = line.find(',', a);
      if (b == std::string::npos) b = line.size();
      x.push_back(std::atof(line.substr(a, b - a).c_str()));
    }
    if (x.size() != cols.size()) continue;
    ov = std::max(ov, x[c_ov]);
    v = std::max(v, x[c_v]);
  }
  INFO("max overlap ratio " << ov << ", max speed " << v << " m/s");
  CHECK(ov > 0.0);
  CHECK(ov < 0.1 * kDefaultOverlapRatioBound);
  CHECK(v * 2e-5 / 1e-3 < 0.1);  // dt = 2e-5 s, r = 1 mm: far below one radius per step
}

}  // namespace test_watchdog
