#include <prt/communicator.h>

#include <cstring>

namespace prt {

namespace {

class SingleProcess final : public Communicator {
 public:
  int rank() const override { return 0; }
  int size() const override { return 1; }
  void all_gather(void*, std::span<const std::size_t>) const override {}
  void gather_to_root(const void* mine, void* all, std::span<const std::size_t> blocks) const override {
    if (mine != all && blocks[1] > blocks[0]) std::memmove(all, mine, blocks[1] - blocks[0]);
  }
};

}  // namespace

const Communicator& single_process() {
  static const SingleProcess one;
  return one;
}

}  // namespace prt
