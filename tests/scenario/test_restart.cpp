/// Restart and thread-count determinism, through the `sparkdem` executable.
///
/// Invariant under test (bit-exactness is the point, so every comparison is memcmp of the
/// stored bytes): a run interrupted by a mid-stage checkpoint and continued with --restart ends
/// in exactly the final_state.h5 of the uninterrupted run, and so does a run with 2 threads
/// (per-contact forces are gathered per particle in a fixed order, see contact_table.hpp).
/// Every dataset of final_state.h5 is compared: particle positions, velocities, omegas,
/// orientations, forces, torques, the contact rows with their history (/state/contacts/state),
/// the wall history fields, walls, Verlet reference, step, time and the RNG.
#include <catch2/catch.hpp>

#include "support/scratch.hpp"
#include <hdf5.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "io/hdf5/h5file.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct ScratchDir : sparkdem::test::ScratchDir {
  ScratchDir() : sparkdem::test::ScratchDir("sparkdem_restart") {}
};

json load_data(const std::string& name) {
  std::ifstream in(fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data" / name);
  REQUIRE(in);
  return json::parse(in);
}

fs::path write_scene(const fs::path& dir, const std::string& name, const json& j) {
  const fs::path f = dir / name;
  std::ofstream(f) << j.dump(2);
  return f;
}

/// Runs `sparkdem <args>` with OMP_NUM_THREADS=threads; returns the exit code.
int run_cli(const std::string& args, int threads, const fs::path& dir) {
  const std::string cmd = "OMP_WAIT_POLICY=PASSIVE OMP_NUM_THREADS=" + std::to_string(threads) + " '" +
                          std::string(SPARKDEM_BINARY) + "' " + args + " > '" + (dir / "stdout.txt").string() +
                          "' 2> '" + (dir / "stderr.txt").string() + "'";
  const int rc = std::system(cmd.c_str());
  if (rc == -1 || !WIFEXITED(rc)) return -1;
  const int code = WEXITSTATUS(rc);
  if (code != 0) {
    std::ifstream e(dir / "stderr.txt");
    UNSCOPED_INFO("sparkdem " << args << " -> " << code << "; stderr: " << std::string(std::istreambuf_iterator<char>(e), {}));
  }
  return code;
}

std::string q(const fs::path& p) { return "'" + p.string() + "'"; }

/// Every dataset of an HDF5 file: name -> (datatype description, dims, raw bytes in file type).
struct RawDataset {
  std::string type;
  std::vector<hsize_t> dims;
  std::vector<unsigned char> bytes;
};

/// Names of every dataset below `group` (recursive, portable HDF5 1.10/1.12 calls only).
void collect_datasets(hid_t file, const std::string& group, std::vector<std::string>& out) {
  const hid_t g = H5Gopen2(file, group.c_str(), H5P_DEFAULT);
  REQUIRE(g >= 0);
  H5G_info_t info;
  REQUIRE(H5Gget_info(g, &info) >= 0);
  for (hsize_t k = 0; k < info.nlinks; ++k) {
    char name[512];
    REQUIRE(H5Lget_name_by_idx(g, ".", H5_INDEX_NAME, H5_ITER_INC, k, name, sizeof name, H5P_DEFAULT) > 0);
    const std::string child = (group == "/" ? "" : group) + "/" + name;
    const hid_t o = H5Oopen(file, child.c_str(), H5P_DEFAULT);
    const H5I_type_t t = H5Iget_type(o);
    H5Oclose(o);
    if (t == H5I_GROUP) collect_datasets(file, child, out);
    else if (t == H5I_DATASET) out.push_back(child.substr(1));
  }
  H5Gclose(g);
}

std::map<std::string, RawDataset> read_all(const fs::path& file) {
  std::map<std::string, RawDataset> out;
  const hid_t f = H5Fopen(file.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  REQUIRE(f >= 0);
  std::vector<std::string> names;
  collect_datasets(f, "/", names);
  for (const auto& n : names) {
    const hid_t d = H5Dopen2(f, n.c_str(), H5P_DEFAULT);
    const hid_t t = H5Dget_type(d);
    const hid_t sp = H5Dget_space(d);
    RawDataset r;
    const int rank = H5Sget_simple_extent_ndims(sp);
    r.dims.resize(rank > 0 ? rank : 0);
    if (rank > 0) H5Sget_simple_extent_dims(sp, r.dims.data(), nullptr);
    const hssize_t npts = H5Sget_simple_extent_type(sp) == H5S_NULL ? 0 : H5Sget_simple_extent_npoints(sp);
    const std::size_t tsize = H5Tget_size(t);
    r.type = std::to_string(H5Tget_class(t)) + ":" + std::to_string(tsize);
    r.bytes.resize(static_cast<std::size_t>(npts) * tsize);
    if (npts > 0) REQUIRE(H5Dread(d, t, H5S_ALL, H5S_ALL, H5P_DEFAULT, r.bytes.data()) >= 0);
    out[n] = std::move(r);
    H5Sclose(sp);
    H5Tclose(t);
    H5Dclose(d);
  }
  H5Fclose(f);
  return out;
}

/// Bit-for-bit comparison of two state files; the named core datasets must be present.
void require_identical(const fs::path& a, const fs::path& b) {
  const auto da = read_all(a), db = read_all(b);
  for (const char* must : {"state/particles/position", "state/particles/velocity", "state/particles/omega",
                           "state/particles/orientation", "state/particles/force", "state/contacts/state",
                           "state/contacts/id_i", "state/step", "state/rng"})
    REQUIRE(da.count(must) == 1);
  std::vector<std::string> na, nb;
  for (const auto& [k, v] : da) na.push_back(k);
  for (const auto& [k, v] : db) nb.push_back(k);
  REQUIRE(na == nb);
  for (const auto& [name, x] : da) {
    const RawDataset& y = db.at(name);
    INFO("dataset " << name << " of " << a << " vs " << b);
    CHECK(x.type == y.type);
    CHECK(x.dims == y.dims);
    REQUIRE(x.bytes.size() == y.bytes.size());
    CHECK(std::memcmp(x.bytes.data(), y.bytes.data(), x.bytes.size()) == 0);
  }
}

/// Largest |shear displacement| in the contact history: proves the friction history is exercised.
double max_shear(const fs::path& file) {
  const auto f = sparkdem::io::H5File::open_read(file);
  double m = 0.0;
  for (double x : f.read_doubles("/state/contacts/state")) m = std::max(m, std::abs(x));
  return m;
}

std::int64_t stored_int(const fs::path& file, const std::string& name) {
  return sparkdem::io::H5File::open_read(file).read_int64(name);
}

json summary_of(const fs::path& dir) {
  std::ifstream in(dir / "summary.json");
  return json::parse(in);
}

}  // namespace

TEST_CASE("restart from a mid-stage checkpoint reproduces the frictional pour bit for bit", "[restart][scenario]") {
  ScratchDir tmp;
  // 6x6x8 lattice of 2 mm spheres, lammps_hertz_tsuji with friction 0.5, tilted floor and tilted
  // gravity, spatial sort every 2 rebuilds, 3000 steps. Its `until` (no pair contact after
  // 0.03 s) never holds in the uninterrupted run; it is checked every 100 steps, so it is also
  // checked right after the restart at step 1700: a regression guard for restoring the
  // per-contact overlaps the monitors read.
  json scene = load_data("restart_pour.json");
  scene["stages"][1]["until"] = {{"contacts", {{"below", 1}}}, {"time", {{"above", 0.03}}}};
  const fs::path plain = write_scene(tmp.path, "plain.json", scene);
  scene["stages"][1]["output"]["checkpoint_every"] = 1700;  // global steps: one checkpoint, mid-stage
  const fs::path ckpt = write_scene(tmp.path, "ckpt.json", scene);
  const fs::path A = tmp.path / "A", B = tmp.path / "B", C = tmp.path / "C";

  REQUIRE(run_cli("run " + q(plain) + " -o " + q(A) + " --quiet", 1, tmp.path) == 0);
  REQUIRE(run_cli("run " + q(ckpt) + " -o " + q(B) + " --quiet", 1, tmp.path) == 0);
  REQUIRE(fs::exists(B / "checkpoint.h5"));
  // The checkpoint lies inside the pour stage (stage 1), at global step 1700 of 3000.
  CHECK(stored_int(B / "checkpoint.h5", "/state/step") == 1700);
  CHECK(stored_int(B / "checkpoint.h5", "/state/stage_index") == 1);
  CHECK(stored_int(B / "checkpoint.h5", "/pipeline/in_stage") == 1);
  REQUIRE(run_cli("run " + q(ckpt) + " --restart " + q(B / "checkpoint.h5") + " -o " + q(C) + " --quiet", 1, tmp.path) == 0);

  CHECK(summary_of(A)["steps"] == 3000);
  CHECK(summary_of(C)["stages"].back()["steps"] == 3000);  // stage steps counted from the stage start
  CHECK(stored_int(C / "final_state.h5", "/state/step") == 3000);
  // Friction is active: tangential history of at least 1e-9 m (overlaps are ~1e-5 m here).
  CHECK(max_shear(A / "final_state.h5") > 1e-9);
  require_identical(A / "final_state.h5", B / "final_state.h5");  // writing a checkpoint changes nothing
  require_identical(A / "final_state.h5", C / "final_state.h5");
}

TEST_CASE("one and two threads give bit-identical frictional pours", "[restart][threads][scenario]") {
  ScratchDir tmp;
  const fs::path scene = fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data/restart_pour.json";
  const fs::path A = tmp.path / "one", B = tmp.path / "two";
  REQUIRE(run_cli("run " + q(scene) + " -o " + q(A) + " --quiet --threads 1", 1, tmp.path) == 0);
  REQUIRE(run_cli("run " + q(scene) + " -o " + q(B) + " --quiet --threads 2", 2, tmp.path) == 0);
  CHECK(summary_of(A)["threads"] == 1);
  CHECK(summary_of(B)["threads"] == 2);
  CHECK(max_shear(A / "final_state.h5") > 1e-9);
  require_identical(A / "final_state.h5", B / "final_state.h5");
}

TEST_CASE("multi-stage restart: checkpoints in the first and in the second dynamics stage", "[restart][scenario]") {
  ScratchDir tmp;
  // lattice -> pour (1800 steps, hertz_mindlin, friction 0.5) -> push (1500 steps, moving wall
  // xlo, mass scaling 2, different dt). checkpoint_every counts global steps: 1100 lands in the
  // pour (stage step 1100), 2300 in the push (stage step 500).
  const json base = load_data("restart_two_stage.json");
  const fs::path plain = write_scene(tmp.path, "plain.json", base);
  const fs::path A = tmp.path / "A";
  REQUIRE(run_cli("run " + q(plain) + " -o " + q(A) + " --quiet", 1, tmp.path) == 0);
  CHECK(summary_of(A)["steps"] == 3300);
  CHECK(max_shear(A / "final_state.h5") > 1e-9);

  struct Case { int stage; int every; std::int64_t stage_step0; };
  for (const Case c : {Case{1, 1100, 0}, Case{2, 2300, 1800}}) {
    DYNAMIC_SECTION("checkpoint in stage " << c.stage << " at global step " << c.every) {
      json scene = base;
      scene["stages"][c.stage]["output"]["checkpoint_every"] = c.every;
      const fs::path f = write_scene(tmp.path, "ckpt" + std::to_string(c.stage) + ".json", scene);
      const fs::path B = tmp.path / ("B" + std::to_string(c.stage)), C = tmp.path / ("C" + std::to_string(c.stage));
      REQUIRE(run_cli("run " + q(f) + " -o " + q(B) + " --quiet", 1, tmp.path) == 0);
      CHECK(stored_int(B / "checkpoint.h5", "/state/step") == c.every);
      CHECK(stored_int(B / "checkpoint.h5", "/state/stage_index") == c.stage);
      CHECK(stored_int(B / "checkpoint.h5", "/state/stage_step0") == c.stage_step0);
      REQUIRE(run_cli("run " + q(f) + " --restart " + q(B / "checkpoint.h5") + " -o " + q(C) + " --quiet", 1, tmp.path) == 0);
      require_identical(A / "final_state.h5", C / "final_state.h5");
    }
  }
}

TEST_CASE("restart inside a fill stage: radius growth, wall history and until conditions", "[restart][scenario]") {
  ScratchDir tmp;
  // 60 spheres grown in a 4 mm box (the growth state lives in per-particle fields restored from
  // the checkpoint), then 500 steps under gravity. The fill stage stops on its `until`
  // conditions (growth complete, settled, small overlaps), checked every 50 steps.
  const json base = load_data("restart_fill.json");
  const fs::path A = tmp.path / "A", B = tmp.path / "B", C = tmp.path / "C";
  REQUIRE(run_cli("run " + q(write_scene(tmp.path, "plain.json", base)) + " -o " + q(A) + " --quiet", 1, tmp.path) == 0);
  const json cook = summary_of(A)["stages"][0];
  CHECK(cook["until_reached"] == true);  // the stop conditions, not the step budget, end the stage
  const std::int64_t n = cook["steps"].get<std::int64_t>();
  // One checkpoint at about 3/4 of the stage, on a check_every boundary: the `until` check right
  // after the restart sees the restored state.
  const std::int64_t every = std::max<std::int64_t>(50, 3 * n / 4 / 50 * 50);
  json scene = base;
  scene["stages"][0]["output"]["checkpoint_every"] = every;
  const fs::path f = write_scene(tmp.path, "ckpt.json", scene);
  REQUIRE(run_cli("run " + q(f) + " -o " + q(B) + " --quiet", 1, tmp.path) == 0);
  CHECK(stored_int(B / "checkpoint.h5", "/state/step") == every);
  CHECK(stored_int(B / "checkpoint.h5", "/state/stage_index") == 0);
  REQUIRE(run_cli("run " + q(f) + " --restart " + q(B / "checkpoint.h5") + " -o " + q(C) + " --quiet", 1, tmp.path) == 0);
  CHECK(summary_of(C)["stages"][0]["steps"] == n);
  require_identical(A / "final_state.h5", C / "final_state.h5");
}
