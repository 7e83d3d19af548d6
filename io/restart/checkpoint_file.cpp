#include "io/restart/checkpoint_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string_view>

#include "engine/core/error.hpp"
#include "io/files/durable_file.hpp"

namespace sparkdem::io {

namespace fs = std::filesystem;

namespace {

constexpr std::uint64_t kFnvPrime = 0x100000001b3ULL;
constexpr std::string_view kFamily = "SPARKDEM-CHECKPOINT ";  // the magic without its version
constexpr std::string_view kLengthKey = "payload-bytes ";
constexpr std::string_view kChecksumKey = "fnv1a64 ";
constexpr std::size_t kLengthDigits = 20;
constexpr std::size_t kChecksumDigits = 16;
constexpr std::size_t kChunk = std::size_t{1} << 20;

std::string label(const fs::path& file) { return "checkpoint '" + file.string() + "'"; }

[[noreturn]] void fail(const fs::path& file, const std::string& what) { throw SetupError(label(file) + what); }

[[noreturn]] void fail_errno(const fs::path& file, const std::string& what, int error) {
  fail(file, ": " + what + ": " + std::strerror(error));
}

std::string hex64(std::uint64_t x) {
  char buffer[24];
  std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(x));
  return buffer;
}

/// Closes a file descriptor at scope exit.
struct Fd {
  int fd;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

/// Reads exactly `size` bytes at `offset`; returns fewer only at end of file.
std::size_t read_at(int fd, unsigned char* out, std::size_t size, std::uint64_t offset, const fs::path& file) {
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::pread(fd, out + done, size - done, static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      fail_errno(file, "cannot read it", errno);
    }
    if (n == 0) break;
    done += static_cast<std::size_t>(n);
  }
  return done;
}

/// Parses `digits` characters of `text` at `pos` in base 10 or 16; false on a bad character or
/// overflow.
bool parse_number(std::string_view text, std::size_t pos, std::size_t digits, int base, std::uint64_t& out) {
  if (pos + digits > text.size()) return false;
  std::uint64_t value = 0;
  for (std::size_t k = pos; k < pos + digits; ++k) {
    const char c = text[k];
    unsigned d;
    if (c >= '0' && c <= '9')
      d = static_cast<unsigned>(c - '0');
    else if (base == 16 && c >= 'a' && c <= 'f')
      d = static_cast<unsigned>(c - 'a' + 10);
    else
      return false;
    if (value > (UINT64_MAX - d) / static_cast<std::uint64_t>(base)) return false;
    value = value * static_cast<std::uint64_t>(base) + d;
  }
  out = value;
  return true;
}

/// Checks the header's first line; throws unless it is the v1 magic. `header` may be shorter than
/// the full header (a truncated file).
void check_magic(std::string_view header, const fs::path& file) {
  if (std::all_of(header.begin(), header.end(), [](char c) { return c == '\0'; }))
    fail(file,
         " is incomplete: its header is blank, so it was never sealed (the writer stopped before "
         "finishing it, e.g. a '.tmp' file left by a killed run)");
  const std::string magic = std::string(kCheckpointMagic) + '\n';
  const std::size_t n = std::min(header.size(), magic.size());
  if (header.substr(0, n) == std::string_view(magic).substr(0, n)) return;
  if (header.size() > kFamily.size() && header.substr(0, kFamily.size()) == kFamily) {
    const std::size_t end = std::min(header.find('\n'), std::size_t{60});
    fail(file, " has the unsupported format '" + std::string(header.substr(0, end)) + "' (this build reads '" + kCheckpointMagic + "')");
  }
  fail(file, " is not a sparkdem checkpoint: it does not start with the '" + std::string(kCheckpointMagic) +
                 "' header (checkpoints written before checksums were introduced cannot be loaded either)");
}

}  // namespace

std::uint64_t fnv1a64(std::span<const unsigned char> bytes, std::uint64_t state) {
  for (const unsigned char b : bytes) {
    state ^= b;
    state *= kFnvPrime;
  }
  return state;
}

