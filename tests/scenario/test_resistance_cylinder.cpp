/// Seed 001's uniform-field validation (Hubert et al. 2017, section 3.1) on the shipped scenario
/// configs/resistance_cylinder.json at N = 5000 (the relax protocol: about 3 s on one core): the
/// packing reaches its force tolerance and Eq. 1's solid fraction, and the network is consistent
/// (Kirchhoff at both electrodes, power = V I, almost no floating particle).
///
/// The figure against R_th = rho_e (l_d - 2 r_mean) / (pi r_d^2) is not checked here: it is the
/// validation ledger's (tools/validate.py, case seed001/cylinder; benchmarks/validation/). The
/// measurements behind this test's former 8 % band are benchmarks/resistance_cylinder/results.csv
/// and results.md as of commit 81fc62f (removed since: superseded by the ledger).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>

namespace test_resistance_cylinder {

namespace fs = std::filesystem;
using nlohmann::json;

TEST_CASE("seed 001 cylinder at N = 5000: the packing reaches its target, Kirchhoff and power balance hold", "[electrical][scenario]") {
  const fs::path src = fs::path(SPARKDEM_SOURCE_DIR) / "configs" / "resistance_cylinder.json";
  json scene = json::parse(std::ifstream(src));
  json& gen = scene["stages"][0]["generator"];
  REQUIRE(scene["stages"][0]["type"] == "relax");
  gen["particles"] = 5000;
  const fs::path dir = fs::temp_directory_path() / ("sparkdem_cylinder_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "scene.json") << scene.dump(1);
  const std::string cmd = std::string(SPARKDEM_BINARY) + " run " + (dir / "scene.json").string() + " -o " + (dir / "out").string() +
                          " --quiet --threads 1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  const json s = json::parse(std::ifstream(dir / "out" / "summary.json"));
  fs::remove_all(dir);
  REQUIRE(s["status"] == "completed");

  const json& el = scene["stages"][1]["modules"]["electrical_network"];
  const double rho_e = el["resistivity"].get<double>();
  const double r_d = gen["radius"].get<double>(), l_d = gen["length"].get<double>();
  const double r_mean = s["stages"][0]["packing"]["mean_radius"].get<double>();
  const json& fin = s["stages"][1]["final"];
  // The relax protocol reaches its force tolerance and the overall solid fraction of Eq. 1.
  CHECK(s["stages"][0]["packing"]["fire_max_force_relative"].get<double>() <= 1e-3);
  // (the solid volume is 0.63 V by construction; what the walls overlap lies outside: < 1e-4)
  CHECK(std::abs(s["stages"][0]["packing"]["packing_density"].get<double>() - 0.63) < 1e-4);
  const double r_dem = fin["electrical_resistance"].get<double>();
  const double r_th = rho_e * (l_d - 2.0 * r_mean) / (M_PI * r_d * r_d);
  const double error = r_dem / r_th - 1.0;
  INFO("R_DEM = " << r_dem << " Ohm, R_th = " << r_th << " Ohm, error = " << 100.0 * error << " %, r_mean = " << r_mean << " m");

  // The network itself: Kirchhoff at both electrodes, power = V I, almost no floating particle.
  CHECK(fin["electrical_current_mismatch"].get<double>() < 1e-9);
  CHECK(fin["electrical_power_mismatch"].get<double>() < 1e-9);
  CHECK(fin["electrical_floating_nodes"].get<double>() <= 0.01 * 5000);
  // The figure against the continuum (R_th) is the validation ledger's, not this test's:
  // tools/validate.py case seed001/cylinder (full tier N = 20,000, three packings; fast tier in CI).
}

}  // namespace test_resistance_cylinder
