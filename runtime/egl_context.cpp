// Headless OpenGL 4.5 core context through EGL. See egl_context.h.
#include "egl_context.h"

#include "gl_util.h"

#include <prt/error.h>
#include <prt/render.h>

#define EGL_EGLEXT_PROTOTYPES 0
#include <EGL/egl.h>
#include <EGL/eglext.h>

#include <string>

namespace prt::gl {

namespace {

std::string egl_error() { return hex(unsigned(eglGetError())); }

[[noreturn]] void egl_fail(const std::string& what) {
  throw NoGlContext("no OpenGL 4.5 context: " + what + " (EGL error " + egl_error() + ")");
}

}  // namespace

void EglContext::create(bool hardware_first) {
  EGLDisplay display = EGL_NO_DISPLAY;
  const char* client_ext = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  std::string tried;
  auto try_init = [&](EGLDisplay d, const char* name) {
    if (d == EGL_NO_DISPLAY) {
      tried += std::string(tried.empty() ? "" : ", ") + name + ": no display (EGL error " + egl_error() + ")";
      return false;
    }
    EGLint major = 0, minor = 0;
    if (!eglInitialize(d, &major, &minor)) {
      tried += std::string(tried.empty() ? "" : ", ") + name + ": eglInitialize failed (EGL error " + egl_error() + ")";
      return false;
    }
    display = d;
    display_ = d;
    return true;
  };
  // 0. With hardware_first: the first EGL device that is no software renderer.
  if (hardware_first && get_platform_display && has_extension(client_ext, "EGL_EXT_platform_device")) {
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto query_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    EGLDeviceEXT devices[8];
    EGLint n = 0;
    if (query_devices && query_devices(8, devices, &n))
      for (EGLint i = 0; i < n && display == EGL_NO_DISPLAY; ++i) {
        const char* dext = query_string ? query_string(devices[i], EGL_EXTENSIONS) : nullptr;
        if (!has_extension(dext, "EGL_MESA_device_software"))
          try_init(get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr), "hardware device");
      }
  }
  // 1. Mesa's surfaceless platform: no X, no Wayland, no DRM device needed.
  if (display == EGL_NO_DISPLAY && get_platform_display && has_extension(client_ext, "EGL_MESA_platform_surfaceless"))
    try_init(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr), "surfaceless");
  // 2. The first EGL device (NVIDIA's headless path).
  if (display == EGL_NO_DISPLAY && get_platform_display && has_extension(client_ext, "EGL_EXT_platform_device")) {
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    EGLDeviceEXT devices[8];
    EGLint n = 0;
    if (query_devices && query_devices(8, devices, &n) && n > 0)
      try_init(get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[0], nullptr), "device");
  }
  // 3. Whatever the default display is.
  if (display == EGL_NO_DISPLAY) try_init(eglGetDisplay(EGL_DEFAULT_DISPLAY), "default display");
  if (display == EGL_NO_DISPLAY) throw NoGlContext("no OpenGL 4.5 context: no usable EGL display; tried " + tried);

  const char* ext = eglQueryString(display, EGL_EXTENSIONS);
  if (!has_extension(ext, "EGL_KHR_surfaceless_context"))
    throw NoGlContext("no OpenGL 4.5 context: the EGL display lacks EGL_KHR_surfaceless_context");
  if (!eglBindAPI(EGL_OPENGL_API)) egl_fail("eglBindAPI(EGL_OPENGL_API)");

  const EGLint config_attribs[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, EGL_PBUFFER_BIT,
                                   EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint configs = 0;
  if (!eglChooseConfig(display, config_attribs, &config, 1, &configs) || configs < 1) {
    if (!has_extension(ext, "EGL_KHR_no_config_context")) egl_fail("no EGL config renders desktop OpenGL");
    config = EGL_NO_CONFIG_KHR;
  }
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  const EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
  if (context == EGL_NO_CONTEXT) egl_fail("eglCreateContext(4.5 core)");
  context_ = context;
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) egl_fail("eglMakeCurrent(no surface)");
  if (version() < 45) {
    const std::string device = device_string();
    throw NoGlContext("no OpenGL 4.5 context: got " + device + " (EGL error " + egl_error() + ")");
  }
}

void EglContext::make_current() const {
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    throw Error("cannot make the OpenGL context current (EGL error " + egl_error() + ")");
}

bool EglContext::try_make_current() const {
  return context_ != EGL_NO_CONTEXT && eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_);
}

void EglContext::release_current() const {
  eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
}

void EglContext::destroy() {
  if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
  // No eglTerminate: the display is shared by every context of the process,
  // and terminating it unloads Mesa's driver, whose remaining allocations
  // LeakSanitizer then reports from an unknown module.
  context_ = EGL_NO_CONTEXT;
  display_ = EGL_NO_DISPLAY;
}

}  // namespace prt::gl
