// Running the `prt` executable (PRT_EXE) as a child under conditions a shell
// command cannot set up reliably: a file-size limit standing in for a full
// disk, and Ctrl-C at a chosen moment (when the child prints a marker, not
// after a fixed sleep).
#pragma once

#include "test_files.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <string>
#include <vector>

extern char** environ;

namespace prt::test {

// argv for execve: PRT_EXE and `args`; envp: this process's environment plus
// `env` ("NAME=value"). Built before fork (the child only calls execve).
struct ChildArgs {
  std::vector<std::string> argv_s, env_s;
  std::vector<char*> argv, envp;
  ChildArgs(const std::vector<std::string>& args, const std::vector<std::string>& env) {
    argv_s.push_back(PRT_EXE);
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    for (char** e = environ; *e; ++e) env_s.emplace_back(*e);
    env_s.insert(env_s.end(), env.begin(), env.end());
    for (auto& e : env_s) envp.push_back(e.data());
    envp.push_back(nullptr);
  }
};

inline int exit_code(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return -1;
}

// Runs prt with `args` while every file it writes may grow to at most
// `max_bytes` (RLIMIT_FSIZE, SIGXFSZ ignored): a write past it fails with
// EFBIG ("File too large"), as one on a full disk fails with ENOSPC. Streams
// are captured in dir.io() (small: under the limit).
inline Result run_prt_file_limit(const TempDir& dir, const std::vector<std::string>& args, rlim_t max_bytes) {
  static int counter = 0;
  const std::string out = (dir.io() / ("lout" + std::to_string(counter) + ".txt")).string();
  const std::string err = (dir.io() / ("lerr" + std::to_string(counter) + ".txt")).string();
  ++counter;
  ChildArgs c(args, {});
  const pid_t pid = ::fork();
  if (pid == 0) {
    redirect_child_stdio(out, err);
    ::signal(SIGXFSZ, SIG_IGN);  // ignored stays ignored across execve
    rlimit lim{};
    ::getrlimit(RLIMIT_FSIZE, &lim);
    lim.rlim_cur = max_bytes;
    if (::setrlimit(RLIMIT_FSIZE, &lim) != 0) ::_exit(125);
    ::execve(c.argv[0], c.argv.data(), c.envp.data());
    ::_exit(127);
  }
  Result r;
  int status = 0;
  if (pid > 0 && ::waitpid(pid, &status, 0) == pid) r.code = exit_code(status);
  r.out = read_file(out);
  r.err = read_file(err);
  return r;
}

struct InterruptedResult : Result {
  bool marker_seen = false;  // SIGINT was sent
  bool timed_out = false;    // killed after the timeout (code 124)
};

// Runs prt with `args` (and `env` added to the environment), reading its
// stderr as it comes; when `marker` first appears there, sends the child
// SIGINT, then reads to the end and waits. The whole run is bounded by
// `timeout_s` (SIGKILL, code 124).
inline InterruptedResult run_prt_interrupted(const TempDir& dir, const std::vector<std::string>& args,
                                             const std::string& marker, const std::vector<std::string>& env = {},
                                             double timeout_s = 120) {
  static int counter = 0;
  const std::string out = (dir.io() / ("iout" + std::to_string(counter++) + ".txt")).string();
  ChildArgs c(args, env);
  int fds[2];
  InterruptedResult r;
  if (::pipe2(fds, O_CLOEXEC) != 0) return r;
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int in = ::open("/dev/null", O_RDONLY);
    const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (in < 0 || o < 0 || ::dup2(in, 0) < 0 || ::dup2(o, 1) < 0 || ::dup2(fds[1], 2) < 0) ::_exit(126);
    ::execve(c.argv[0], c.argv.data(), c.envp.data());
    ::_exit(127);
  }
  ::close(fds[1]);
  const auto start = std::chrono::steady_clock::now();
  for (;;) {
    const double left = timeout_s - std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (left <= 0) {
      ::kill(pid, SIGKILL);
      r.timed_out = true;
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    if (::poll(&p, 1, int(left * 1000) + 1) <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // the child closed stderr: it is exiting
    r.err.append(buf, std::size_t(n));
    if (!r.marker_seen && r.err.find(marker) != std::string::npos) {
      r.marker_seen = true;
      ::kill(pid, SIGINT);
    }
  }
  ::close(fds[0]);
  int status = 0;
  if (pid > 0 && ::waitpid(pid, &status, 0) == pid) r.code = r.timed_out ? 124 : exit_code(status);
  r.out = read_file(out);
  return r;
}

// Names in dir.work() that look like write_atomically's temporaries
// (".NAME.tmpPID-N.EXT"), recursively.
inline std::vector<std::string> temporaries(const TempDir& dir) {
  std::vector<std::string> found;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir.work())) {
    const std::string name = e.path().filename().string();
    if (!name.empty() && name[0] == '.' && name.find(".tmp") != std::string::npos) found.push_back(name);
  }
  return found;
}

}  // namespace prt::test
