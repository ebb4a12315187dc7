#include "runtime/parse_number.hpp"

#include <exception>

namespace nova {
namespace {

template <class T, class Convert>
std::optional<T> parse_whole(const std::string& text, Convert convert) {
  size_t used = 0;
  T v{};
  try {
    v = convert(text, &used);
  } catch (const std::exception&) {  // invalid_argument (no number), out_of_range
    return std::nullopt;
  }
  if (used != text.size()) return std::nullopt;
  return v;
}

}  // namespace

std::optional<double> parse_whole_double(const std::string& text) {
  return parse_whole<double>(text, [](const std::string& s, size_t* used) { return std::stod(s, used); });
}

std::optional<long> parse_whole_long(const std::string& text) {
  return parse_whole<long>(text, [](const std::string& s, size_t* used) { return std::stol(s, used); });
}

std::optional<unsigned long long> parse_whole_unsigned(const std::string& text) {
  return parse_whole<unsigned long long>(text,
                                         [](const std::string& s, size_t* used) { return std::stoull(s, used); });
}

}  // namespace nova
