/// The single checked-in registry table (LAMMPS gran_sub_mod_register.cpp style).
/// How to add a law, module, generator or monitor (docs/ARCHITECTURE.md, "Recipes"):
///   1. write it with a `Params` aggregate and `static ParamSpec<Params> spec()` (and, for a
///      contact law, the Law interface documented in engine/contact/contact_model.hpp);
///   2. add one row below;
///   3. add its tests (closed form or invariant) under tests/.
#include "physics/register_all.hpp"

#include "physics/body/gravity.hpp"
#include "physics/bonds/cohesive_beam.hpp"
#include "physics/bonds/spring_bond.hpp"
#include "physics/bonds/virial_failure.hpp"
#include "physics/contact/hertz_mindlin.hpp"
#include "physics/control/temperature_controller.hpp"
#include "physics/contact/sintering.hpp"
#include "physics/contact/hooke.hpp"
#include "physics/contact/lammps_granular.hpp"
#include "physics/contact/mass_conserving_radii.hpp"
#include "physics/electrical/contact_percolation.hpp"
#include "physics/electrical/electrical_network.hpp"
#include "physics/electrical/ptc_strain.hpp"
#include "physics/electrical/ptc_self_heating.hpp"
#include "physics/mechanics/torsion_test.hpp"
#include "physics/mechanics/tension_test.hpp"
#include "physics/packing/box_density.hpp"
#include "physics/packing/neck_statistics.hpp"
#include "physics/packing/compact.hpp"
#include "physics/packing/cpc_fillers.hpp"
#include "physics/packing/generators.hpp"
#include "physics/thermal/heat_conduction.hpp"
#include "physics/thermal/temperature_history.hpp"

namespace sparkdem::physics {

void register_all(Registry& r) {
  r.contact_law<HertzMindlin>();
  r.contact_law<Sintering>();
  r.contact_law<LinearSpringDashpot>();
  r.contact_law<LammpsHertzTsuji>();
  r.bond_law<SpringBond>();
  r.bond_law<CohesiveBeam>();
  r.module<Gravity>();
  r.module<ViscousDamping>();
  r.module<LocalDamping>();
  r.module<AddForce>();
  r.module<BondVirialFailure>();
  r.module<TensionTest>();
  r.module<ElectricalNetwork>();
  r.module<TemperatureHistory>();
  r.module<MassConservingRadii>();
  r.module<HeatConduction>();
  r.module<TemperatureController>();
  r.module<TorsionTest>();
  r.module<ContactPercolation>();
  r.module<PtcStrain>();
  r.module<PtcSelfHeating>();
  r.generator<LatticeGenerator>();
  r.generator<DepositGenerator>();
  r.generator<FillGenerator>();
  r.generator<RelaxGenerator>();
  r.generator<CpcFillersGenerator>();
  r.monitor<CompactMonitor>();
  r.monitor<BoxDensityMonitor>();
  r.monitor<NeckMonitor>();
}

}  // namespace sparkdem::physics
