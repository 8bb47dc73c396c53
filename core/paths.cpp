// Run-time lookup of prt's plugin and data relative to libprt_core (prt/paths.h).
#include <prt/paths.h>

#include <dlfcn.h>
#include <link.h>
#include <unistd.h>

#include <climits>
#include <cstdlib>
#include <string>
#include <system_error>

// Relative paths between install directories (core/CMakeLists.txt): nothing absolute.
#ifndef PRT_DATA_FROM_LIBDIR
#error "PRT_DATA_FROM_LIBDIR (e.g. \"../share/prt\") must be defined"
#endif
#ifndef PRT_LIB_FROM_BINDIR
#error "PRT_LIB_FROM_BINDIR (e.g. \"../lib\") must be defined"
#endif
#ifndef PRT_LIBDIR
#error "PRT_LIBDIR (e.g. \"lib\") must be defined"
#endif

namespace prt {

namespace {

namespace fs = std::filesystem;

fs::path resolved(const fs::path& p) {
  std::error_code ec;
  fs::path r = fs::weakly_canonical(p, ec);
  return ec ? p.lexically_normal() : r;
}

fs::path exe_path() {
  char buf[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return {};
  buf[n] = 0;
  return fs::path(buf);
}

struct Location {
  fs::path dir;                 // library_dir()
  std::vector<fs::path> dirs;   // library_dirs()
};

const Location& location() {
  static const Location loc = [] {
    Location l;
    Dl_info info{};
    link_map* map = nullptr;
    bool in_executable = true;
    if (dladdr1(reinterpret_cast<const void*>(&library_dir), &info, reinterpret_cast<void**>(&map),
                RTLD_DL_LINKMAP) != 0 &&
        map && map->l_name && map->l_name[0] != '\0') {
      // A shared libprt_core (l_name is empty for the executable itself).
      in_executable = false;
      l.dir = resolved(fs::path(map->l_name)).parent_path();
      l.dirs.push_back(l.dir);
    }
    if (in_executable) {
      const fs::path exe = exe_path();
      if (!exe.empty()) {
        l.dir = resolved(exe).parent_path();
        l.dirs.push_back(resolved(l.dir / PRT_LIB_FROM_BINDIR));
        const fs::path build = resolved(l.dir / PRT_LIBDIR);
        if (build != l.dirs.front()) l.dirs.push_back(build);
      }
    }
    return l;
  }();
  return loc;
}

const char* env(const char* name) {
  const char* v = std::getenv(name);
  return v && *v ? v : nullptr;
}

// <d>/sub for the first d of library_dirs() where <d>/sub/probe (or, with
// no probe, the directory <d>/sub) exists; <library_dirs()[0]>/sub when none has it.
fs::path search(const fs::path& sub, const fs::path& probe) {
  const std::vector<fs::path>& dirs = location().dirs;
  for (const fs::path& d : dirs) {
    std::error_code ec;
    const fs::path p = (d / sub).lexically_normal();
    if (probe.empty() ? fs::is_directory(p, ec) : fs::exists(p / probe, ec)) return p;
  }
  return dirs.empty() ? sub : (dirs.front() / sub).lexically_normal();
}

}  // namespace

fs::path library_dir() { return location().dir; }

std::vector<fs::path> library_dirs() { return location().dirs; }

fs::path plugin_dir() {
  if (const char* dir = env("PRT_PLUGIN_DIR")) return dir;
  return search("prt", "libprt_oiio.so");
}

fs::path data_dir() {
  if (const char* dir = env("PRT_DATA_DIR")) return dir;
  return search(PRT_DATA_FROM_LIBDIR, {});
}

}  // namespace prt
