#pragma once
/// The sintering law's NiAl parameters for tests (configs/materials/nial_sintering.json, with the
/// dihedral angle of 150 deg it had before issue 36): a test sets what it varies beside them.
#include "physics/contact/sintering.hpp"

namespace sparkdem::test_support {

inline physics::Sintering::Params nial_sintering() {
  physics::Sintering::Params p;
  p.youngs_modulus = 222e9;
  p.poisson_ratio = 0.31;
  p.surface_energy = 1.8;
  p.dihedral_angle = 2.618;
  p.gb_diffusivity_prefactor = 2.0e-3;
  p.gb_activation_energy = 195000.0;
  p.gb_width = 5e-10;
  p.atomic_volume = 1.203e-29;
  p.sintering_start_temperature = 973.0;
  return p;
}

}  // namespace sparkdem::test_support
