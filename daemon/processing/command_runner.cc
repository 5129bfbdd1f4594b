// SPDX-License-Identifier: GPL-3.0-or-later
#include "daemon/processing/command_runner.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <optional>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "absl/time/clock.h"
#include "processing/base/input_limits.h"
#include "processing/base/status_macros.h"

extern char** environ;

namespace hdrstereo::process {
namespace {

int DecodeWaitStatus(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

std::vector<char*> Pointers(const std::vector<std::string>& strings) {
  std::vector<char*> pointers;
  for (const std::string& s : strings) {
    pointers.push_back(const_cast<char*>(s.c_str()));
  }
  pointers.push_back(nullptr);
  return pointers;
}

// This process's environment with `overrides` replacing or adding entries.
std::vector<std::string> Environment(
    const std::vector<std::string>& overrides) {
  std::vector<std::string> out;
  auto name_of = [](const std::string& entry) {
    return entry.substr(0, entry.find('='));
  };
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry = *e;
    if (std::none_of(overrides.begin(), overrides.end(),
                     [&](const std::string& o) {
                       return name_of(o) == name_of(entry);
                     })) {
      out.push_back(entry);
    }
  }
  out.insert(out.end(), overrides.begin(), overrides.end());
  return out;
}

// A pipe whose ends are closed when it goes out of scope (or before, by
// Close), so that no path out of RunCommand leaks one.
struct Pipe {
  int read_end = -1;
  int write_end = -1;

  Pipe() = default;
  Pipe(const Pipe&) = delete;
  Pipe& operator=(const Pipe&) = delete;
  ~Pipe() {
    Close(read_end);
    Close(write_end);
  }
  absl::Status Open() {
    int fds[2];
    if (::pipe2(fds, O_CLOEXEC) != 0) return absl::ErrnoToStatus(errno, "pipe");
    read_end = fds[0];
    write_end = fds[1];
    return absl::OkStatus();
  }
  static void Close(int& fd) {
    if (fd >= 0) ::close(fd);
    fd = -1;
  }
};

// The last `limit` bytes appended and how many came before them. The front
// is dropped only once half a limit has piled up beyond it, so each byte is
// moved at most twice and the text stays under 1.5 * limit + one read.
class Tail {
 public:
  explicit Tail(size_t limit) : limit_(limit) {}
  void Append(const char* data, size_t n) {
    text_.append(data, n);
    if (text_.size() > limit_ && text_.size() - limit_ > limit_ / 2) Trim();
  }
  // The last `limit` bytes into *text, the count of those before into
  // *dropped.
  void Finish(std::string* text, int64_t* dropped) {
    if (text_.size() > limit_) Trim();
    *text = std::move(text_);
    *dropped = dropped_;
  }

 private:
  void Trim() {
    const size_t excess = text_.size() - limit_;
    text_.erase(0, excess);
    dropped_ += static_cast<int64_t>(excess);
  }

