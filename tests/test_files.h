// Helpers shared by prt's tests that touch the file system: a per-test
// temporary directory, whole-file reads and writes, and running the built
// `prt` executable (PRT_EXE) with its output captured.
#pragma once

#include <prt/envmap.h>

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <ios>
#include <iterator>
#include <string>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

namespace prt::test {

// A fresh directory per test, removed afterwards. Tests put their inputs and
// outputs in work(); captured streams of prt go to io() instead, so a listing
// of work() shows exactly what was written.
class TempDir {
 public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("prt_test_") + info->test_suite_name() + "_" + info->name();
    for (char& c : name)
      if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') c = '_';
    path_ = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(work());
    std::filesystem::create_directories(io());
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string file(const std::string& name) const { return (work() / name).string(); }
  std::filesystem::path work() const { return path_ / "work"; }
  std::filesystem::path io() const { return path_ / "io"; }

  // Sorted names of the entries of work() (to catch leftover temporaries).
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(work())) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

 private:
  std::filesystem::path path_;
};

inline std::string read_file(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

inline void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

inline std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

struct Result {
  int code = -1;  // exit status; 128 + signal when killed
  std::string out, err;
};

// Runs prt with `args`, stdin from /dev/null, capturing both streams in dir.io().
// env: NAME=VALUE pairs added to prt's environment.
inline Result run_prt(const TempDir& dir, const std::vector<std::string>& args,
                      const std::vector<std::pair<std::string, std::string>>& env = {}) {
  static int counter = 0;
  const std::filesystem::path out = dir.io() / ("out" + std::to_string(counter) + ".txt");
  const std::filesystem::path err = dir.io() / ("err" + std::to_string(counter) + ".txt");
  ++counter;
  std::string cmd = env.empty() ? std::string() : std::string("env");
  for (const auto& [name, value] : env) cmd.append(" ").append(shell_quote(name + "=" + value));
  cmd.append(env.empty() ? "" : " ").append(shell_quote(PRT_EXE));
  for (const auto& a : args) cmd.append(" ").append(shell_quote(a));
  cmd.append(" </dev/null >").append(shell_quote(out.string()));
  cmd.append(" 2>").append(shell_quote(err.string()));
  const int status = std::system(cmd.c_str());
  Result r;
  if (status != -1 && WIFEXITED(status))
    r.code = WEXITSTATUS(status);
  else if (status != -1 && WIFSIGNALED(status))
    r.code = 128 + WTERMSIG(status);
  r.out = read_file(out);
  r.err = read_file(err);
  return r;
}

// A run of prt bounded in time, with its peak memory: what run_prt gives,
// plus the child's own peak resident set (wait4's rusage) and wall time.
struct BoundedResult : Result {
  long max_rss_kb = 0;
  double seconds = 0;
  bool timed_out = false;  // killed after the timeout (code is then 124)
};

// In a forked child: stdin from /dev/null, stdout and stderr to the files
// (created or truncated); exits 126 if any of it fails.
inline void redirect_child_stdio(const std::string& out, const std::string& err) {
  const int in = ::open("/dev/null", O_RDONLY);
  const int o = ::open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const int e = ::open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (in < 0 || o < 0 || e < 0 || ::dup2(in, 0) < 0 || ::dup2(o, 1) < 0 || ::dup2(e, 2) < 0) ::_exit(126);
}

// Runs prt with `args` (no shell: fork and exec, stdin from /dev/null, both
// streams captured in dir.io()), killing it after `timeout_s` seconds. For
// inputs that must be refused fast and without allocating (memory bombs) or
// without blocking (FIFOs).
inline BoundedResult run_prt_bounded(const TempDir& dir, const std::vector<std::string>& args,
                                     double timeout_s = 30.0) {
  static int counter = 0;
  const std::filesystem::path out = dir.io() / ("bout" + std::to_string(counter) + ".txt");
  const std::filesystem::path err = dir.io() / ("berr" + std::to_string(counter) + ".txt");
  ++counter;
  std::vector<std::string> argv_s = {PRT_EXE};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& a : argv_s) argv.push_back(a.data());
  argv.push_back(nullptr);
  const auto start = std::chrono::steady_clock::now();
  BoundedResult r;
  const pid_t pid = ::fork();
  if (pid == 0) {
    redirect_child_stdio(out.string(), err.string());
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  if (pid < 0) return r;
  int status = 0;
  struct rusage ru {};
  for (;;) {
    const pid_t done = ::wait4(pid, &status, WNOHANG, &ru);
    if (done == pid) break;
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > timeout_s) {
      ::kill(pid, SIGKILL);
      ::wait4(pid, &status, 0, &ru);
      r.timed_out = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  r.max_rss_kb = ru.ru_maxrss;
  if (r.timed_out)
    r.code = 124;
  else if (WIFEXITED(status))
    r.code = WEXITSTATUS(status);
  else if (WIFSIGNALED(status))
    r.code = 128 + WTERMSIG(status);
  r.out = read_file(out);
  r.err = read_file(err);
  return r;
}

// The most memory a refused input may take: prt's own start-up (~20 MB;
// several times that under AddressSanitizer's shadow memory), far below the
// gigabytes a trusted header would have allocated.
#if defined(__SANITIZE_ADDRESS__)
constexpr long kRefusalRssKb = 400 * 1024;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr long kRefusalRssKb = 400 * 1024;
#else
constexpr long kRefusalRssKb = 100 * 1024;
#endif
#else
constexpr long kRefusalRssKb = 100 * 1024;
#endif

// A run's exit status and the start of both streams, for failure messages.
inline std::string describe_run(const Result& r) {
  return "exit " + std::to_string(r.code) + "\n--- stdout ---\n" + r.out.substr(0, 2000) + "\n--- stderr ---\n" +
         r.err.substr(0, 2000);
}

inline constexpr double kPi = 3.14159265358979323846;

// PRT_REQUIRE_TOOLS (scripts/test.sh sets 1): a test that finds a tool it
// needs (Node, Chromium, the Python module) missing fails instead of skipping.
inline bool tools_required() {
  const char* v = std::getenv("PRT_REQUIRE_TOOLS");
  return v && *v && std::string(v) != "0";
}

// A 64 x 32 lat-long map of constant radiance `value` in `dir` (constant.exr).
inline std::string write_constant_map(const TempDir& dir, float value) {
  const std::string path = dir.file("constant.exr");
  write_image(path, 64, 32, std::vector<float>(64 * 32 * 3, value));
  return path;
}

// RFC 4648 base64 with padding, for data: URIs in hand-made glTF files.
inline std::string base64(const std::vector<std::uint8_t>& bytes) {
  static const char* digits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (std::size_t i = 0; i < bytes.size(); i += 3) {
    const std::uint32_t n = std::uint32_t(bytes[i]) << 16 |
                            (i + 1 < bytes.size() ? std::uint32_t(bytes[i + 1]) << 8 : 0) |
                            (i + 2 < bytes.size() ? std::uint32_t(bytes[i + 2]) : 0);
    out += digits[n >> 18 & 63];
    out += digits[n >> 12 & 63];
    out += i + 1 < bytes.size() ? digits[n >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? digits[n & 63] : '=';
  }
  return out;
}

}  // namespace prt::test
