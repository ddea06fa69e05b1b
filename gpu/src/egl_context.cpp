#include "gpu/egl_context.hpp"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GLES3/gl31.h>

#include <algorithm>
#include <cstring>
#include <map>
#include <mutex>
#include <string>
#include <vector>

namespace gpu {
namespace {

using terrain::Error;

std::string egl_error_name(EGLint code) {
  switch (code) {
    case EGL_SUCCESS:
      return "EGL_SUCCESS";
    case EGL_NOT_INITIALIZED:
      return "EGL_NOT_INITIALIZED";
    case EGL_BAD_ACCESS:
      return "EGL_BAD_ACCESS";
    case EGL_BAD_ALLOC:
      return "EGL_BAD_ALLOC";
    case EGL_BAD_ATTRIBUTE:
      return "EGL_BAD_ATTRIBUTE";
    case EGL_BAD_CONFIG:
      return "EGL_BAD_CONFIG";
    case EGL_BAD_CONTEXT:
      return "EGL_BAD_CONTEXT";
    case EGL_BAD_CURRENT_SURFACE:
      return "EGL_BAD_CURRENT_SURFACE";
    case EGL_BAD_DISPLAY:
      return "EGL_BAD_DISPLAY";
    case EGL_BAD_MATCH:
      return "EGL_BAD_MATCH";
    case EGL_BAD_NATIVE_PIXMAP:
      return "EGL_BAD_NATIVE_PIXMAP";
    case EGL_BAD_NATIVE_WINDOW:
      return "EGL_BAD_NATIVE_WINDOW";
    case EGL_BAD_PARAMETER:
      return "EGL_BAD_PARAMETER";
    case EGL_BAD_SURFACE:
      return "EGL_BAD_SURFACE";
    case EGL_CONTEXT_LOST:
      return "EGL_CONTEXT_LOST";
    default:
      return "EGL error 0x" + std::to_string(code);
  }
}

Error egl_failure(const std::string& call) {
  return Error{call + " failed: " + egl_error_name(eglGetError()), ""};
}

bool has_extension(const char* list, const char* name) {
  if (list == nullptr) return false;
  const std::size_t n = std::strlen(name);
  for (const char* p = list; (p = std::strstr(p, name)) != nullptr; p += n) {
    const bool starts = p == list || p[-1] == ' ';
    const bool ends = p[n] == '\0' || p[n] == ' ';
    if (starts && ends) return true;
  }
  return false;
}

std::string gl_string(GLenum name) {
  const auto* s = reinterpret_cast<const char*>(glGetString(name));
  return s != nullptr ? s : "?";
}

// eglInitialize and eglTerminate do not count: every context on one device shares one display
// handle, and terminating it for one context would break the others (EGL_BAD_CONTEXT). So the
// users of each display are counted here, and the last one terminates it.
std::mutex display_users_mutex;
std::map<EGLDisplay, int> display_users;

bool initialize_display(EGLDisplay display, EGLint& major, EGLint& minor) {
  const std::lock_guard lock(display_users_mutex);
  if (eglInitialize(display, &major, &minor) != EGL_TRUE) return false;
  ++display_users[display];
  return true;
}

void release_display(EGLDisplay display) {
  const std::lock_guard lock(display_users_mutex);
  auto it = display_users.find(display);
  if (it == display_users.end() || --it->second > 0) return;
  display_users.erase(it);
  eglTerminate(display);
}

}  // namespace

struct EglContext::Handles {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  bool initialized = false;

