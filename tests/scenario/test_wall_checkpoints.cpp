/// Wall-clock checkpoints (issue 64 item 3, output.checkpoint_every_s): a run writes a checkpoint
/// whenever that many wall seconds passed since the last one, at whatever step that is, and a
/// restart from it ends bit for bit in the uninterrupted run's final state; 0 writes none; the
/// default is 600 s; the newest two are kept (checkpoint.h5, checkpoint.previous.h5) and a restart
/// from either ends in the same final state.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "io/scenario/pipeline.hpp"
#include "io/scenario/scenario.hpp"
#include "support/h5compare.hpp"
#include "support/scratch.hpp"

namespace test_wall_checkpoints {

namespace {
namespace fs = std::filesystem;
using nlohmann::json;
using namespace sparkdem;

json run(const json& scene, const fs::path& out, const std::optional<fs::path>& restart = {}) {
  return test::run_scene(scene, fs::path(SPARKDEM_SOURCE_DIR) / "tests/scenario/data", out, restart);
}

std::size_t lines_with(const fs::path& file, const std::string& what) {
  std::ifstream in(file);
  std::size_t n = 0;
  for (std::string line; std::getline(in, line);) n += line.find(what) != std::string::npos;
  return n;
}

}  // namespace

TEST_CASE("wall-clock checkpoints: written every checkpoint_every_s, a restart from one continues bit for bit", "[restart][scenario]") {
  test::ScratchDir tmp("sparkdem_wall_checkpoints");
  json scene = test::load_data("hot_press_small.json");
  scene["stages"][1]["stop"] = {{"steps", 60000}};  // about 0.15 s on one thread
  CHECK(io::load_scenario(scene, test::registry(), tmp.path).stages[1].cfg.checkpoint_every_s == 600.0);
  for (json& st : scene["stages"]) st["output"]["checkpoint_every_s"] = 0.0;
  run(scene, tmp.path / "A");
  CHECK_FALSE(fs::exists(tmp.path / "A" / "checkpoint.h5"));
  scene["stages"][1]["output"]["checkpoint_every_s"] = 0.02;
  run(scene, tmp.path / "B");
  const std::size_t written = lines_with(tmp.path / "B" / "run.log", "checkpoint written");
  INFO("checkpoints written: " << written);
  REQUIRE(written >= 2);
  REQUIRE(fs::exists(tmp.path / "B" / "checkpoint.h5"));
  // The newest two are kept, both sealed (verified on reading), the previous one at an earlier step.
  REQUIRE(fs::exists(tmp.path / "B" / "checkpoint.previous.h5"));
  std::size_t files = 0;
  for (const auto& e : fs::directory_iterator(tmp.path / "B")) files += e.path().filename().string().rfind("checkpoint", 0) == 0;
  CHECK(files == 2);
  State newest, previous;
  io::read_checkpoint(tmp.path / "B" / "checkpoint.h5", newest);
  io::read_checkpoint(tmp.path / "B" / "checkpoint.previous.h5", previous);
  CHECK(previous.step < newest.step);
  const json c = run(scene, tmp.path / "C", tmp.path / "B" / "checkpoint.h5");
  CHECK(c["status"] == "completed");
  test::require_identical_state(tmp.path / "A" / "final_state.h5", tmp.path / "C" / "final_state.h5", {"pipeline/record"});
  const json d = run(scene, tmp.path / "D", tmp.path / "B" / "checkpoint.previous.h5");
  CHECK(d["status"] == "completed");
  test::require_identical_state(tmp.path / "A" / "final_state.h5", tmp.path / "D" / "final_state.h5", {"pipeline/record"});
}

}  // namespace test_wall_checkpoints
