#include "render/egl_context.hpp"

#include <vector>

#include <epoxy/egl.h>
#include <fmt/format.h>

#include "mca/error.hpp"

namespace mca::render {
namespace {

constexpr const char* kFix =
    "offscreen rendering needs EGL with Mesa (Debian: libegl1 libegl-mesa0 libgl1-mesa-dri, installed by "
    "scripts/setup.sh) or a GPU driver with EGL; run without --render to simulate without pictures";

// A GL 4.5 core context on `dpy` (initialised), or EGL_NO_CONTEXT with `why` set.
EGLContext make_context(EGLDisplay dpy, std::string& why) {
  if (!eglBindAPI(EGL_OPENGL_API)) {
    why = fmt::format("eglBindAPI(EGL_OPENGL_API) failed (0x{:x})", eglGetError());
    return EGL_NO_CONTEXT;
  }
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT,
                                   EGL_RED_SIZE, 8, EGL_GREEN_SIZE, 8, EGL_BLUE_SIZE, 8, EGL_DEPTH_SIZE, 24, EGL_NONE};
  EGLConfig config = nullptr;
  EGLint count = 0;
  if (!eglChooseConfig(dpy, config_attribs, &config, 1, &count) || count < 1) {
    // Surfaceless drawing needs no pbuffer: any OpenGL-capable config will do.
    const EGLint any[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    if (!eglChooseConfig(dpy, any, &config, 1, &count) || count < 1) {
      why = "no EGL config can render with OpenGL";
      return EGL_NO_CONTEXT;
    }
  }
  const EGLint ctx_attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
  EGLContext ctx = eglCreateContext(dpy, config, EGL_NO_CONTEXT, ctx_attribs);
  if (ctx == EGL_NO_CONTEXT) {
    why = fmt::format("eglCreateContext for OpenGL 4.5 core failed (0x{:x})", eglGetError());
    return EGL_NO_CONTEXT;
  }
  if (!eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
    why = fmt::format("eglMakeCurrent without a surface failed (0x{:x})", eglGetError());
    eglDestroyContext(dpy, ctx);
    return EGL_NO_CONTEXT;
  }
  return ctx;
}

}  // namespace

EglContext::EglContext() {
  std::vector<std::string> tried;
  auto attempt = [&](EGLDisplay dpy, const std::string& what) {
    if (dpy == EGL_NO_DISPLAY) {
      tried.push_back(fmt::format("{}: no display (0x{:x})", what, eglGetError()));
      return false;
    }
    EGLint major = 0, minor = 0;
    if (!eglInitialize(dpy, &major, &minor)) {
      tried.push_back(fmt::format("{}: eglInitialize failed (0x{:x})", what, eglGetError()));
      return false;
    }
    std::string why;
    EGLContext ctx = make_context(dpy, why);
    if (ctx == EGL_NO_CONTEXT) {
      tried.push_back(fmt::format("{}: {}", what, why));
      eglTerminate(dpy);
      return false;
    }
    display_ = dpy;
    context_ = ctx;
    source_ = what;
    return true;
  };
  // Client extensions are queried on EGL_NO_DISPLAY; a missing libEGL vendor gives none.
  const bool devices = epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_device_enumeration") &&
                       epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_device");
  if (devices) {
    EGLDeviceEXT list[16];
    EGLint n = 0;
    if (eglQueryDevicesEXT(16, list, &n)) {
      for (EGLint k = 0; k < n; ++k)
        if (attempt(eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, list[k], nullptr), fmt::format("EGL device {}", k)))
          return;
    } else {
      tried.push_back(fmt::format("eglQueryDevicesEXT failed (0x{:x})", eglGetError()));
    }
  } else {
    tried.push_back("no EGL device enumeration (EGL_EXT_device_enumeration)");
  }
  if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
    if (attempt(eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr), "Mesa surfaceless"))
      return;
  } else {
    tried.push_back("no Mesa surfaceless platform (EGL_MESA_platform_surfaceless)");
  }
  std::string list;
  for (const auto& t : tried) list += (list.empty() ? "" : "; ") + t;
  throw Error(fmt::format("cannot create an offscreen OpenGL 4.5 context ({}); {}", list, kFix));
}

EglContext::~EglContext() {
  const auto dpy = static_cast<EGLDisplay>(display_);
  eglMakeCurrent(dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(dpy, static_cast<EGLContext>(context_));
  eglTerminate(dpy);
}

}  // namespace mca::render
