#pragma once
/// `sparkdem run SCENE -o OUTDIR --resume`: the newest restart point of a run's output directory.
///
/// The candidates are the sealed state files a run leaves in OUTDIR: checkpoint.h5 and
/// checkpoint.previous.h5 (the newest two wall-clock or step checkpoints), final_state.h5 (the
/// end of the last stage completed), checkpoint_before_failure.h5 (the watchdog's last healthy
/// state, written after a physics failure) and snapshots/*.h5. Each is verified as --restart
/// verifies it (length, checksum, then HDF5; io/restart/checkpoint_file.hpp); one that fails is
/// passed over with the reason. The watchdog's scratch copy .healthy_state.h5 is not a candidate:
/// it is written unsealed (for speed), so it cannot be verified.
///
/// The newest is the one furthest along the scenario: by stage, then inside a stage before after
/// it, then (inside a sweep) the finished items and the item it lies in, then the step; a tie
/// goes to the first in the order above.
#include <cstdint>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/scenario/scenario.hpp"

namespace sparkdem::io {

/// --resume found nothing to continue, or a folder that is not this scenario's (exit code 2).
class NothingToResume : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ResumeChoice {
  bool finished = false;              ///< summary.json says the run completed: nothing to run
  std::filesystem::path file;         ///< the restart point taken (empty when finished)
  std::string description;            ///< which point it is and what will be redone, for the user
  std::vector<std::string> passed_over;  ///< candidates refused, each with the reason
};

/// The newest valid restart point of `outdir` for scenario `sc` (see the header comment). Throws
/// NothingToResume when `outdir` does not exist, holds a different scenario (its resolved.json
/// differs from `sc`'s) or holds no valid restart point (the message lists the candidates
/// refused and why).
ResumeChoice find_resume_point(const Scenario& sc, const std::filesystem::path& outdir);

}  // namespace sparkdem::io
