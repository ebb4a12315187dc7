#pragma once
// Our own .npy reader and writer: little-endian float32/float64 in C order only (what
// poses_bounds.npy and disp/*.npy hold). Anything else is a clear nova::Error naming the
// file: other dtypes, big-endian, Fortran order, a bad header, a truncated file.
#include <cstddef>
#include <string>
#include <vector>

namespace nova {

struct NpyArray {
  std::vector<size_t> shape;
  std::string dtype;           // "<f4" or "<f8", as stored
  std::vector<double> values;  // row-major, converted to double

  size_t size() const { return values.size(); }
};

NpyArray read_npy(const std::string& path);
// Parses an in-memory .npy (e.g. a member of an uncompressed .npz); `origin` names it.
NpyArray parse_npy(const std::string& bytes, const std::string& origin);

// Writes version 1.0 with the header padded to 64 bytes, so equal data gives equal bytes.
void write_npy_f64(const std::string& path, const std::vector<size_t>& shape,
                   const std::vector<double>& values);
void write_npy_f32(const std::string& path, const std::vector<size_t>& shape,
                   const std::vector<float>& values);

}  // namespace nova
