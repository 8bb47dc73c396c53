// Replays fuzz inputs without libFuzzer: calls the target's
// LLVMFuzzerTestOneInput on every regular file under each argument (a file,
// or a directory, searched recursively, in sorted order). Built with the
// normal compiler for each target (ctest fuzz_replay.<target>, label unit,
// so also under ASan + UBSan in scripts/test.sh).
//
// Usage: fuzz_replay_<target> PATH...     exit 0 when every input ran, 1 when
//                                         one threw anything (the target
//                                         catches prt::Error itself), 2 on a
//                                         usage error or no inputs; a crash
//                                         names the input on stderr before
//                                         the signal's report.
#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);
extern "C" __attribute__((weak)) int LLVMFuzzerInitialize(int* argc, char*** argv);

namespace {

namespace fs = std::filesystem;

// The input being replayed, for the crash handler (written before each run).
char g_current[4096] = "";
struct sigaction g_previous[32];

void on_crash(int sig, siginfo_t* info, void* context) {
  const char prefix[] = "fuzz_replay: crashed on input ";
  ssize_t ignored = write(2, prefix, sizeof prefix - 1);
  ignored = write(2, g_current, std::strlen(g_current));
  ignored = write(2, "\n", 1);
  (void)ignored;
  // Hand over to whoever handled the signal before (a sanitizer's report), else die of it.
  const struct sigaction& prev = g_previous[sig];
  if ((prev.sa_flags & SA_SIGINFO) && prev.sa_sigaction) {
    prev.sa_sigaction(sig, info, context);
  } else if (!(prev.sa_flags & SA_SIGINFO) && prev.sa_handler != SIG_DFL && prev.sa_handler != SIG_IGN) {
    prev.sa_handler(sig);
  }
  signal(sig, SIG_DFL);
  raise(sig);
}

void install_crash_handler() {
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) {
    struct sigaction sa {};
    sa.sa_sigaction = on_crash;
    sa.sa_flags = SA_SIGINFO | SA_NODEFER;
    sigemptyset(&sa.sa_mask);
    sigaction(sig, &sa, &g_previous[sig]);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s FILE_OR_DIRECTORY...\n", argv[0]);
    return 2;
  }
  if (LLVMFuzzerInitialize) LLVMFuzzerInitialize(&argc, &argv);
  std::vector<fs::path> inputs;
  for (int i = 1; i < argc; ++i) {
    const fs::path p = argv[i];
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      // Names starting with '.' (.gitkeep in an empty crashes/ folder) are not inputs.
      for (const auto& e : fs::recursive_directory_iterator(p))
        if (e.is_regular_file() && e.path().filename().string().front() != '.') inputs.push_back(e.path());
    } else if (fs::is_regular_file(p, ec)) {
      inputs.push_back(p);
    } else {
      std::fprintf(stderr, "fuzz_replay: %s: no such file or directory\n", argv[i]);
      return 2;
    }
  }
  std::sort(inputs.begin(), inputs.end());
  if (inputs.empty()) {
    std::fprintf(stderr, "fuzz_replay: no inputs under the paths given\n");
    return 2;
  }
  install_crash_handler();

  const auto start = std::chrono::steady_clock::now();
  std::size_t bytes = 0;
  for (const fs::path& p : inputs) {
    std::ifstream f(p, std::ios::binary);
    const std::vector<char> data{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
    if (!f.eof() && f.fail()) {
      std::fprintf(stderr, "fuzz_replay: %s: cannot read\n", p.c_str());
      return 2;
    }
    std::snprintf(g_current, sizeof g_current, "%s", p.c_str());
    bytes += data.size();
    try {
      LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(data.data()), data.size());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "fuzz_replay: %s: uncaught exception: %s\n", p.c_str(), e.what());
      return 1;
    } catch (...) {
      std::fprintf(stderr, "fuzz_replay: %s: uncaught exception of unknown type\n", p.c_str());
      return 1;
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("fuzz_replay: %zu inputs (%zu bytes) in %.2f s\n", inputs.size(), bytes, seconds);
  return 0;
}
