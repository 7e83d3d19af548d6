#include "io/files/durable_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <system_error>
#include <utility>

#include "engine/core/error.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

[[noreturn]] void fail_errno(const std::string& what, int error) { throw SetupError(what + ": " + std::strerror(error)); }

/// Opens `path` with open(2), retrying on EINTR; throws on failure.
int open_or_throw(const fs::path& path, int flags, const std::string& what, mode_t mode = 0644) {
  for (;;) {
    const int fd = ::open(path.c_str(), flags | O_CLOEXEC, mode);
    if (fd >= 0) return fd;
    if (errno != EINTR) fail_errno(what, errno);
  }
}

/// Writes all of `data` to `fd` (write(2) may write less than asked); throws on failure.
void write_all(int fd, const char* data, std::size_t size, const std::string& what) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail_errno(what, errno);
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
}

void sync_fd(int fd, const fs::path& path) {
  if (::fsync(fd) != 0) {
    const int error = errno;
    ::close(fd);
    fail_errno("cannot sync '" + path.string() + "'", error);
  }
}

/// The directory holding `file` ("." for a bare file name).
fs::path directory_of(const fs::path& file) {
  const fs::path parent = file.parent_path();
  return parent.empty() ? fs::path(".") : parent;
}

}  // namespace

fs::path tmp_name(const fs::path& file) {
  fs::path tmp = file;
  tmp += ".tmp";
  return tmp;
}

void sync_file(const fs::path& file) {
  const int fd = open_or_throw(file, O_RDONLY, "cannot open '" + file.string() + "' to sync it");
  sync_fd(fd, file);
  ::close(fd);
}

void sync_directory(const fs::path& dir) {
  const int fd = open_or_throw(dir, O_RDONLY | O_DIRECTORY, "cannot open directory '" + dir.string() + "' to sync it");
  sync_fd(fd, dir);
  ::close(fd);
}

void rename_durably(const fs::path& from, const fs::path& to) {
  if (std::rename(from.c_str(), to.c_str()) != 0) fail_errno("cannot rename '" + from.string() + "' to '" + to.string() + "'", errno);
  sync_directory(directory_of(to));
}

void commit_file(const fs::path& from, const fs::path& to) {
  sync_file(from);
  rename_durably(from, to);
}

void write_file_synced(const fs::path& file, std::string_view content) {
  const int fd = open_or_throw(file, O_WRONLY | O_CREAT | O_TRUNC, "cannot create '" + file.string() + "'");
  try {
    write_all(fd, content.data(), content.size(), "cannot write '" + file.string() + "'");
  } catch (const SetupError&) {
    ::close(fd);
    std::error_code ec;
    fs::remove(file, ec);
    throw;
  }
  sync_fd(fd, file);
  if (::close(fd) != 0) fail_errno("cannot close '" + file.string() + "'", errno);
}

void write_file_atomic(const fs::path& file, std::string_view content) {
  const fs::path tmp = tmp_name(file);
  write_file_synced(tmp, content);
  rename_durably(tmp, file);
}

void remove_if_present(const fs::path& file) {
  std::error_code ec;
  fs::remove(file, ec);
  if (ec) throw SetupError("cannot remove '" + file.string() + "': " + ec.message());
}

RunLog::RunLog(const fs::path& file)
    : path_(file), fd_(open_or_throw(file, O_WRONLY | O_CREAT | O_APPEND, "cannot open the run log '" + file.string() + "'")) {}

RunLog::RunLog(RunLog&& other) noexcept : path_(std::move(other.path_)), fd_(std::exchange(other.fd_, -1)) {}

RunLog::~RunLog() {
  if (fd_ >= 0) ::close(fd_);
}

void RunLog::line(std::string_view text) {
  if (fd_ < 0) throw SetupError("run log '" + path_.string() + "': the log is closed");
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  gmtime_r(&now, &utc);
  char stamp[40];
  std::strftime(stamp, sizeof stamp, "[%Y-%m-%d %H:%M:%S UTC] ", &utc);
  std::string out = stamp;
  for (const char c : text) out += (c == '\n' || c == '\r') ? ' ' : c;
  out += '\n';
  write_all(fd_, out.data(), out.size(), "cannot write to the run log '" + path_.string() + "'");
}

}  // namespace sparkdem::io
