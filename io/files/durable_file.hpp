#pragma once
/// Crash-safe file primitives (POSIX): every output of a run goes through these.
///
/// The pattern is always the same: write the complete content under `name.tmp`, fsync it,
/// rename it over `name` (atomic on POSIX file systems) and fsync the directory so the rename
/// itself is durable. A reader therefore sees either the previous complete file or the new
/// complete file, never a partial one, whether the writer is killed (SIGKILL: only data
/// already handed to the kernel survives, and a rename is all or nothing) or the machine
/// loses power (fsync before rename: the new name never points at unwritten blocks).
///
/// RunLog is the run's append-only journal (OUTDIR/run.log): each line goes to the kernel with
/// write(2) on an O_APPEND descriptor as soon as it is logged (one call, unless the kernel takes
/// only part of it), and anything the log reports was done before its line was written. A
/// reader must ignore a last line without its '\n' (a kill or power loss can leave one).
///
/// Every failure throws sparkdem::SetupError naming the file and the system error.
#include <filesystem>
#include <string>
#include <string_view>

namespace sparkdem::io {

/// `file` with ".tmp" appended: the name a file is written under before it is committed.
std::filesystem::path tmp_name(const std::filesystem::path& file);

/// fsync(2) an existing file's data and metadata.
void sync_file(const std::filesystem::path& file);

/// fsync(2) a directory, making the renames and creations inside it durable.
void sync_directory(const std::filesystem::path& dir);

/// Renames `from` to `to` (replacing `to`) and syncs the directory of `to`. `from` must already
/// be synced (see commit_file) and lie in the same directory.
void rename_durably(const std::filesystem::path& from, const std::filesystem::path& to);

/// sync_file(from), then rename_durably(from, to).
void commit_file(const std::filesystem::path& from, const std::filesystem::path& to);

/// Writes `content` to `file` (created or truncated) and syncs it; no rename.
void write_file_synced(const std::filesystem::path& file, std::string_view content);

/// Writes `content` to `tmp_name(file)`, syncs it and renames it to `file` (durably).
void write_file_atomic(const std::filesystem::path& file, std::string_view content);

/// Removes `file` if it exists; throws only if it exists and cannot be removed.
void remove_if_present(const std::filesystem::path& file);

/// Append-only, line-oriented log file (see the header comment). Move-only.
class RunLog {
 public:
  /// Opens (creating if needed) `file` for appending.
  explicit RunLog(const std::filesystem::path& file);
  RunLog(RunLog&& other) noexcept;
  RunLog& operator=(RunLog&&) = delete;
  RunLog(const RunLog&) = delete;
  RunLog& operator=(const RunLog&) = delete;
  ~RunLog();

  /// Appends "[YYYY-MM-DD hh:mm:ss UTC] <text>\n" with one write(2). `text` must not contain
  /// a newline (it is replaced by a space).
  void line(std::string_view text);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  int fd_ = -1;
};

}  // namespace sparkdem::io
