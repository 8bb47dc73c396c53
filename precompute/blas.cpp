// See blas.h.
#include "blas.h"

#include <cblas.h>

#include <mutex>

namespace prt::detail {

void blas_single_threaded() {
  static std::once_flag once;
  std::call_once(once, [] { openblas_set_num_threads(1); });
}

}  // namespace prt::detail
