#pragma once
/// # The CPC modules' gap thresholds, relative to the pair's contact distance
///
/// Seed 002 states its contact rule as "within 0.1 % of D"; ptc_strain and ptc_self_heating take
/// every gap threshold of the bonded matrix and of the connection rule (ptc_matrix.hpp) as a
/// fraction of D_ij = R_i + R_j (the filler diameter for equal fillers), so a scene scaled in
/// size keeps its switching strain. The absolute keys they replace [m] are refused by name.
#include <string>

#include "engine/model/param_spec.hpp"

namespace sparkdem::physics::ptc {

/// The message that refuses a retired absolute gap key and names its relative replacement.
inline std::string retired_gap(const std::string& key, const std::string& replacement, const std::string& example) {
  return "the absolute gap [m] was replaced by \"" + replacement + "\", a fraction of the pair's contact distance R_i + R_j (" +
         example + "); give " + replacement + " instead of " + key;
}

/// touch_gap_rel, break_gap_rel, cutoff_gap_rel, min_gap_rel on P, and the refusal of the absolute keys.
template <class P>
void add_relative_gaps(ParamSpec<P>& s) {
  s.add("touch_gap_rel", &P::touch_gap_rel)
      .unit("1")
      .nonnegative()
      .doc("touching contacts: gap <= this x (R_i + R_j) (paper 0.1 % of D: 1e-3); no eigenstrain in them");
  s.add("break_gap_rel", &P::break_gap_rel)
      .unit("1")
      .doc("a contact stops conducting when its gap exceeds max(this x (R_i + R_j), initial gap); 0 = the gap becomes positive");
  s.add("cutoff_gap_rel", &P::cutoff_gap_rel).unit("1").nonnegative().doc("h_max / (R_i + R_j): springs join fillers with gap <= h_max");
  s.add("min_gap_rel", &P::min_gap_rel).unit("1").positive().doc("h_min / (R_i + R_j): spring stiffness E_m A / max(h, h_min)");
  s.retire("touch_tolerance", retired_gap("touch_tolerance", "touch_gap_rel", "0.1 % of D: 1e-3, i.e. the old 2e-3 m at R = 1 m"));
  s.retire("break_gap", retired_gap("break_gap", "break_gap_rel", "the old 2e-3 m at R = 1 m is 1e-3"));
  s.retire("cutoff_gap", retired_gap("cutoff_gap", "cutoff_gap_rel", "the old 1 m at R = 1 m is 0.5"));
  s.retire("min_gap", retired_gap("min_gap", "min_gap_rel", "the old 1e-2 m at R = 1 m is 5e-3"));
}

}  // namespace sparkdem::physics::ptc
