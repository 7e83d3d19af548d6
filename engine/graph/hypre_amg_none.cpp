// HypreAmgPcg in a build without MPI (SPARKDEM_MPI=OFF): no hypre, so every use of the Amg
// Laplacian method is a SetupError naming the build option.
#include "engine/core/error.hpp"
#include "engine/graph/hypre_amg.hpp"

namespace sparkdem {

namespace {
[[noreturn]] void unavailable() {
  throw SetupError(
      "the Laplacian method 'amg' needs hypre, and this sparkdem was built without MPI (SPARKDEM_MPI=OFF); "
      "use another method or rebuild with -DSPARKDEM_MPI=ON");
}
}  // namespace

void ensure_mpi() { unavailable(); }
void set_amg_spread_ranks(int) {}
int amg_spread_ranks() { return 1; }
void serve_amg_command(const std::string&) { unavailable(); }
void serve_amg_commands_until(int) { unavailable(); }

struct HypreAmgPcg::Impl {};

HypreAmgPcg::HypreAmgPcg() : HypreAmgPcg(Settings{}) {}
HypreAmgPcg::HypreAmgPcg(Settings s) : settings_(s), impl_(std::make_unique<Impl>()) {}
HypreAmgPcg::~HypreAmgPcg() = default;
bool HypreAmgPcg::ready() const { return false; }
int HypreAmgPcg::ranks() const { return 1; }
void HypreAmgPcg::setup(const Eigen::SparseMatrix<double>&) { unavailable(); }
HypreAmgPcg::Outcome HypreAmgPcg::solve(const Eigen::VectorXd&, Eigen::VectorXd&, double, int) { unavailable(); }

}  // namespace sparkdem