  // Releases in reverse order of creation; safe on a partly made setup.
  ~Handles() {
    if (display != EGL_NO_DISPLAY) {
      eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (context != EGL_NO_CONTEXT) eglDestroyContext(display, context);
      if (initialized) release_display(display);
    }
    eglReleaseThread();
  }
};

namespace {

using HandlesPtr = std::unique_ptr<EglContext::Handles>;

// Initialises `display` and creates an ES 3.1 context that is current with no surface.
terrain::Status setup(EglContext::Handles& h) {
  EGLint major = 0, minor = 0;
  if (!initialize_display(h.display, major, minor)) return egl_failure("eglInitialize");
  h.initialized = true;
  const char* extensions = eglQueryString(h.display, EGL_EXTENSIONS);
  if (!has_extension(extensions, "EGL_KHR_surfaceless_context")) {
    return Error{"the EGL display lacks EGL_KHR_surfaceless_context (needed without a window)", ""};
  }
  if (eglBindAPI(EGL_OPENGL_ES_API) != EGL_TRUE) return egl_failure("eglBindAPI(OpenGL ES)");
  EGLConfig config = EGL_NO_CONFIG_KHR;
  if (!has_extension(extensions, "EGL_KHR_no_config_context")) {
    // Without no-config contexts any ES3-capable config will do: nothing is ever drawn.
    const EGLint wanted[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_ES3_BIT, EGL_NONE};
    EGLint found = 0;
    if (eglChooseConfig(h.display, wanted, &config, 1, &found) != EGL_TRUE) {
      return egl_failure("eglChooseConfig");
    }
    if (found < 1) return Error{"no EGL config supports OpenGL ES 3", ""};
  }
  const EGLint attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 3, EGL_CONTEXT_MINOR_VERSION, 1,
                               EGL_NONE};
  h.context = eglCreateContext(h.display, config, EGL_NO_CONTEXT, attributes);
  if (h.context == EGL_NO_CONTEXT) return egl_failure("eglCreateContext(OpenGL ES 3.1)");
  if (eglMakeCurrent(h.display, EGL_NO_SURFACE, EGL_NO_SURFACE, h.context) != EGL_TRUE) {
    return egl_failure("eglMakeCurrent");
  }
  return terrain::Ok{};
}

template <class F>
F load(const char* name) {
  return reinterpret_cast<F>(eglGetProcAddress(name));
}

terrain::Result<HandlesPtr> open_device(int index) {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_extension(client, "EGL_EXT_platform_device") ||
      !has_extension(client, "EGL_EXT_device_enumeration")) {
    return Error{"EGL lacks EGL_EXT_platform_device or EGL_EXT_device_enumeration", ""};
  }
  auto query_devices = load<PFNEGLQUERYDEVICESEXTPROC>("eglQueryDevicesEXT");
  auto platform_display = load<PFNEGLGETPLATFORMDISPLAYEXTPROC>("eglGetPlatformDisplayEXT");
  if (query_devices == nullptr || platform_display == nullptr) {
    return Error{"eglQueryDevicesEXT or eglGetPlatformDisplayEXT is missing", ""};
  }
  EGLint count = 0;
  if (query_devices(0, nullptr, &count) != EGL_TRUE) return egl_failure("eglQueryDevicesEXT");
  std::vector<EGLDeviceEXT> devices(static_cast<std::size_t>(count));
  if (count > 0 && query_devices(count, devices.data(), &count) != EGL_TRUE) {
    return egl_failure("eglQueryDevicesEXT");
  }
  if (index >= count) {
    return Error{"EGL device " + std::to_string(index) + " does not exist (" +
                     std::to_string(count) + " device" + (count == 1 ? "" : "s") + " found)",
                 ""};
  }
  std::string failures;
  const int first = index >= 0 ? index : 0;
  const int last = index >= 0 ? index + 1 : count;
  for (int i = first; i < last; ++i) {
    auto h = std::make_unique<EglContext::Handles>();
    h->display =
        platform_display(EGL_PLATFORM_DEVICE_EXT, devices[static_cast<std::size_t>(i)], nullptr);
    if (h->display == EGL_NO_DISPLAY) {
      failures +=
          "; device " + std::to_string(i) + ": " + egl_failure("eglGetPlatformDisplayEXT").message;
      continue;
    }
    terrain::Status s = setup(*h);
    if (s) return h;
    failures += "; device " + std::to_string(i) + ": " + s.error().message;
  }
  if (count == 0) return Error{"no EGL device found", ""};
  return Error{"no EGL device gave an OpenGL ES 3.1 context" + failures, ""};
}

terrain::Result<HandlesPtr> open_surfaceless() {
  const char* client = eglQueryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
  if (!has_extension(client, "EGL_MESA_platform_surfaceless")) {
    return Error{"EGL lacks EGL_MESA_platform_surfaceless", ""};
  }
  auto platform_display = load<PFNEGLGETPLATFORMDISPLAYEXTPROC>("eglGetPlatformDisplayEXT");
  if (platform_display == nullptr) return Error{"eglGetPlatformDisplayEXT is missing", ""};
  auto h = std::make_unique<EglContext::Handles>();
  h->display = platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (h->display == EGL_NO_DISPLAY) return egl_failure("eglGetPlatformDisplayEXT(surfaceless)");
  terrain::Status s = setup(*h);
  if (!s) return s.error();
  return h;
}

}  // namespace

