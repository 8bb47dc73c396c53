#include <prt/mpi.h>

#include <prt/error.h>

#include <cstdlib>
#include <cstring>
#include <vector>

#if PRT_HAVE_MPI
#include <mpi.h>
#endif

namespace prt::mpi {

bool launched() {
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_SIZE"})
    if (const char* s = std::getenv(v); s && *s) return true;
  return false;
}

int local_size() {
  const char* s = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
  const int n = s ? std::atoi(s) : 1;
  return n > 0 ? n : 1;
}

#if PRT_HAVE_MPI

namespace {

// MPI counts are ints: arrays go in rounds of at most kChunk bytes per rank.
constexpr std::size_t kChunk = std::size_t(1) << 30;

class World final : public Communicator {
 public:
  int rank() const override {
    int r = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &r);
    return r;
  }
  int size() const override {
    int n = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &n);
    return n;
  }
  void all_gather(void* data, std::span<const std::size_t> blocks) const override {
    exchange(static_cast<char*>(data) + blocks[std::size_t(rank())], data, blocks, true);
  }
  void gather_to_root(const void* mine, void* all, std::span<const std::size_t> blocks) const override {
    if (rank() == 0 && mine != static_cast<char*>(all) + blocks[0] && blocks[1] > blocks[0])
      std::memmove(static_cast<char*>(all) + blocks[0], mine, blocks[1] - blocks[0]);
    exchange(mine, all, blocks, false);
  }

 private:
  // Rounds of Allgatherv / Gatherv, each moving up to kChunk bytes of every
  // rank's block, in place.
  // `mine`: this rank's part; `data`: the whole array (rank 0, or every
  // rank for all).
  void exchange(const void* mine, void* data, std::span<const std::size_t> blocks, bool all) const {
    const int n = size(), me = rank();
    auto* bytes = static_cast<char*>(data);
    const auto* own = static_cast<const char*>(mine);
    std::vector<int> counts(static_cast<std::size_t>(n)), displs(static_cast<std::size_t>(n));
    for (std::size_t done = 0;; done += kChunk) {
      bool any = false;
      for (int r = 0; r < n; ++r) {
        const std::size_t len = blocks[std::size_t(r) + 1] - blocks[std::size_t(r)];
        const std::size_t part = len > done ? std::min(kChunk, len - done) : 0;
        counts[std::size_t(r)] = int(part);
        any |= part > 0;
      }
      if (!any) break;
      // Displacements are ints too: each round's receive buffer starts at
      // the lowest block start of the round.
      std::size_t base = SIZE_MAX;
      for (int r = 0; r < n; ++r)
        if (counts[std::size_t(r)] > 0) base = std::min(base, blocks[std::size_t(r)] + done);
      bool fits = true;
      for (int r = 0; r < n; ++r) {
        const std::size_t d = counts[std::size_t(r)] > 0 ? blocks[std::size_t(r)] + done - base : 0;
        fits &= d <= std::size_t(INT32_MAX);
        displs[std::size_t(r)] = int(d);
      }
      if (!fits) {  // blocks far apart: one rank's part at a time (Bcast)
        for (int r = 0; r < n; ++r)
          if (counts[std::size_t(r)] > 0) {
            if (all) {
              MPI_Bcast(bytes + blocks[std::size_t(r)] + done, counts[std::size_t(r)], MPI_BYTE, r, MPI_COMM_WORLD);
            } else if (r != 0 && me == r) {
              MPI_Send(own + done, counts[std::size_t(r)], MPI_BYTE, 0, 7, MPI_COMM_WORLD);
            } else if (r != 0 && me == 0) {
              MPI_Recv(bytes + blocks[std::size_t(r)] + done, counts[std::size_t(r)], MPI_BYTE, r, 7, MPI_COMM_WORLD,
                       MPI_STATUS_IGNORE);
            }
          }
        continue;
      }
      char* recv = bytes + base;
      if (all)
        MPI_Allgatherv(MPI_IN_PLACE, 0, MPI_DATATYPE_NULL, recv, counts.data(), displs.data(), MPI_BYTE, MPI_COMM_WORLD);
      else if (me == 0)
        MPI_Gatherv(MPI_IN_PLACE, 0, MPI_BYTE, recv, counts.data(), displs.data(), MPI_BYTE, 0, MPI_COMM_WORLD);
      else
        MPI_Gatherv(own + done, counts[std::size_t(me)], MPI_BYTE, nullptr, nullptr, nullptr, MPI_BYTE, 0,
                    MPI_COMM_WORLD);
    }
  }
};

}  // namespace

bool available() { return true; }

void init(int* argc, char*** argv) {
  int provided = 0;
  if (MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
    throw Error("MPI_Init_thread failed: this process was started by mpirun but could not join the job");
}

void finalize() {
  int done = 0;
  MPI_Finalized(&done);
  if (!done) MPI_Finalize();
}

const Communicator& world() {
  static const World w;
  return w;
}

void abort(int code) {
  MPI_Abort(MPI_COMM_WORLD, code);
  std::_Exit(code);
}

#else

bool available() { return false; }
void init(int*, char***) {
  throw Error("this prt was built without MPI (PRT_MPI; Debian libopenmpi-dev): run it without mpirun");
}
void finalize() {}
const Communicator& world() { return single_process(); }
void abort(int code) { std::_Exit(code); }

#endif

}  // namespace prt::mpi
