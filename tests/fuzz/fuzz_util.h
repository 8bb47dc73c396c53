// Shared by prt's fuzz targets (tests/fuzz/README.md): a per-process scratch
// file for the readers that take a path, and the rule of what counts as a
// finding.
//
// Every target defines LLVMFuzzerTestOneInput. It is linked either with
// libFuzzer (-DPRT_FUZZ=ON, clang) or with replay_main.cpp (the normal test
// build: ctest fuzz_replay.<target> runs it on every committed input).
//
// A finding is anything but prt::Error: a crash, a sanitizer report, an
// exception of another type (prt::InternalError, std::bad_alloc,
// std::length_error, ...), a broken round trip (finding()), or a hang.
#pragma once

#include <prt/error.h>

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <filesystem>
#include <string>
#include <vector>

namespace prt::fuzz {

// This process's scratch file "prt-fuzz-<pid>-<name>" (name ends with the
// extension the reader dispatches on), under /dev/shm when it is a writable
// directory (no disk writes per iteration), else $TMPDIR, else /tmp. The same
// path on every call with the same name; the file is removed at exit.
inline std::string scratch_path(const std::string& name) {
  namespace fs = std::filesystem;
  std::string dir = "/tmp";
  std::error_code ec;
  if (fs::is_directory("/dev/shm", ec) && access("/dev/shm", W_OK) == 0)
    dir = "/dev/shm";
  else if (const char* t = std::getenv("TMPDIR"); t && *t)
    dir = t;
  const std::string path = dir + "/prt-fuzz-" + std::to_string(getpid()) + "-" + name;
  // Removed at normal exit; a crash leaves it behind (the input is in the
  // crash file anyway).
  struct Remover {
    std::string p;
    ~Remover() {
      std::error_code e;
      std::filesystem::remove(p, e);
    }
  };
  static std::deque<Remover> removers;  // one per name (a deque: growing it moves no Remover, which would delete the file)
  bool known = false;
  for (const Remover& r : removers) known |= r.p == path;
  if (!known) removers.push_back({path});
  return path;
}

// Replaces the file at `path` with `size` bytes at `data`.
inline void write_file(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) {
    std::perror(path.c_str());
    std::abort();  // the harness, not the input: stop rather than fuzz nothing
  }
  if (size && std::fwrite(data, 1, size, f) != size) {
    std::perror(path.c_str());
    std::abort();
  }
  std::fclose(f);
}

// A property the reader broke (not a crash): reported like one.
[[noreturn]] inline void finding(const std::string& what) {
  std::fprintf(stderr, "prt fuzz finding: %s\n", what.c_str());
  std::fflush(stderr);
  std::abort();
}

// Runs f; a prt::Error is the reader refusing bad input as it should.
// Anything else propagates (libFuzzer: "deadly signal" after terminate;
// replay: reported with the input's name).
template <typename F>
void expect_only_prt_errors(F&& f) {
  try {
    f();
  } catch (const prt::Error&) {
  }
}

}  // namespace prt::fuzz
