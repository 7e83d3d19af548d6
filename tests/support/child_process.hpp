#pragma once
/// Runs one fuzz case in a forked child process, so that a crash (signal) or a hang (time limit)
/// of the code under test is observed and classified instead of taking the fuzzer down.
///
/// The child: stdin, stdout and stderr go to /dev/null, its address space is limited (so a huge
/// allocation fails with std::bad_alloc instead of exhausting the machine), alarm() ends it with
/// SIGALRM after the time limit, and a crash handler writes a backtrace (raw frames, symbols of
/// shared libraries) to the message pipe before the default action runs. The case function
/// returns an exit code and may write a message (at most 4 kB) to the pipe.
///
/// Only call this from a process that has not started OpenMP worker threads (a forked child
/// inherits no threads; run the code under test with one thread).
#include <execinfo.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <functional>
#include <string>

namespace sparkdem::test {

/// How a child case ended.
struct ChildResult {
  enum class Kind { Exited, Crashed, TimedOut };
  Kind kind = Kind::Exited;
  int exit_code = -1;  ///< Exited
  int signal = 0;      ///< Crashed: the signal (SIGSEGV, SIGABRT, ...)
  double seconds = 0.0;
  std::string message;  ///< what the child wrote to the pipe (e.g. an exception text or a backtrace)
};

namespace detail {
inline int& message_fd() {
  static int fd = -1;
  return fd;
}
inline void crash_handler(int sig) {
  void* frames[64];
  const int n = ::backtrace(frames, 64);
  char head[64];
  const int len = std::snprintf(head, sizeof head, "signal %d, backtrace:\n", sig);
  if (message_fd() >= 0) {
    if (::write(message_fd(), head, static_cast<std::size_t>(len)) < 0) {}
    ::backtrace_symbols_fd(frames, n, message_fd());
  }
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}
}  // namespace detail

/// Writes `text` (truncated to 4000 bytes) to the message pipe of the current child case.
inline void child_message(const std::string& text) {
  if (detail::message_fd() < 0) return;
  const std::size_t n = std::min<std::size_t>(text.size(), 4000);
  if (::write(detail::message_fd(), text.data(), n) < 0) {}
}

/// Runs `body` in a forked child with a time limit [s] and an address-space limit [bytes]
/// (0: none); returns how it ended.
inline ChildResult run_in_child(const std::function<int()>& body, unsigned time_limit_s, std::size_t address_space_bytes) {
  int pipe_fd[2];
  if (::pipe(pipe_fd) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  std::fflush(nullptr);
  const auto t0 = std::chrono::steady_clock::now();
  const pid_t pid = ::fork();
  if (pid < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid == 0) {
    ::close(pipe_fd[0]);
    detail::message_fd() = pipe_fd[1];
    const int null_fd = ::open("/dev/null", O_RDWR);
    if (null_fd >= 0) {
      ::dup2(null_fd, STDIN_FILENO);
      ::dup2(null_fd, STDOUT_FILENO);
      ::dup2(null_fd, STDERR_FILENO);
    }
    if (address_space_bytes > 0) {
      rlimit lim{static_cast<rlim_t>(address_space_bytes), static_cast<rlim_t>(address_space_bytes)};
      ::setrlimit(RLIMIT_AS, &lim);
    }
    for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) ::signal(sig, detail::crash_handler);
    ::signal(SIGALRM, SIG_DFL);
    ::alarm(time_limit_s);
    int rc = 120;
    try {
      rc = body();
    } catch (...) {
      rc = 121;  // the body is expected to classify its own exceptions
    }
    ::_exit(rc);
  }
  ::close(pipe_fd[1]);
  ChildResult r;
  char buffer[4096];
  for (;;) {
    const ssize_t n = ::read(pipe_fd[0], buffer, sizeof buffer);
    if (n > 0) {
      if (r.message.size() < 16384) r.message.append(buffer, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    break;
  }
  ::close(pipe_fd[0]);
  int status = 0;
  pid_t w;
  do { w = ::waitpid(pid, &status, 0); } while (w < 0 && errno == EINTR);
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (WIFSIGNALED(status)) {
    r.signal = WTERMSIG(status);
    r.kind = r.signal == SIGALRM ? ChildResult::Kind::TimedOut : ChildResult::Kind::Crashed;
  } else {
    r.exit_code = WEXITSTATUS(status);
  }
  return r;
}

}  // namespace sparkdem::test
