#pragma once
// The blanks around a config.ini key or value (spaces, tabs, a Windows line end).
#include <string>

namespace nova::detail {

inline std::string trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r");
  return s.substr(a, b - a + 1);
}

}  // namespace nova::detail
