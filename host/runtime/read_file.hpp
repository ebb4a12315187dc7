#pragma once
// Whole-file reads for the parsers of every module; the caller names the file and what it is
// for when it cannot be opened, so that the message says which input is missing.
#include <optional>
#include <string>

namespace nova {

// The file's bytes, or nullopt when it cannot be opened.
std::optional<std::string> read_file(const std::string& path);

}  // namespace nova
