#pragma once
// Argument checks shared by the picture and video writers, with messages that name the sizes.
#include <cstdio>
#include <string>

#include "nova/runtime/error.hpp"

namespace nova::detail {

inline std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

inline std::string dims(int width, int height) { return std::to_string(width) + "x" + std::to_string(height); }

// `size` values are a width x height image of `channels` channels.
inline void check_buffer(const char* what, size_t size, int width, int height, int channels) {
  if (width <= 0 || height <= 0)
    throw Error(std::string(what) + ": image size " + dims(width, height) + " is not positive");
  const size_t want = size_t(width) * height * channels;
  if (size != want)
    throw Error(std::string(what) + ": buffer holds " + std::to_string(size) + " values, " +
                dims(width, height) + " x " + std::to_string(channels) + " needs " +
                std::to_string(want));
}

}  // namespace nova::detail
