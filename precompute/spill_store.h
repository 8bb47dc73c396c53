// precompute/spill_store.h - blocks of records kept in memory up to a budget,
// the rest in a temporary file (internal to prt::precompute;
// docs/PRECOMPUTE.md, "Memory").
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace prt::detail {

// Resident memory of this process now, in bytes (Linux /proc/self/statm; 0
// where it cannot be read).
std::size_t resident_bytes();
// The machine's memory, or the cgroup's limit when lower, in bytes.
std::size_t machine_memory_bytes();

// Byte blocks appended in order and read back by index. A block stays in
// memory while the blocks held stay within `budget` bytes; past it, it is
// written to an unnamed temporary file (created on first use in TMPDIR, or
// /tmp, and gone when the store is) and read back into a buffer of the
// caller's. Not thread-safe: one thread appends and reads.
class SpillStore {
 public:
  explicit SpillStore(std::size_t budget) : budget_(budget) {}
  ~SpillStore();
  SpillStore(const SpillStore&) = delete;
  SpillStore& operator=(const SpillStore&) = delete;

  // Takes the block's bytes (moved from `bytes`).
  void append(std::vector<std::uint8_t>&& bytes);
  std::size_t blocks() const { return blocks_.size(); }
  // Block i: a pointer into memory, or `buffer` filled from the file.
  const std::uint8_t* get(std::size_t i, std::vector<std::uint8_t>& buffer) const;
  void release(std::size_t i);  // frees block i (in memory) once it is no longer needed
  std::size_t held_bytes() const { return held_; }
  std::uint64_t spilled_bytes() const { return file_bytes_; }

 private:
  struct Block {
    std::vector<std::uint8_t> bytes;  // empty when spilled or released
    std::uint64_t offset = 0, size = 0;
    bool spilled = false;
  };
  std::size_t budget_, held_ = 0;
  std::vector<Block> blocks_;
  std::FILE* file_ = nullptr;
  std::uint64_t file_bytes_ = 0;
};

}  // namespace prt::detail
