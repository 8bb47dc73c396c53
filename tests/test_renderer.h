// A headless prt::Renderer for GL tests, or the reason none can be had
// (tests/test_gl.h says when a test then skips and when it fails).
#pragma once

#include "test_gl.h"

#include <prt/render.h>

#include <memory>
#include <string>

namespace prt::test {

// A renderer, or the reason no context can be had here. Only a missing
// context is a reason: any other error (a shader that does not build) goes
// up and fails the test.
inline std::unique_ptr<Renderer> try_renderer(std::string& why) {
  try {
    return std::make_unique<Renderer>();
  } catch (const NoGlContext& e) {
    why = e.what();
    return nullptr;
  }
}

}  // namespace prt::test

// Declares `r`, a std::unique_ptr<prt::Renderer>, or skips the test (fails
// it under PRT_REQUIRE_GL=1) when there is no GL context.
#define REQUIRE_RENDERER(r)                                        \
  std::string why_##r;                                             \
  std::unique_ptr<::prt::Renderer> r = ::prt::test::try_renderer(why_##r); \
  if (!r) PRT_SKIP_WITHOUT_GL(why_##r);
