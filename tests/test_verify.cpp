// The self-check behind `prt verify` passes, and its pass/fail logic is sound.
#include <prt/verify.h>

#include <gtest/gtest.h>

#include <cmath>

namespace prt {
namespace {

TEST(Verify, EveryCheckPassesAt32Bands) {
  int count = 0;
  for (const auto& r : run_verify({})) {
    EXPECT_TRUE(r.pass()) << r.group << ": " << r.name << ": error " << r.error << " > " << r.tolerance;
    EXPECT_FALSE(r.why.empty()) << r.name;
    ++count;
  }
  EXPECT_GE(count, 20);
}

TEST(Verify, FailureIsDetected) {
  CheckResult r{"g", "n", 2.0, 1.0, "why"};
  EXPECT_FALSE(r.pass());
  r.error = std::nan("");
  EXPECT_FALSE(r.pass());  // NaN never passes
  r.error = 1.0;
  EXPECT_TRUE(r.pass());
}

}  // namespace
}  // namespace prt
