// prt/hash.h - the one hash prt uses: XXH3-64 with seed 0, as in xxHash 0.8.
//
// Every hash prt stores or compares goes through here: Mesh::hash(),
// shading_hash(), the transfer file checksum (docs/FORMAT.md) and the error
// set cache key (prt/accuracy.h). The values are XXH3_64bits() of the bytes
// added, in order: adding in pieces gives the same digest as hashing the
// concatenation in one call.
//
// Failure policy: the only failure is allocating a Hasher's state, which
// throws std::bad_alloc. add() and digest() do not fail.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <type_traits>

namespace prt {

// XXH3-64 (seed 0) of `bytes` bytes at `data` (data may be null when bytes is 0).
std::uint64_t hash64(const void* data, std::size_t bytes);

// Streaming XXH3-64 (seed 0).
class Hasher {
 public:
  Hasher();  // throws std::bad_alloc
  ~Hasher();
  Hasher(const Hasher&) = delete;
  Hasher& operator=(const Hasher&) = delete;

  // Adds `bytes` bytes at `data` (null when bytes is 0).
  Hasher& add(const void* data, std::size_t bytes);
  // Adds the object representation of `value` (sizeof(T) bytes, padding included).
  template <typename T>
  Hasher& add_value(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>, "hash the bytes of trivially copyable values only");
    return add(&value, sizeof value);
  }
  // Adds the elements' bytes, without their count.
  template <typename T>
  Hasher& add_span(std::span<const T> values) {
    static_assert(std::is_trivially_copyable_v<T>, "hash the bytes of trivially copyable values only");
    return add(values.data(), values.size_bytes());
  }
  // The digest of everything added so far; adding may continue.
  std::uint64_t digest() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace prt
