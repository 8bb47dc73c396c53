// prt/communicator.h - the processes of one precomputation (prt::precompute).
//
// compute_transfer and compute_wavelet_transfer split their points into one
// contiguous range per process (rank) and exchange whole arrays between
// passes through a Communicator: all ranks call each operation in the same
// order. prt links no MPI here; an MPI build (PRT_MPI) makes one with
// mpi_communicator() (prt/mpi.h), and a single process uses
// single_process(). docs/PRECOMPUTE.md, "Many processes".
#pragma once

#include <cstddef>
#include <span>
#include <vector>

namespace prt {

class Communicator {
 public:
  virtual ~Communicator() = default;
  virtual int rank() const = 0;
  virtual int size() const = 0;
  // `data` is the whole array on every rank, blocks[r] .. blocks[r + 1]
  // (bytes, blocks.size() == size() + 1) the part rank r computed. After the
  // call every rank holds every part.
  virtual void all_gather(void* data, std::span<const std::size_t> blocks) const = 0;
  // To rank 0 only: `mine` is this rank's part (blocks[r + 1] - blocks[r]
  // bytes), `all` the whole array on rank 0 (unused on the others); after the
  // call rank 0 holds every part there.
  virtual void gather_to_root(const void* mine, void* all, std::span<const std::size_t> blocks) const = 0;
};

// One process: every operation is a no-op.
const Communicator& single_process();

// The first point of rank r's range when `count` points are split over
// `ranks` ranks: r * count / ranks (contiguous, sizes differing by at most 1).
inline std::size_t range_begin(std::size_t count, int r, int ranks) {
  const std::size_t n = std::size_t(ranks), q = count / n, m = count % n;  // r * count / n without overflow
  return std::size_t(r) * q + std::size_t(r) * m / n;
}

// The byte offsets of each rank's part of an array of `count` items of
// `item_bytes` (blocks for all_gather and gather_to_root).
inline std::vector<std::size_t> rank_blocks(std::size_t count, std::size_t item_bytes, const Communicator& comm) {
  std::vector<std::size_t> b(std::size_t(comm.size()) + 1);
  for (int r = 0; r <= comm.size(); ++r) b[std::size_t(r)] = range_begin(count, r, comm.size()) * item_bytes;
  return b;
}

}  // namespace prt
