// XXH3-64 behind prt/hash.h. xxHash is compiled into this file
// (XXH_INLINE_ALL): nothing links libxxhash, only its header is needed.
#include <prt/hash.h>

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <new>

namespace prt {

struct Hasher::State {
  XXH3_state_t s;  // 64-byte aligned: operator new honours its alignment
};

std::uint64_t hash64(const void* data, std::size_t bytes) { return XXH3_64bits(data, bytes); }

Hasher::Hasher() : state_(new State) {
  // Resetting a state XXH3_64bits_reset can write to cannot fail.
  XXH3_64bits_reset(&state_->s);
}

Hasher::~Hasher() = default;

Hasher& Hasher::add(const void* data, std::size_t bytes) {
  if (bytes > 0) XXH3_64bits_update(&state_->s, data, bytes);
  return *this;
}

std::uint64_t Hasher::digest() const { return XXH3_64bits_digest(&state_->s); }

}  // namespace prt
