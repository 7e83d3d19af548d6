#pragma once
/// The sealed checkpoint container: an ordinary HDF5 file whose 512-byte user block carries a
/// header with the length and a checksum of everything after it.
///
/// Why: a checkpoint is an input of later runs (--restart, "from_snapshot"), and the HDF5
/// library can crash, not just fail, on a mangled file. So nothing of a checkpoint is handed to
/// HDF5 before its bytes are known to be exactly the bytes that were written.
///
/// Layout (HDF5 places its superblock at byte 512 when the user block is 512 bytes; h5dump,
/// h5py and ParaView read the file as usual and ignore the user block):
///
///   bytes 0..511   header, ASCII lines then NUL padding to 512 bytes:
///                    "SPARKDEM-CHECKPOINT v1\n"
///                    "payload-bytes NNNNNNNNNNNNNNNNNNNN\n"   20 decimal digits
///                    "fnv1a64 HHHHHHHHHHHHHHHH\n"             16 lower-case hex digits
///   bytes 512..    the HDF5 data ("payload"), payload-bytes long
///
/// The checksum is FNV-1a 64 (offset basis 0xcbf29ce484222325, prime 0x100000001b3), byte by
/// byte over the payload. Each step xors one byte into the state and multiplies by an odd
/// constant, both bijections of the state, so a change of any single byte always changes the
/// checksum; a truncated or extended file is caught by the length; any other damage goes
/// undetected with probability about 2^-64. The header lines are checked character by
/// character, and the padding must be all NUL.
///
/// Writing (seal_checkpoint, used by Hdf5Archive::commit): HDF5 writes `name.tmp` with the
/// user block reserved and closes it; the payload is then read back and hashed, the header is
/// written into the user block, the file is fsynced, renamed to `name` and the directory
/// fsynced. Reading (VerifiedCheckpoint, used by Hdf5Archive::for_reading): the file is opened and
/// verified with plain file I/O, streaming; HDF5 then opens the same open file through
/// /proc/self/fd, or, where /proc is missing, the verified bytes from memory
/// (read_verified_checkpoint). A file renamed over the name or removed in between makes HDF5's
/// open fail cleanly (it resolves the link, which then names a deleted file); a file rewritten in
/// place while it is read is not caught (sparkdem never rewrites a checkpoint in place: it writes a
/// tmp file and renames it).
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

namespace sparkdem::io {

/// Size of the HDF5 user block holding the header.
inline constexpr std::size_t kCheckpointHeaderBytes = 512;
/// First line of the header (without its '\n').
inline constexpr const char* kCheckpointMagic = "SPARKDEM-CHECKPOINT v1";

/// FNV-1a 64 of `bytes`, continuing from `state` (start with the default offset basis).
std::uint64_t fnv1a64(std::span<const unsigned char> bytes, std::uint64_t state = 0xcbf29ce484222325ULL);

/// The 512-byte header for a payload of `payload_bytes` bytes with checksum `checksum`.
std::string checkpoint_header(std::uint64_t payload_bytes, std::uint64_t checksum);

/// Seals a closed HDF5 file created with a 512-byte user block: hashes the payload, writes the
/// header into the user block and fsyncs the file. Throws SetupError.
void seal_checkpoint(const std::filesystem::path& file);

/// The name the previous checkpoint keeps when a new one is written over `file`:
/// "checkpoint.h5" -> "checkpoint.previous.h5" (see keep_previous_checkpoint).
std::filesystem::path previous_checkpoint_name(const std::filesystem::path& file);

/// Before a new checkpoint is written to `file`: the one there (if any) becomes
/// previous_checkpoint_name(file) too (a hard link renamed over the older one), so that the newest
/// two are kept and `file` is never missing: the new checkpoint is renamed over it when complete.
/// Throws SetupError.
void keep_previous_checkpoint(const std::filesystem::path& file);

/// Reads a sealed checkpoint and verifies its header, length and checksum, without any HDF5
/// call. Returns the whole file (header included). Throws SetupError naming the file and what is
/// wrong: does not exist, empty, truncated (shorter than the header or than the header says),
/// not a sparkdem checkpoint, blank header (a tmp file its writer never sealed), unsupported
/// format version, damaged header, longer than the header says, checksum mismatch.
std::vector<unsigned char> read_verified_checkpoint(const std::filesystem::path& file);

/// A sealed checkpoint verified as read_verified_checkpoint does (same errors), streaming the
/// payload through the hash instead of holding it, and kept open. same_file_path() names the
/// verified file itself (/proc/self/fd/N on Linux; see the header comment for what that does and
/// does not rule out).
class VerifiedCheckpoint {
 public:
  explicit VerifiedCheckpoint(const std::filesystem::path& file);
  ~VerifiedCheckpoint();
  VerifiedCheckpoint(const VerifiedCheckpoint&) = delete;
  VerifiedCheckpoint& operator=(const VerifiedCheckpoint&) = delete;
  std::filesystem::path same_file_path() const;

 private:
  int fd_;
};

}  // namespace sparkdem::io
