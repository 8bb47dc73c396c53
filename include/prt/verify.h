// prt/verify.h - the numerical self-check behind `prt verify`.
//
// Each check measures one error against an exact answer (closed forms, exact
// quadrature, group identities) and compares it with a named tolerance. The
// same checks run in the test suite.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace prt {

struct CheckResult {
  std::string group;   // "basis", "rotation", "projection", ...
  std::string name;    // what was checked
  double error = 0;    // measured error (the metric is stated in `name`)
  double tolerance = 0;
  std::string why;     // why the tolerance is what it is
  bool pass() const { return error <= tolerance; }  // false for NaN
};

struct VerifyOptions {
  int bands_max = 32;    // double-precision checks run up to this many bands
  int float_bands = 16;  // float paths are checked up to this many bands
};

// Runs every check; calls on_check after each (for progress output).
std::vector<CheckResult> run_verify(const VerifyOptions& opt,
                                    const std::function<void(const CheckResult&)>& on_check = {});

}  // namespace prt
