/// The three bond failure criteria of the cohesive beam on finished tension (or torsion) runs
/// (issue 20, step 2: choose the criterion by how independent of N and packing seed its
/// calibrated strength is).
///
///   bond_criteria PARAMS.json RUN_DIR [RUN_DIR ...]
///
/// PARAMS.json: the cohesive_beam parameters of the runs (configs/materials/cast_iron_beams.json).
/// Each RUN_DIR (or RUN_DIR/out) holds final_state.h5 (the checkpoint at the end of the last stage, the
/// equilibrium `hold` of configs/calibration/cast_iron_tension.json, or an elastic twist of the pin)
/// and summary.json. For each criterion (max_normal, von_mises, tresca:
/// physics/bonds/cohesive_beam.hpp, the engine's own kernel) the largest criterion stress over the
/// intact bonds, and the macroscopic load of the last stage (`tension_stress` [Pa] or
/// `torsion_twist` [rad]). In tension this gives the strength calibration
///   sigma_mu_f = sigma_t * max_bonds(criterion) / sigma_macro
/// of io/scenario/calibrate_beams.hpp, per run; on an elastic twist theta the predicted first
/// break theta sigma_mu_f / max_bonds(criterion) (linear elastic up to it). Also the averaged criterion of bond_virial_failure
/// (physics/bonds/virial_failure.hpp: the mean hydrostatic virial stress of a bond's two elements,
/// packing fraction 0.63; the bond forces recomputed by the engine's bond pass without failure).
/// Prints CSV: run, N, load name, load, and per criterion the largest bond value [Pa]. A criterion whose ratio varies least over N and seeds calibrates a
/// strength that transfers; the ratio is linear in the load, so the equilibrium state suffices.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>

#include "engine/contact/bond_model.hpp"
#include "engine/state/state.hpp"
#include "io/scenario/pipeline.hpp"
#include "physics/bonds/cohesive_beam.hpp"
#include "physics/bonds/virial_failure.hpp"

int main(int argc, char** argv) {
  using namespace sparkdem;
  using nlohmann::json;
  if (argc < 3) {
    std::cerr << "usage: bond_criteria PARAMS.json RUN_DIR [RUN_DIR ...]\n";
    return 2;
  }
  try {
    const json pj = json::parse(std::ifstream(argv[1]));
    physics::CohesiveBeam::Params base;
    base.young_modulus = pj.at("young_modulus").get<double>();
    base.poisson_ratio = pj.at("poisson_ratio").get<double>();
    base.radius_ratio = pj.at("radius_ratio").get<double>();
    const char* names[] = {"max_normal", "von_mises", "tresca"};
    std::printf("run,N,load,load_value,max_normal_Pa,von_mises_Pa,tresca_Pa,virial_hydrostatic_Pa,virial_von_mises_Pa\n");
    for (int a = 2; a < argc; ++a) {
      const std::string dir = argv[a];
      // RUN_DIR/out (a `sparkdem run -o RUN_DIR/out`) or RUN_DIR itself (a calibration iteration).
      const std::string out = std::filesystem::exists(dir + "/out/summary.json") ? dir + "/out" : dir;
      State s;
      io::read_checkpoint(out + "/final_state.h5", s);
      const json summary = json::parse(std::ifstream(out + "/summary.json"));
      const json& fin = summary["stages"].back()["final"];
      const char* load = fin.contains("tension_stress") ? "tension_stress" : "torsion_twist";
      std::printf("%s,%zu,%s,%.9g", dir.c_str(), s.particles.size(), load, fin.at(load).get<double>());
      for (const char* n : names) {
        physics::CohesiveBeam::Params p = base;
        p.failure = n;
        const physics::CohesiveBeam law(p);
        double m = 0.0;
        for (std::size_t r = 0; r < s.bonds.size(); ++r)
          if (!s.bonds.broken(r)) m = std::max(m, law.failure_stress(detail::bond_geometry(s.particles, s.bonds, r), nullptr));
        std::printf(",%.9g", m);
      }
      // Averaged: the bond pass fills the per-row forces (failure none: nothing breaks).
      physics::CohesiveBeam::Params p = base;
      p.failure = "none";
      const BondModelT<physics::CohesiveBeam> model(p);
      (void)model.pass(s.particles, s.bonds, 0.0);
      for (const bool vm : {false, true}) {
        const std::vector<double> c = physics::bond_virial_criterion(s.particles, s.bonds, 0.63, vm);
        std::printf(",%.9g", c.empty() ? 0.0 : *std::max_element(c.begin(), c.end()));
      }
      std::printf("\n");
    }
  } catch (const std::exception& e) {
    std::cerr << "bond_criteria: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
