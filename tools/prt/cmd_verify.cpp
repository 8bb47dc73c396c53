// prt verify: the numerical self-check, as a table.
#include "commands.h"

#include <prt/sh.h>
#include <prt/verify.h>

#include <fmt/core.h>

#include <chrono>

namespace prt::cli {

Run add_verify(CLI::App& app) {
  auto opt = std::make_shared<VerifyOptions>();
  auto verbose = std::make_shared<bool>(false);
  CLI::App* s = app.add_subcommand("verify", "Check prt's SH numerics against exact answers; exit 1 on any failure");
  s->add_option("--bands-max", opt->bands_max,
                "Run the double-precision checks up to this many bands (64: the most prt takes; ~1 min on 2 cores)")
      ->check(int_range(3, sh::kMaxBands))
      ->capture_default_str();
  s->add_flag("-v,--verbose", *verbose, "Also print why each tolerance is what it is");
  auto scale = std::make_shared<double>(1.0);
  s->add_option("--tolerance-scale", *scale,
                "Multiply every tolerance by this before judging (below 1: how much margin each check has)")
      ->check(positive_number())
      ->capture_default_str();
  return [opt, verbose, scale] {
    const auto t0 = std::chrono::steady_clock::now();
    int passed = 0, failed = 0;
    fmt::print("{:<14} {:<88} {:>10} {:>10}  {}\n", "group", "check", "error", "tolerance", "result");
    run_verify(*opt, [&](CheckResult r) {
      r.tolerance *= *scale;
      fmt::print("{:<14} {:<88} {:>10.3g} {:>10.3g}  {}\n", r.group, r.name, r.error, r.tolerance,
                 r.pass() ? "PASS" : "FAIL");
      if (*verbose) fmt::print("{:<14} {}\n", "", "tolerance: " + r.why);
      std::fflush(stdout);
      (r.pass() ? passed : failed)++;
    });
    const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    fmt::print("\nverify: {} passed, {} failed in {:.2f} s\n", passed, failed, secs);
    return failed == 0 ? 0 : 1;
  };
}

}  // namespace prt::cli
