// The .npy format (NumPy NEP 1): magic "\x93NUMPY", version, header length, a Python dict
// literal {'descr': ..., 'fortran_order': ..., 'shape': (...)}, padding, then raw data.
#include "nova/io/npy.hpp"

#include <bit>
#include <cstring>
#include <fstream>
#include <sstream>

#include "nova/runtime/error.hpp"
#include "runtime/parse_number.hpp"
#include "runtime/read_file.hpp"

namespace nova {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the .npy reader assumes a little-endian host");

[[noreturn]] void fail(const std::string& origin, const std::string& what) {
  throw Error(origin + ": " + what);
}

// The value text after 'key': in the header dict, up to the next top-level ',' or '}'.
std::string dict_value(const std::string& header, const std::string& key,
                       const std::string& origin) {
  const std::string pat = "'" + key + "'";
  auto k = header.find(pat);
  if (k == std::string::npos) fail(origin, "bad .npy header: no '" + key + "' entry");
  auto colon = header.find(':', k + pat.size());
  if (colon == std::string::npos) fail(origin, "bad .npy header near '" + key + "'");
  size_t i = colon + 1;
  while (i < header.size() && header[i] == ' ') ++i;
  size_t j = i;
  int depth = 0;
  for (; j < header.size(); ++j) {
    const char c = header[j];
    if (c == '(') ++depth;
    if (c == ')') --depth;
    if (depth == 0 && (c == ',' || c == '}')) break;
  }
  return header.substr(i, j - i);
}

}  // namespace

NpyArray parse_npy(const std::string& bytes, const std::string& origin) {
  if (bytes.size() < 10 || std::memcmp(bytes.data(), "\x93NUMPY", 6) != 0)
    fail(origin, "not a .npy file (missing the \\x93NUMPY magic)");
  const int major = static_cast<unsigned char>(bytes[6]);
  size_t header_len = 0, offset = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(bytes[8]) |
                 (size_t(static_cast<unsigned char>(bytes[9])) << 8);
    offset = 10;
  } else if (major == 2 || major == 3) {
    if (bytes.size() < 12) fail(origin, "truncated .npy header");
    for (int b = 0; b < 4; ++b)
      header_len |= size_t(static_cast<unsigned char>(bytes[8 + b])) << (8 * b);
    offset = 12;
  } else {
    fail(origin, "unsupported .npy version " + std::to_string(major));
  }
  if (bytes.size() < offset + header_len) fail(origin, "truncated .npy header");
  const std::string header = bytes.substr(offset, header_len);
  offset += header_len;

  NpyArray a;
  std::string descr = dict_value(header, "descr", origin);
  if (descr.size() >= 2 && (descr.front() == '\'' || descr.front() == '"'))
    descr = descr.substr(1, descr.size() - 2);
  a.dtype = descr;
  size_t item = 0;
  if (descr == "<f4")
    item = 4;
  else if (descr == "<f8")
    item = 8;
  else if (descr == ">f4" || descr == ">f8")
    fail(origin, "big-endian dtype '" + descr + "' is not supported (need <f4 or <f8)");
  else
    fail(origin, "dtype '" + descr + "' is not supported (need float32 '<f4' or float64 '<f8')");

  const std::string fortran = dict_value(header, "fortran_order", origin);
  if (fortran == "True") fail(origin, "Fortran-order arrays are not supported (need C order)");
  if (fortran != "False") fail(origin, "bad .npy header: fortran_order is '" + fortran + "'");

  std::string shape = dict_value(header, "shape", origin);
  if (shape.size() < 2 || shape.front() != '(' || shape.back() != ')')
    fail(origin, "bad .npy header: shape is '" + shape + "'");
  shape = shape.substr(1, shape.size() - 2);
  std::stringstream ss(shape);
  std::string dim;
  size_t count = 1;
  while (std::getline(ss, dim, ',')) {
    const auto b = dim.find_first_not_of(' ');
    if (b == std::string::npos) continue;  // the trailing comma of a 1-tuple
    dim = dim.substr(b, dim.find_last_not_of(' ') - b + 1);
    const std::optional<unsigned long long> v = parse_whole_unsigned(dim);
    if (!v) fail(origin, "bad .npy header: shape entry '" + dim + "'");
    a.shape.push_back(static_cast<size_t>(*v));
    count *= static_cast<size_t>(*v);
  }
  const size_t need = count * item;
  if (bytes.size() - offset < need)
    fail(origin, "truncated .npy data: " + std::to_string(bytes.size() - offset) +
                     " bytes, the shape needs " + std::to_string(need));
  a.values.resize(count);
  const char* p = bytes.data() + offset;
  if (item == 4) {
    for (size_t i = 0; i < count; ++i) {
      float f;
      std::memcpy(&f, p + 4 * i, 4);
      a.values[i] = f;
    }
  } else {
    std::memcpy(a.values.data(), p, need);
  }
  return a;
}

NpyArray read_npy(const std::string& path) {
  const std::optional<std::string> bytes = read_file(path);
  if (!bytes) throw Error(path + ": cannot open");
  return parse_npy(*bytes, path);
}

namespace {

void write_npy(const std::string& path, const std::vector<size_t>& shape, const char* descr,
               const void* data, size_t bytes) {
  std::string dict = std::string("{'descr': '") + descr + "', 'fortran_order': False, 'shape': (";
  for (size_t i = 0; i < shape.size(); ++i) dict += std::to_string(shape[i]) + ", ";
  if (shape.size() > 1) dict.resize(dict.size() - 2);
  else if (shape.size() == 1) dict.resize(dict.size() - 1);
  dict += "), }";
  // magic(6) + version(2) + len(2) + dict + padding + '\n' is a multiple of 64.
  const size_t unpadded = 10 + dict.size() + 1;
  dict.append((64 - unpadded % 64) % 64, ' ');
  dict += '\n';
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw Error(path + ": cannot create");
  out.write("\x93NUMPY\x01\x00", 8);
  const unsigned char len[2] = {static_cast<unsigned char>(dict.size() & 0xff),
                                static_cast<unsigned char>(dict.size() >> 8)};
  out.write(reinterpret_cast<const char*>(len), 2);
  out.write(dict.data(), static_cast<std::streamsize>(dict.size()));
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  if (!out) throw Error(path + ": write failed");
}

size_t product(const std::vector<size_t>& shape) {
  size_t n = 1;
  for (size_t s : shape) n *= s;
  return n;
}

}  // namespace

void write_npy_f64(const std::string& path, const std::vector<size_t>& shape,
                   const std::vector<double>& values) {
  if (product(shape) != values.size()) throw Error(path + ": shape does not match the data");
  write_npy(path, shape, "<f8", values.data(), values.size() * 8);
}

void write_npy_f32(const std::string& path, const std::vector<size_t>& shape,
                   const std::vector<float>& values) {
  if (product(shape) != values.size()) throw Error(path + ": shape does not match the data");
  write_npy(path, shape, "<f4", values.data(), values.size() * 4);
}

}  // namespace nova
