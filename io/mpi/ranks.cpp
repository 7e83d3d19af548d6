#include "io/mpi/ranks.hpp"

#include <chrono>
#include <cstdlib>
#include <thread>

#include "engine/core/error.hpp"

#ifdef SPARKDEM_HAVE_MPI
#include <mpi.h>
#endif

namespace sparkdem::io::ranks {

namespace {
bool g_started = false;  // init() initialised MPI
int g_rank = 0, g_size = 1;

/// Set by Open MPI's, MPICH's and PMIx launchers.
bool launched() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE"})
    if (std::getenv(v)) return true;
  return false;
}
}  // namespace

bool built_with_mpi() {
#ifdef SPARKDEM_HAVE_MPI
  return true;
#else
  return false;
#endif
}

void init(int& argc, char**& argv) {
#ifdef SPARKDEM_HAVE_MPI
  if (!launched()) return;
  int provided = 0;
  if (MPI_Init_thread(&argc, &argv, MPI_THREAD_MULTIPLE, &provided) != MPI_SUCCESS) throw SetupError("MPI_Init_thread failed");
  g_started = true;
  MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
  MPI_Comm_size(MPI_COMM_WORLD, &g_size);
  // Rank 0 runs items on its main thread while a second thread talks to the other ranks.
  if (g_size > 1 && provided < MPI_THREAD_MULTIPLE)
    throw SetupError("MPI provides thread level " + std::to_string(provided) + ", below MPI_THREAD_MULTIPLE (" +
                     std::to_string(MPI_THREAD_MULTIPLE) + ") that runs on several ranks need");
#else
  (void)argc;
  (void)argv;
#endif
}

void finalize() {
#ifdef SPARKDEM_HAVE_MPI
  int done = 0;
  MPI_Finalized(&done);
  if (g_started && !done) MPI_Finalize();
#endif
  g_started = false;
}

int rank() { return g_rank; }
int size() { return g_size; }

void send(int dest, Tag tag, const std::string& text) {
#ifdef SPARKDEM_HAVE_MPI
  if (MPI_Send(text.data(), static_cast<int>(text.size()), MPI_CHAR, dest, tag, MPI_COMM_WORLD) != MPI_SUCCESS)
    throw SetupError("MPI_Send to rank " + std::to_string(dest) + " failed");
#else
  (void)dest;
  (void)tag;
  (void)text;
  throw SetupError("sparkdem was built without MPI (SPARKDEM_MPI=OFF): no message can be sent");
#endif
}

std::optional<Message> poll(int tag) {
#ifdef SPARKDEM_HAVE_MPI
  if (!g_started) return std::nullopt;
  int flag = 0;
  MPI_Status st;
  MPI_Iprobe(MPI_ANY_SOURCE, tag < 0 ? MPI_ANY_TAG : tag, MPI_COMM_WORLD, &flag, &st);
  if (!flag) return std::nullopt;
  int count = 0;
  MPI_Get_count(&st, MPI_CHAR, &count);
  Message m;
  m.source = st.MPI_SOURCE;
  m.tag = st.MPI_TAG;
  m.text.resize(static_cast<std::size_t>(count));
  MPI_Recv(m.text.data(), count, MPI_CHAR, st.MPI_SOURCE, st.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return m;
#else
  (void)tag;
  return std::nullopt;
#endif
}

Message wait(int tag, int interval_ms) {
  if (!g_started) throw SetupError("waiting for a message on a single rank: nothing can arrive");
  for (;;) {
    if (auto m = poll(tag)) return *m;
    std::this_thread::sleep_for(std::chrono::milliseconds(interval_ms));
  }
}

}  // namespace sparkdem::io::ranks
