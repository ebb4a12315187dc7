#pragma once
// Just enough of the ZIP format to read NumPy .npz files: the central directory (with Zip64
// sizes), stored and deflated members (inflated by zlib).
#include <map>
#include <string>

namespace nova::io {

// Raw DEFLATE stream -> bytes; `expected_size` is the uncompressed size from the directory.
// Throws nova::Error naming `origin` on a malformed stream.
std::string inflate(const std::string& compressed, size_t expected_size, const std::string& origin);

// Every member of the archive at `path`, by name, uncompressed.
std::map<std::string, std::string> read_zip(const std::string& path);

}  // namespace nova::io
