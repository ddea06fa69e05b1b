// The GLSL files of gpu/glsl/, embedded at build time (glsl_sources.cpp.in).
#pragma once

#include <string_view>

namespace gpu::glsl {

std::string_view portable_math();
std::string_view noise();
std::string_view nodes();
std::string_view interpreter();
std::string_view material();
std::string_view lighting();
std::string_view trace();
std::string_view compute_prelude();
std::string_view compute_main();
std::string_view compute_trace_main();

}  // namespace gpu::glsl
