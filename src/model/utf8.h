// The UTF-8 check that the URDF guards (urdf_guard.cpp) and the scene reader (scene_reader.cpp)
// run over outside text before a parser sees it.
#pragma once

#include <cstddef>
#include <string>

namespace se3 {

/// Offset of the first byte of s that is not valid UTF-8 (overlong forms, surrogates and code
/// points past U+10FFFF included), or s.size() when all of it is.
std::size_t first_invalid_utf8(const std::string& s);

}  // namespace se3
