// When GL tests skip and when they fail (tests/README.md, "GL tests").
//
// A GL test skips only when no OpenGL 4.5 core context can be had here
// (prt::NoGlContext, or the command line's "no OpenGL 4.5 context" message),
// never on a shader or program error, which fails it like any other error.
// With PRT_REQUIRE_GL=1 (scripts/test.sh sets it: the machines it runs on
// have Mesa's llvmpipe) even that fails the test instead: a broken context
// must not pass as a row of skips.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <string>

namespace prt::test {

inline bool gl_required() {
  const char* v = std::getenv("PRT_REQUIRE_GL");
  return v && *v && std::string(v) != "0";
}

}  // namespace prt::test

// Skips the current test for `why` (no GL context here), or fails it under
// PRT_REQUIRE_GL=1. Use in a test body or SetUp (it returns from either).
#define PRT_SKIP_WITHOUT_GL(why)                                                               \
  do {                                                                                         \
    if (::prt::test::gl_required())                                                            \
      GTEST_FAIL() << "PRT_REQUIRE_GL is set, but there is no OpenGL 4.5 context: " << (why);  \
    GTEST_SKIP() << "headless rendering unavailable: " << (why);                               \
  } while (0)
