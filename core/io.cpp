#include <prt/io.h>

#include <prt/error.h>

#include <fmt/format.h>

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace prt {

std::uint64_t check_input_file(const std::string& path, std::string_view kind) {
  if (path.empty()) throw Error("'': not a file name");
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    const int err = errno;
    struct stat link {};
    switch (err) {
      case ENOENT:
        if (::lstat(path.c_str(), &link) == 0 && S_ISLNK(link.st_mode))
          throw Error(path + ": no such file (a symbolic link to a file that does not exist)");
        throw Error(path + ": no such file");
      case ENOTDIR: throw Error(path + ": no such file (a part of the path is not a directory)");
      case ELOOP: throw Error(path + ": too many levels of symbolic links");
      case EACCES: throw Error(path + ": permission denied");
      default: throw Error(path + ": cannot access: " + std::strerror(err));
    }
  }
  if (S_ISDIR(st.st_mode)) throw Error(fmt::format("{}: is a directory, not {}", path, kind));
  if (!S_ISREG(st.st_mode)) {
    const char* what = S_ISFIFO(st.st_mode)   ? "a FIFO (named pipe)"
                       : S_ISCHR(st.st_mode)  ? "a character device"
                       : S_ISBLK(st.st_mode)  ? "a block device"
                       : S_ISSOCK(st.st_mode) ? "a socket"
                                              : "a special file";
    throw Error(fmt::format("{}: is {}, not a regular file", path, what));
  }
  if (::access(path.c_str(), R_OK) != 0) throw Error(path + ": permission denied");
  return static_cast<std::uint64_t>(st.st_size);
}

namespace {

// The StagedWrites this thread's write_atomically calls go to (StagedWrites::Scope).
thread_local StagedWrites* t_staging = nullptr;

}  // namespace

void write_atomically(const std::string& path, const std::function<void(const std::string& tmp)>& write) {
  namespace fs = std::filesystem;
  static std::atomic<unsigned> counter{0};
  fs::path p(path);
  if (p.filename().empty()) throw Error(path + ": not a file name");
  std::error_code ec;
  // A symbolic link is written through: the file it names is replaced, the
  // link stays.
  if (fs::is_symlink(p, ec)) {
    const fs::path target = fs::weakly_canonical(p, ec);
    if (!ec) p = target;
  }
  const fs::file_status st = fs::status(p, ec);
  if (fs::is_directory(st)) throw Error(path + ": is a directory");
  if (fs::exists(st) && !fs::is_regular_file(st)) {
    // A device, FIFO or socket (e.g. /dev/stdout): nothing to replace
    // atomically; renaming over it would destroy it. Write in place.
    write(p.string());
    return;
  }
  // Hidden, unique, and with the same extension (image writers choose the
  // format by extension).
  std::string name = ".";
  name += p.stem().string();
  name += fmt::format(".tmp{}-{}", getpid(), counter++);
  name += p.extension().string();
  const fs::path tmp = p.parent_path() / name;
  try {
    write(tmp.string());
  } catch (...) {
    std::error_code ignored;
    fs::remove(tmp, ignored);
    throw;
  }
  if (t_staging) {
    t_staging->stage(tmp.string(), p.string(), path);
    return;
  }
  fs::rename(tmp, p, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw Error(path + ": cannot write: " + ec.message());
  }
}

StagedWrites::~StagedWrites() { discard(); }

StagedWrites::Scope::Scope(StagedWrites& staged) : previous_(t_staging) { t_staging = &staged; }
StagedWrites::Scope::~Scope() { t_staging = previous_; }

void StagedWrites::stage(const std::string& tmp, const std::string& path, const std::string& shown) {
  std::error_code ec;
  for (auto it = staged_.begin(); it != staged_.end(); ++it)
    if (it->path == path) {  // written again: the new version replaces the staged one
      std::filesystem::remove(it->tmp, ec);
      staged_.erase(it);
      break;
    }
  staged_.push_back({tmp, path, shown, std::filesystem::exists(path, ec)});
}

void StagedWrites::commit() {
  namespace fs = std::filesystem;
  for (std::size_t i = 0; i < staged_.size(); ++i) {
    std::error_code ec;
    fs::rename(staged_[i].tmp, staged_[i].path, ec);
    if (!ec) continue;
    const std::string message = staged_[i].shown + ": cannot write: " + ec.message();
    for (std::size_t j = 0; j < i; ++j)
      if (!staged_[j].existed) fs::remove(staged_[j].path, ec);
    for (std::size_t j = i; j < staged_.size(); ++j) fs::remove(staged_[j].tmp, ec);
    staged_.clear();
    throw Error(message);
  }
  staged_.clear();
}

void StagedWrites::discard() {
  std::error_code ec;
  for (const Entry& e : staged_) std::filesystem::remove(e.tmp, ec);
  staged_.clear();
}

bool same_file(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  if (a.empty() || b.empty()) return false;
  std::error_code ea, eb;
  const bool both = fs::exists(a, ea) && fs::exists(b, eb);
  if (both) {
    std::error_code ec;
    const bool same = fs::equivalent(a, b, ec);
    if (!ec) return same;
  }
  // Normalised: through the symbolic links of the part that exists, "." and ".." resolved.
  const auto normal = [](const std::string& p) {
    std::error_code ec;
    fs::path abs = fs::absolute(p, ec);
    if (ec) abs = fs::path(p);
    fs::path canon = fs::weakly_canonical(abs, ec);
    return (ec ? abs : canon).lexically_normal();
  };
  return normal(a) == normal(b);
}

void check_writable(const std::string& path) {
  namespace fs = std::filesystem;
  const fs::path p(path);
  if (path.empty() || p.filename().empty()) throw Error("'" + path + "': not a file name");
  const fs::path dir = p.parent_path().empty() ? fs::path(".") : p.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(path + ": directory " + dir.string() + " does not exist");
  if (access(dir.c_str(), W_OK) != 0) throw Error(path + ": directory " + dir.string() + " is not writable");
  if (fs::is_directory(p, ec)) throw Error(path + ": is a directory");
}

void write_text_file(const std::string& path, const std::string& text) {
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw Error(path + ": cannot open for writing: " + std::strerror(errno));
    f << text;
    f.close();
    if (!f) throw Error(path + ": write failed: " + std::strerror(errno));
  });
}

}  // namespace prt