  const size_t limit_;
  std::string text_;
  int64_t dropped_ = 0;
};

}  // namespace

absl::StatusOr<CommandResult> RunCommand(const std::vector<std::string>& argv,
                                         const std::vector<std::string>& env,
                                         absl::Duration timeout,
                                         size_t max_output_bytes) {
  if (argv.empty()) return absl::InvalidArgumentError("no command to run");
  Pipe out_pipe, err_pipe;
  RETURN_IF_ERROR(out_pipe.Open());
  RETURN_IF_ERROR(err_pipe.Open());
  posix_spawn_file_actions_t actions;
  int rc = posix_spawn_file_actions_init(&actions);
  if (rc != 0) return absl::ErrnoToStatus(rc, "posix_spawn_file_actions_init");
  rc = posix_spawn_file_actions_adddup2(&actions, out_pipe.write_end,
                                        STDOUT_FILENO);
  if (rc == 0) {
    rc = posix_spawn_file_actions_adddup2(&actions, err_pipe.write_end,
                                          STDERR_FILENO);
  }
  if (rc == 0) {
    rc = posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null",
                                          O_RDONLY, 0);
  }
  pid_t pid = 0;
  // The child starts with default signal handling and nothing blocked,
  // whatever this process set: the daemon blocks the signals it takes with
  // sigwait, and ignores SIGPIPE once a PTP/IP camera is open.
  posix_spawnattr_t attributes;
  if (rc == 0) rc = posix_spawnattr_init(&attributes);
  if (rc == 0) {
    sigset_t defaults, none;
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGPIPE);
    sigemptyset(&none);
    rc = posix_spawnattr_setsigdefault(&attributes, &defaults);
    if (rc == 0) rc = posix_spawnattr_setsigmask(&attributes, &none);
    if (rc == 0) {
      rc = posix_spawnattr_setflags(
          &attributes, POSIX_SPAWN_SETSIGDEF | POSIX_SPAWN_SETSIGMASK);
    }
    if (rc == 0) {
      std::vector<char*> args = Pointers(argv);
      const std::vector<std::string> environment = Environment(env);
      std::vector<char*> envp = Pointers(environment);
      rc = ::posix_spawnp(&pid, args[0], &actions, &attributes, args.data(),
                          envp.data());
    }
    posix_spawnattr_destroy(&attributes);
  }
  posix_spawn_file_actions_destroy(&actions);
  // The child holds its own copies; ours would keep the pipes from ending.
  Pipe::Close(out_pipe.write_end);
  Pipe::Close(err_pipe.write_end);
  if (rc != 0) {
    return absl::ErrnoToStatus(rc, absl::StrCat("cannot run ", argv[0]));
  }

  const absl::Time deadline = absl::Now() + timeout;
  pollfd fds[2] = {{out_pipe.read_end, POLLIN, 0},
                   {err_pipe.read_end, POLLIN, 0}};
  Tail tails[2] = {Tail(max_output_bytes), Tail(max_output_bytes)};
  int open_fds = 2;
  bool timed_out = false;
  int poll_errno = 0;
  while (open_fds > 0) {
    int wait_ms = static_cast<int>(std::max<int64_t>(
        0, absl::ToInt64Milliseconds(deadline - absl::Now())));
    if (wait_ms == 0) {
      timed_out = true;
      break;
    }
    if (::poll(fds, 2, wait_ms) < 0) {
      if (errno == EINTR) continue;  // revents are stale
      poll_errno = errno;
      break;
    }
    for (int i = 0; i < 2; ++i) {
      if (fds[i].fd < 0 || fds[i].revents == 0) continue;
      char buffer[4096];
      ssize_t n = ::read(fds[i].fd, buffer, sizeof buffer);
      if (n > 0) {
        tails[i].Append(buffer, static_cast<size_t>(n));
      } else if (n == 0 || errno != EINTR) {
        fds[i].fd = -1;  // closed with its Pipe
        --open_fds;
      }
    }
  }
  Pipe::Close(out_pipe.read_end);
  Pipe::Close(err_pipe.read_end);
  if (timed_out || poll_errno != 0) ::kill(pid, SIGKILL);
  std::optional<int> code = WaitForExit(pid, absl::Now() + absl::Seconds(10));
  CommandResult result;
  tails[0].Finish(&result.out, &result.out_dropped);
  tails[1].Finish(&result.err, &result.err_dropped);
  if (poll_errno != 0) {
    return absl::ErrnoToStatus(poll_errno,
                               absl::StrCat("waiting for ", argv[0]));
  }
  if (timed_out) {
    return absl::DeadlineExceededError(absl::StrCat(
        argv[0], " did not finish within ", absl::FormatDuration(timeout),
        "; the end of its output: ",
        QuoteInputTail(result.out, kMaxQuotedBytes, result.out_dropped),
        ", of its standard error: ",
        QuoteInputTail(result.err, kMaxQuotedBytes, result.err_dropped)));
  }
  result.exit_code = code.value_or(-1);
  return result;
}

std::optional<int> WaitForExit(pid_t pid, absl::Time deadline) {
  while (true) {
    int status = 0;
    pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid) return DecodeWaitStatus(status);
    if (done < 0 && errno != EINTR) return -1;
    if (absl::Now() >= deadline) return std::nullopt;
    absl::SleepFor(absl::Milliseconds(5));
  }
}

}  // namespace hdrstereo::process
