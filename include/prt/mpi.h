// prt/mpi.h - running one precomputation as several processes with Open MPI
// (prt::precompute; docs/PRECOMPUTE.md, "Many processes"). Built in where
// CMake finds MPI (option PRT_MPI, on by default); elsewhere available() is
// false and launched() too. MPI's headers stay out of prt's.
#pragma once

#include <prt/communicator.h>

namespace prt::mpi {

bool available();  // prt was built with MPI
// This process was started by mpirun / mpiexec (Open MPI's or PMIx's
// variables are set), so init() will join the others.
bool launched();
// MPI_Init_thread (MPI_THREAD_FUNNELED: only the calling thread talks to
// MPI); once, before world(). Throws prt::Error when MPI fails to start.
void init(int* argc, char*** argv);
void finalize();  // at a normal exit
// All the processes of the job (MPI_COMM_WORLD).
const Communicator& world();
// The processes of the job on this machine (OMPI_COMM_WORLD_LOCAL_SIZE; 1
// when unknown).
int local_size();
// Ends every process of the job with `code` (MPI_Abort): for a failure on
// one rank while the others may be waiting in an exchange.
[[noreturn]] void abort(int code);

}  // namespace prt::mpi