std::string checkpoint_header(std::uint64_t payload_bytes, std::uint64_t checksum) {
  char length[32];
  std::snprintf(length, sizeof length, "%020llu", static_cast<unsigned long long>(payload_bytes));
  std::string h = std::string(kCheckpointMagic) + "\n" + std::string(kLengthKey) + length + "\n" + std::string(kChecksumKey) +
                  hex64(checksum) + "\n";
  h.resize(kCheckpointHeaderBytes, '\0');
  return h;
}

void seal_checkpoint(const fs::path& file) {
  Fd f{::open(file.c_str(), O_RDWR | O_CLOEXEC)};
  if (f.fd < 0) fail_errno(file, "cannot open it to seal it", errno);
  struct stat st {};
  if (::fstat(f.fd, &st) != 0) fail_errno(file, "cannot stat it", errno);
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size < kCheckpointHeaderBytes) fail(file, ": cannot seal it: " + std::to_string(size) + " bytes, shorter than the user block");
  std::vector<unsigned char> buffer(kChunk);
  std::uint64_t hash = fnv1a64({});
  for (std::uint64_t offset = kCheckpointHeaderBytes; offset < size;) {
    const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, size - offset));
    const std::size_t got = read_at(f.fd, buffer.data(), want, offset, file);
    if (got != want) fail(file, ": cannot seal it: it shrank while being read");
    hash = fnv1a64(std::span(buffer.data(), got), hash);
    offset += got;
  }
  const std::string header = checkpoint_header(size - kCheckpointHeaderBytes, hash);
  for (std::size_t done = 0; done < header.size();) {
    const ssize_t n = ::pwrite(f.fd, header.data() + done, header.size() - done, static_cast<off_t>(done));
    if (n < 0) {
      if (errno == EINTR) continue;
      fail_errno(file, "cannot write its header", errno);
    }
    done += static_cast<std::size_t>(n);
  }
  if (::fsync(f.fd) != 0) fail_errno(file, "cannot sync it", errno);
  const int fd = f.fd;
  f.fd = -1;
  if (::close(fd) != 0) fail_errno(file, "cannot close it", errno);
}

fs::path previous_checkpoint_name(const fs::path& file) {
  fs::path p = file;
  p.replace_filename(file.stem().string() + ".previous" + file.extension().string());
  return p;
}

void keep_previous_checkpoint(const fs::path& file) {
  std::error_code ec;
  if (!fs::exists(file, ec)) return;
  // A second name for the current checkpoint (a hard link, renamed over the previous one), so
  // that `file` itself stays until the new checkpoint is renamed over it: a kill at any moment
  // leaves `file`. Where the file system has no hard links, the current one is renamed instead.
  const fs::path previous = previous_checkpoint_name(file);
  const fs::path link = tmp_name(previous);
  fs::remove(link, ec);
  if (::link(file.c_str(), link.c_str()) == 0) {
    rename_durably(link, previous);
    // rename() of two names of one file does nothing (POSIX): when `previous` already is `file`
    // (a run killed after this link, before its new checkpoint, then resumed), the link stays.
    fs::remove(link, ec);
  } else {
    rename_durably(file, previous);
  }
}

