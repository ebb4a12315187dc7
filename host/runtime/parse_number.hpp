#pragma once
// Numbers from option values, config entries and file headers: the whole text must be the
// number (std::stod / std::stol / std::stoull syntax), so that "3x" or "" is rejected rather
// than read as a prefix; the caller words the error, naming the option or file.
#include <optional>
#include <string>

namespace nova {

// nullopt when `text` is not entirely a number or is out of the type's range.
std::optional<double> parse_whole_double(const std::string& text);
std::optional<long> parse_whole_long(const std::string& text);
// As std::stoull: a leading '-' is accepted and wraps; callers that forbid it check.
std::optional<unsigned long long> parse_whole_unsigned(const std::string& text);

}  // namespace nova
