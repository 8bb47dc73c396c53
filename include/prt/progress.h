// prt/progress.h - the progress callback of long computations.
#pragma once

#include <cstddef>
#include <functional>

namespace prt {

// Progress callback: (work done, work total, phase name). Called from one
// thread at a time; return false to cancel (compute_transfer then throws
// prt::Error("cancelled")).
using Progress = std::function<bool(std::size_t done, std::size_t total, const char* phase)>;

}  // namespace prt