namespace {

/// Opens `file` and verifies its header, length and checksum, streaming the payload through the
/// hash in chunks (`keep`, when given, receives the whole file). Returns the open descriptor.
int open_and_verify(const fs::path& file, std::vector<unsigned char>* keep) {
  Fd f{::open(file.c_str(), O_RDONLY | O_CLOEXEC)};
  if (f.fd < 0) {
    if (errno == ENOENT) fail(file, " does not exist");
    fail_errno(file, "cannot open it", errno);
  }
  struct stat st {};
  if (::fstat(f.fd, &st) != 0) fail_errno(file, "cannot stat it", errno);
  if (!S_ISREG(st.st_mode)) fail(file, " is not a regular file");
  const auto size = static_cast<std::uint64_t>(st.st_size);
  if (size == 0) fail(file, " is empty (0 bytes): it is not a complete sparkdem checkpoint");

  // The header alone first: a file of the wrong kind is rejected before reading all of it.
  std::string header(static_cast<std::size_t>(std::min<std::uint64_t>(size, kCheckpointHeaderBytes)), '\0');
  const std::size_t got = read_at(f.fd, reinterpret_cast<unsigned char*>(header.data()), header.size(), 0, file);
  if (got != header.size()) fail(file, ": it shrank while being read");
  check_magic(header, file);
  if (size < kCheckpointHeaderBytes)
    fail(file,
         " is truncated: " + std::to_string(size) + " bytes, shorter than its " + std::to_string(kCheckpointHeaderBytes) + "-byte header");

  const std::string magic_line = std::string(kCheckpointMagic) + '\n';
  std::size_t pos = magic_line.size();
  std::uint64_t payload = 0, checksum = 0;
  const auto field = [&](std::string_view key, std::size_t digits, int base, std::uint64_t& out) {
    if (std::string_view(header).substr(pos, key.size()) != key) return false;
    pos += key.size();
    if (!parse_number(header, pos, digits, base, out)) return false;
    pos += digits;
    if (pos >= header.size() || header[pos] != '\n') return false;
    ++pos;
    return true;
  };
  if (!field(kLengthKey, kLengthDigits, 10, payload)) fail(file, " has a damaged header: no valid '" + std::string(kLengthKey) + "' line");
  if (!field(kChecksumKey, kChecksumDigits, 16, checksum))
    fail(file, " has a damaged header: no valid '" + std::string(kChecksumKey) + "' line");
  if (std::any_of(header.begin() + static_cast<std::ptrdiff_t>(pos), header.end(), [](char c) { return c != '\0'; }))
    fail(file, " has a damaged header: its padding is not all zero bytes");

  if (payload > UINT64_MAX - kCheckpointHeaderBytes)
    fail(file, " has a damaged header: impossible payload length " + std::to_string(payload));
  const std::uint64_t expected = kCheckpointHeaderBytes + payload;
  if (size < expected) fail(file, " is truncated: " + std::to_string(size) + " bytes, its header says " + std::to_string(expected));
  if (size > expected) fail(file, " is corrupt: " + std::to_string(size) + " bytes, its header says " + std::to_string(expected));

  std::uint64_t actual = 0xcbf29ce484222325ULL;
  if (keep) {
    keep->resize(static_cast<std::size_t>(size));
    if (read_at(f.fd, keep->data(), keep->size(), 0, file) != keep->size()) fail(file, ": it shrank while being read");
    if (std::memcmp(keep->data(), header.data(), header.size()) != 0) fail(file, ": it changed while being read");
    actual = fnv1a64(std::span(*keep).subspan(kCheckpointHeaderBytes));
  } else {
    std::vector<unsigned char> chunk(static_cast<std::size_t>(std::min<std::uint64_t>(kChunk, payload)));
    for (std::uint64_t offset = kCheckpointHeaderBytes; offset < size;) {
      const std::size_t want = static_cast<std::size_t>(std::min<std::uint64_t>(chunk.size(), size - offset));
      if (read_at(f.fd, chunk.data(), want, offset, file) != want) fail(file, ": it shrank while being read");
      actual = fnv1a64(std::span(chunk).first(want), actual);
      offset += want;
    }
  }
  if (actual != checksum)
    fail(file, " is corrupt: checksum mismatch (FNV-1a 64 of its " + std::to_string(payload) + " data bytes is " + hex64(actual) +
                   ", its header says " + hex64(checksum) + ")");
  const int fd = f.fd;
  f.fd = -1;
  return fd;
}

}  // namespace

std::vector<unsigned char> read_verified_checkpoint(const fs::path& file) {
  std::vector<unsigned char> bytes;
  ::close(open_and_verify(file, &bytes));
  return bytes;
}

VerifiedCheckpoint::VerifiedCheckpoint(const fs::path& file) : fd_(open_and_verify(file, nullptr)) {}

VerifiedCheckpoint::~VerifiedCheckpoint() {
  if (fd_ >= 0) ::close(fd_);
}

fs::path VerifiedCheckpoint::same_file_path() const { return fs::path("/proc/self/fd") / std::to_string(fd_); }

}  // namespace sparkdem::io
