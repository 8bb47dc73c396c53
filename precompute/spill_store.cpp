#include "spill_store.h"

#include <prt/error.h>

#include <fmt/format.h>

#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace prt::detail {

std::size_t resident_bytes() {
  std::ifstream f("/proc/self/statm");
  std::size_t pages = 0, resident = 0;
  if (!(f >> pages >> resident)) return 0;
  return resident * std::size_t(::sysconf(_SC_PAGESIZE));
}

std::size_t machine_memory_bytes() {
  std::size_t total = std::size_t(::sysconf(_SC_PHYS_PAGES)) * std::size_t(::sysconf(_SC_PAGESIZE));
  for (const char* path : {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"}) {
    std::ifstream f(path);
    std::string text;
    if (!(f >> text) || text == "max") continue;
    char* end = nullptr;
    const unsigned long long limit = std::strtoull(text.c_str(), &end, 10);
    if (end && *end == '\0' && limit > 0 && limit < total) total = std::size_t(limit);
  }
  return total;
}

SpillStore::~SpillStore() {
  if (file_) std::fclose(file_);
}

void SpillStore::append(std::vector<std::uint8_t>&& bytes) {
  Block b;
  b.size = bytes.size();
  if (held_ + bytes.size() <= budget_) {
    held_ += bytes.size();
    b.bytes = std::move(bytes);
  } else {
    if (!file_) {
      // An unnamed file: mkstemp, then unlink (nothing is left behind, even
      // when the process is killed).
      const char* dir = std::getenv("TMPDIR");
      std::string pattern = (std::filesystem::path(dir && *dir ? dir : "/tmp") / "prt-spill-XXXXXX").string();
      const int fd = ::mkstemp(pattern.data());
      if (fd < 0)
        throw Error(fmt::format("{}: cannot create the temporary file for the records past --memory-limit: {}",
                                pattern, std::strerror(errno)));
      ::unlink(pattern.c_str());
      file_ = ::fdopen(fd, "w+b");
      if (!file_) throw Error(fmt::format("temporary file: {}", std::strerror(errno)));
    }
    if (!bytes.empty() && std::fwrite(bytes.data(), 1, bytes.size(), file_) != bytes.size())
      throw Error(fmt::format("writing {} bytes past --memory-limit to the temporary file (TMPDIR) failed: {}",
                              bytes.size(), std::strerror(errno)));
    b.offset = file_bytes_;
    b.spilled = true;
    file_bytes_ += bytes.size();
    std::vector<std::uint8_t>().swap(bytes);
  }
  blocks_.push_back(std::move(b));
}

const std::uint8_t* SpillStore::get(std::size_t i, std::vector<std::uint8_t>& buffer) const {
  const Block& b = blocks_[i];
  if (!b.spilled) return b.bytes.data();
  buffer.resize(b.size);
  if (std::fflush(file_) != 0 || std::fseek(file_, long(b.offset), SEEK_SET) != 0 ||
      (b.size && std::fread(buffer.data(), 1, b.size, file_) != b.size))
    throw Error(fmt::format("reading back {} bytes from the temporary file (TMPDIR) failed: {}", b.size,
                            std::strerror(errno)));
  std::fseek(file_, 0, SEEK_END);
  return buffer.data();
}

void SpillStore::release(std::size_t i) {
  Block& b = blocks_[i];
  if (b.spilled) return;
  held_ -= b.bytes.size();
  std::vector<std::uint8_t>().swap(b.bytes);
}

}  // namespace prt::detail
