// OpenBLAS inside TBB's workers (private to prt::precompute). prt calls BLAS
// from many threads at once, each call on a small matrix: OpenBLAS must be a
// build that locks its buffer pool (Debian's pthread flavour; the serial one
// is built without locking and races, measured: a clustered PCA fit went
// wrong in 5 of 12 runs on 2 threads), and must not start threads of its own
// under TBB's. blas_single_threaded() sets OpenBLAS's thread count to 1, once
// per process, before prt's first BLAS call; every caller of BLAS here calls it.
#pragma once

namespace prt::detail {

void blas_single_threaded();

}  // namespace prt::detail
