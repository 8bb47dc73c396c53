// A headless OpenGL 4.5 core context through EGL (private to runtime/).
//
// Display: eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA) (Mesa,
// llvmpipe included), falling back to the first EGL_PLATFORM_DEVICE_EXT
// device (NVIDIA), then the default display. Context: desktop OpenGL 4.5
// core with no surface (EGL_KHR_surfaceless_context; a config that renders
// OpenGL, or EGL_KHR_no_config_context).
//
// The display is never terminated: EGL has one display per platform and
// device, shared by every context of the process (eglInitialize does not
// count users), and terminating it unloads Mesa's driver, whose remaining
// allocations LeakSanitizer then reports from an unknown module (see the
// git history of runtime/renderer.cpp: terminating it from the last user was
// tried and reverted).
//
// No EGL types here: the handles are kept as the pointers they are.
#pragma once

namespace prt::gl {

class EglContext {
 public:
  EglContext() = default;
  ~EglContext() { destroy(); }
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

  // Initialises a display, creates the context and makes it current; checks
  // it is OpenGL 4.5 or later. Throws prt::NoGlContext("no OpenGL 4.5 context: ...
  // (EGL error 0x...)") naming the displays tried or the step that failed.
  // On failure the display (and context) made so far stay for destroy().
  // `hardware_first` (the GPU tracer): EGL devices that are not software
  // (no EGL_MESA_device_software) are tried before Mesa's surfaceless
  // platform, so a machine with a GPU and Mesa computes on the GPU; else
  // surfaceless first (the renderer: what tests and CI compare against).
  void create(bool hardware_first = false);

  bool has_display() const { return display_ != nullptr; }

  // Makes the context current on the calling thread (no surface). Throws
  // prt::Error("cannot make the OpenGL context current (EGL error 0x...)").
  void make_current() const;
  // The same without throwing: false when there is no context or EGL refuses.
  bool try_make_current() const;
  // Makes no context current on the calling thread.
  void release_current() const;

  // Destroys the context (not the display: see above) and forgets both.
  // Idempotent.
  void destroy();

 private:
  void* display_ = nullptr;  // EGLDisplay (EGL_NO_DISPLAY is null)
  void* context_ = nullptr;  // EGLContext (EGL_NO_CONTEXT is null)
};

}  // namespace prt::gl
