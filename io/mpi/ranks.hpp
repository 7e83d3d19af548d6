#pragma once
/// The MPI ranks of a run started by a launcher (`mpirun -np N sparkdem run ...`): which rank
/// this process is, and small JSON messages between rank 0 and the others (sweep items, results,
/// the stop signal). Without a launcher, or in a build without MPI (SPARKDEM_MPI=OFF), the run
/// is a single rank and nothing here touches MPI. Waiting never spins: a waiting rank probes for
/// its message and sleeps between probes (Open MPI's blocking receive would busy-poll a core).
#include <optional>
#include <string>

namespace sparkdem::io::ranks {

/// Message tags (10 and 11 are the engine's spread network solves: engine/graph/hypre_amg.hpp).
enum Tag : int { kItem = 1, kResult = 2, kStop = 3 };

struct Message {
  int source = 0;
  int tag = 0;
  std::string text;
};

/// Initialises MPI (thread level MULTIPLE) when the process was started by an MPI launcher;
/// otherwise does nothing. Call once at the start of main. Throws SetupError when the launcher's
/// MPI cannot give the thread level rank 0 needs.
void init(int& argc, char**& argv);
/// Finalises MPI if init started it.
void finalize();
/// This process's rank and the number of ranks (0 and 1 without a launcher).
int rank();
int size();
/// Whether MPI support was built in.
bool built_with_mpi();

/// Sends `text` to rank `dest` with `tag` (blocking until the buffer is reusable).
void send(int dest, Tag tag, const std::string& text);
/// A waiting message with `tag` (any tag when `tag` < 0) from any rank, received; or nothing.
std::optional<Message> poll(int tag);
/// Waits for a message with `tag` (any tag when < 0), probing every `interval_ms` and sleeping
/// in between.
Message wait(int tag, int interval_ms = 5);

}  // namespace sparkdem::io::ranks