terrain::Result<std::unique_ptr<EglContext>> EglContext::create(const ContextOptions& options) {
  terrain::Result<HandlesPtr> handles = Error{"no EGL platform was tried", ""};
  std::string platform;
  if (options.platform != EglPlatform::surfaceless) {
    handles = open_device(options.device);
    platform = "device";
    // An explicit device index that fails is an error, not a reason to pick something else.
    if (!handles && (options.platform == EglPlatform::device || options.device >= 0)) {
      return Error{handles.error().message, ""};
    }
  }
  if (!handles && options.platform != EglPlatform::device) {
    std::string device_failure = handles.error().message;
    handles = open_surfaceless();
    platform = "surfaceless";
    if (!handles) {
      return Error{"no headless EGL context: " + handles.error().message +
                       (options.platform == EglPlatform::automatic
                            ? " (platform device: " + device_failure + ")"
                            : ""),
                   ""};
    }
  }
  std::unique_ptr<EglContext> out(new EglContext());
  out->handles_ = std::move(handles).value();
  // Compute shaders are ES 3.1; a driver may give a lower version than asked for.
  GLint major = 0, minor = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  glGetIntegerv(GL_MINOR_VERSION, &minor);
  if (major < 3 || (major == 3 && minor < 1)) {
    return Error{"the context is OpenGL ES " + std::to_string(major) + "." + std::to_string(minor) +
                     ", compute shaders need 3.1",
                 ""};
  }
  out->renderer_ = gl_string(GL_RENDERER);
  out->description_ = out->renderer_ + "; " + gl_string(GL_VERSION) + "; " + platform;
  // Released here, made current again by each Scope: any thread may use the context next.
  eglMakeCurrent(out->handles_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  return out;
}

EglContext::~EglContext() = default;

EglContext::Scope::Scope(EglContext& context) : context_(context), lock_(context.mutex_) {
  const EglContext::Handles& h = *context_.handles_;
  if (eglMakeCurrent(h.display, EGL_NO_SURFACE, EGL_NO_SURFACE, h.context) != EGL_TRUE) {
    status_ = egl_failure("eglMakeCurrent");
  }
}

EglContext::Scope::~Scope() {
  const EglContext::Handles& h = *context_.handles_;
  eglMakeCurrent(h.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
}

terrain::Result<unsigned> EglContext::compile_compute(std::string_view source) {
  const GLuint shader = glCreateShader(GL_COMPUTE_SHADER);
  if (shader == 0) return Error{"glCreateShader(GL_COMPUTE_SHADER) failed", ""};
  const char* text = source.data();
  const auto length = static_cast<GLint>(source.size());
  glShaderSource(shader, 1, &text, &length);
  glCompileShader(shader);
  GLint ok = GL_FALSE;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  auto info_log = [](GLuint object, bool is_shader) {
    GLint size = 0;
    if (is_shader) {
      glGetShaderiv(object, GL_INFO_LOG_LENGTH, &size);
    } else {
      glGetProgramiv(object, GL_INFO_LOG_LENGTH, &size);
    }
    std::string log(static_cast<std::size_t>(std::max(size, 1)), '\0');
    GLsizei written = 0;
    if (is_shader) {
      glGetShaderInfoLog(object, size, &written, log.data());
    } else {
      glGetProgramInfoLog(object, size, &written, log.data());
    }
    log.resize(static_cast<std::size_t>(written));
    return log;
  };
  if (ok != GL_TRUE) {
    std::string log = info_log(shader, true);
    glDeleteShader(shader);
    return Error{"compute shader compilation failed: " + log, ""};
  }
  const GLuint program = glCreateProgram();
  glAttachShader(program, shader);
  glLinkProgram(program);
  glDeleteShader(shader);  // flagged; freed with the program
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    std::string log = info_log(program, false);
    glDeleteProgram(program);
    return Error{"compute shader link failed: " + log, ""};
  }
  return static_cast<unsigned>(program);
}

terrain::Status EglContext::check_fragment_shader(std::string_view source) {
  const GLuint shader = glCreateShader(GL_FRAGMENT_SHADER);
  if (shader == 0) return Error{"glCreateShader(GL_FRAGMENT_SHADER) failed", ""};
  const char* text = source.data();
  const auto length = static_cast<GLint>(source.size());
  glShaderSource(shader, 1, &text, &length);
  glCompileShader(shader);
  GLint ok = GL_FALSE;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  GLint size = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &size);
  std::string log(static_cast<std::size_t>(std::max(size, 1)), '\0');
  GLsizei written = 0;
  glGetShaderInfoLog(shader, size, &written, log.data());
  log.resize(static_cast<std::size_t>(written));
  glDeleteShader(shader);
  if (ok != GL_TRUE) return Error{"fragment shader compilation failed: " + log, ""};
  return terrain::Ok{};
}

}  // namespace gpu
