/// The three packing generators on small cases (fast) and on the shipped configs ([slow]):
/// the density measured from the particles within 0.01 of the target, settled (kinetic energy per
/// mass below the generator's threshold), largest overlap below 1 % of the smaller radius, and the
/// mean coordination of the interior where the source states it (fill/deposit: jammed, about 6;
/// GranOO reports 6.7 for 5,000 elements).
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

namespace test_packing_generators {

namespace fs = std::filesystem;
using nlohmann::json;

namespace {

json run_scene(const std::string& scene, const std::string& tag) {
  const fs::path out = fs::temp_directory_path() / ("sparkdem_gen_" + tag + "_" + std::to_string(::getpid()));
  fs::remove_all(out);
  const std::string cmd = std::string(SPARKDEM_BINARY) + " run " + scene + " -o " + out.string() + " --quiet --threads 1";
  const int rc = std::system(cmd.c_str());
  REQUIRE(rc == 0);
  std::ifstream in(out / "summary.json");
  json j = json::parse(in);
  fs::remove_all(out);
  return j;
}

json generator_params(const std::string& scene) {
  std::ifstream in(scene);
  return json::parse(in)["stages"][0]["generator"];
}

void check_packing(const json& summary, const json& gen, bool dynamic, bool jammed) {
  const json& st = summary["stages"][0];
  const json& p = st["packing"];
  const double target = gen["target_density"].get<double>();
  INFO("packing report: " << p.dump());
  CHECK(std::abs(p["packing_density"].get<double>() - target) <= 0.01);
  CHECK(p["max_overlap_ratio"].get<double>() <= 0.01);
  if (dynamic) {
    CHECK(st["until_reached"].get<bool>());
    CHECK(st["final"]["kinetic_energy_per_mass"].get<double>() <= gen["ke_per_mass_below"].get<double>());
  }
  if (jammed) {
    // Jammed frictionless/low-friction packings: interior coordination near the isostatic 6.
    CHECK(p["coordination_interior"].get<double>() >= 4.5);
    CHECK(p["coordination_interior"].get<double>() <= 7.5);
  }
}

const std::string data = std::string(SPARKDEM_SOURCE_DIR) + "/tests/scenario/data/";
const std::string configs = std::string(SPARKDEM_SOURCE_DIR) + "/configs/";

}  // namespace

TEST_CASE("relax reaches its density with FIRE on a small box", "[generators]") {
  const std::string scene = data + "gen_relax_small.json";
  const json s = run_scene(scene, "relax");
  check_packing(s, generator_params(scene), false, false);
  // FIRE converged: largest force below force_tolerance k / r_mean (default 1e-6).
  CHECK(s["stages"][0]["packing"]["fire_max_force_relative"].get<double>() <= 1e-6);
}

TEST_CASE("relax packs a lognormal size distribution into a small cylinder without rescaling it", "[generators]") {
  const std::string scene = data + "gen_relax_cylinder_psd.json";
  const json s = run_scene(scene, "relax_cyl");
  const json& p = s["stages"][0]["packing"];
  const json gen = generator_params(scene);
  INFO("packing report: " << p.dump());
  // FIRE stops once the largest overlap / smaller radius is at most max_overlap (1e-3); the report
  // recomputes it from the final positions (1e-9 relative margin for the rounding).
  const double tol = gen["max_overlap"].get<double>() * (1.0 + 1e-9);
  // Inside the die and between the planes: for every particle and wall, (r - d)/r <= tol, with d
  // the distance of the centre from the wall (negative outside), so no centre is outside.
  CHECK(p["max_overlap_ratio_walls"].get<double>() <= tol);
  CHECK(p["max_overlap_ratio"].get<double>() <= tol);
  // Solid volume / container volume: the drawing stops within half the last particle of
  // target_density * V (sample_until_volume), at most pi/12 d_max^3 / V = 0.0043 here; 1 % of
  // the target (0.0065) bounds it.
  const double target = gen["target_density"].get<double>();
  CHECK(std::abs(p["solid_volume"].get<double>() / p["container_volume"].get<double>() - target) <= 0.01 * target);
  CHECK(p["container_volume"].get<double>() == Approx(3.14159265358979 * 22e-6 * 22e-6 * 40e-6).epsilon(1e-9));
  // The radii are the drawn ones: KS distance below the 1 % critical value 1.63/sqrt(n), plus
  // 1/n for the last draw that the volume criterion keeps or drops.
  const double n = p["particles"].get<double>();
  CHECK(n >= 300);
  CHECK(p["psd_ks_distance"].get<double>() <= 1.63 / std::sqrt(n) + 1.0 / n);
  CHECK(p["diameter_max"].get<double>() <= 1e-5);
  CHECK(p["diameter_min"].get<double>() >= 1.5e-6);
}

TEST_CASE("relax reaches an interior target: the solid fraction 4 mean diameters in, the overall fraction following", "[generators]") {
  // Seed 001's pin (r_d = 1 mm, l_d = 5 mm, radii r(1 +- 0.125)) at 3000 particles: packed at the
  // overall 0.63 its interior is denser (the loose wall layer); with interior_target_density the
  // radii are rescaled and relaxed until the interior is the target, and the overall fraction is
  // what that leaves (measured: interior 0.669 at the overall 0.630; the target 0.65 reached in two
  // rescale-and-relax rounds).
  json scene = json::parse(std::ifstream(configs + "resistance_cylinder.json"));
  scene["stages"] = json::array({scene["stages"][0]});
  json& gen = scene["stages"][0]["generator"];
  gen["particles"] = 3000;
  const json overall = run_scene([&] {
    const fs::path f = fs::temp_directory_path() / ("sparkdem_interior_a_" + std::to_string(::getpid()) + ".json");
    std::ofstream(f) << scene.dump();
    return f.string();
  }(), "interior_a")["stages"][0]["packing"];
  gen["interior_target_density"] = 0.65;
  gen["interior_tolerance"] = 0.001;
  const fs::path f = fs::temp_directory_path() / ("sparkdem_interior_b_" + std::to_string(::getpid()) + ".json");
  std::ofstream(f) << scene.dump();
  const json p = run_scene(f.string(), "interior_b")["stages"][0]["packing"];
  fs::remove(f);
  INFO("overall protocol: " << overall.dump() << "\ninterior protocol: " << p.dump());
  CHECK(std::abs(overall["packing_density"].get<double>() - 0.63) <= 1e-3);
  CHECK(overall["density_profile_interior"].get<double>() > 0.65 + 0.003);  // the precondition: a rescale is needed
  CHECK(std::abs(p["density_profile_interior"].get<double>() - 0.65) <= 0.001);
  CHECK(p["interior_rounds"].get<double>() >= 1.0);
  // The overall fraction follows the interior's: lower by the wall layer's deficit.
  CHECK(p["packing_density"].get<double>() < overall["packing_density"].get<double>() - 0.002);
  CHECK(p["solid_volume"].get<double>() / p["container_volume"].get<double>() == Approx(p["packing_density"].get<double>()).epsilon(0.02));
}

TEST_CASE("fill (cooker) reaches its density on a small box", "[generators]") {
  const std::string scene = data + "gen_fill_small.json";
  const json s = run_scene(scene, "fill");
  check_packing(s, generator_params(scene), true, true);
  CHECK(s["stages"][0]["packing"]["growth_scale"].get<double>() == Approx(1.0).margin(1e-12));
}

TEST_CASE("deposit reaches its tap density in a small die", "[generators]") {
  const std::string scene = data + "gen_deposit_small.json";
  const json s = run_scene(scene, "deposit");
  check_packing(s, generator_params(scene), true, true);
  // The sampled size distribution is reported against the requested one (uniform 1-2 mm):
  // KS distance of ~280 samples below 0.15 (the 1 % critical value is 1.63/sqrt(n) = 0.097 for
  // n = 280; 0.15 leaves room for the volume-based truncation of the last draw).
  CHECK(s["stages"][0]["packing"]["psd_ks_distance"].get<double>() <= 0.15);
}

TEST_CASE("shipped fill and relax configs reach their targets", "[generators][slow]") {
  for (const char* name : {"pack_relax_box.json", "pack_fill_cylinder.json"}) {
    const std::string scene = configs + name;
    const json s = run_scene(scene, name);
    CHECK(s["status"].get<std::string>() == "completed");
    const bool fill = std::string(name).find("fill") != std::string::npos;
    check_packing(s, generator_params(scene), fill, fill);
  }
}

}  // namespace test_packing_generators
