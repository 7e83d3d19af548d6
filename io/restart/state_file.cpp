#include "io/restart/state_file.hpp"

#include <string>

#include "engine/core/error.hpp"

namespace sparkdem::io {

/// Every particle's material index names one of the scenario's materials (checked once the
/// materials are known: a checkpoint does not store them).
void check_materials(const State& s, const std::filesystem::path& file) {
  if (s.materials.empty()) return;
  for (std::size_t i = 0; i < s.particles.size(); ++i)
    if (static_cast<std::size_t>(s.particles.material[i]) >= s.materials.size())
      throw SetupError("checkpoint '" + file.string() + "': particle " + std::to_string(s.particles.id[i]) + " has material " +
                       std::to_string(s.particles.material[i]) + ", but the scenario has " + std::to_string(s.materials.size()) +
                       " materials");
}

std::pair<std::int64_t, bool> read_state(Hdf5Archive& ar, State& s) {
  s.visit(ar);
  check_materials(s, ar.path());
  std::int64_t flag = 0;
  if (ar.has("pipeline/in_stage")) ar.visit("pipeline/in_stage", flag);
  return {s.stage_index, flag != 0};
}

std::pair<std::int64_t, bool> read_checkpoint(const std::filesystem::path& file, State& s) {
  Hdf5Archive ar = Hdf5Archive::for_reading(file);
  return read_state(ar, s);
}

}  // namespace sparkdem::io
