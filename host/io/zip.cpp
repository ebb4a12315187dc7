// ZIP reading for .npz files (see zip.hpp); deflated members are inflated by zlib.
#include "io/zip.hpp"

#include <zlib.h>

#include <climits>
#include <cstdint>
#include <vector>

#include "nova/runtime/error.hpp"
#include "runtime/read_file.hpp"

namespace nova::io {
namespace {

uint32_t le32(const std::string& s, size_t at) {
  if (at + 4 > s.size()) throw Error("zip: read past the end");
  return uint32_t(uint8_t(s[at])) | uint32_t(uint8_t(s[at + 1])) << 8 |
         uint32_t(uint8_t(s[at + 2])) << 16 | uint32_t(uint8_t(s[at + 3])) << 24;
}
uint16_t le16(const std::string& s, size_t at) {
  if (at + 2 > s.size()) throw Error("zip: read past the end");
  return uint16_t(uint8_t(s[at]) | uint8_t(s[at + 1]) << 8);
}
uint64_t le64(const std::string& s, size_t at) {
  return uint64_t(le32(s, at)) | uint64_t(le32(s, at + 4)) << 32;
}

}  // namespace

std::string inflate(const std::string& in, size_t expected_size, const std::string& origin) {
  if (in.size() > UINT_MAX || expected_size > UINT_MAX)
    throw Error(origin + ": a member of more than 4 GiB is not supported");
  std::string out(expected_size, '\0');
  z_stream z{};
  // Negative window bits: a raw DEFLATE stream, as ZIP stores it (no zlib header).
  if (inflateInit2(&z, -15) != Z_OK) throw Error(origin + ": zlib cannot start inflating", kExitInternal);
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(expected_size);
  const int rc = ::inflate(&z, Z_FINISH);
  const size_t produced = z.total_out;
  const bool room_left = z.avail_out > 0;
  const std::string why = z.msg ? z.msg : "";
  inflateEnd(&z);
  if (rc == Z_STREAM_END) {
    if (produced != expected_size)
      throw Error(origin + ": inflated to " + std::to_string(produced) + " bytes, expected " +
                  std::to_string(expected_size));
    return out;
  }
  if (rc == Z_DATA_ERROR) throw Error(origin + ": bad DEFLATE data (" + why + ")");
  if (!room_left)
    throw Error(origin + ": inflates to more than the " + std::to_string(expected_size) + " bytes the directory gives");
  throw Error(origin + ": truncated DEFLATE stream (" + std::to_string(produced) + " of " +
              std::to_string(expected_size) + " bytes)");
}

std::map<std::string, std::string> read_zip(const std::string& path) {
  const std::optional<std::string> file = read_file(path);
  if (!file) throw Error(path + ": cannot open");
  const std::string& z = *file;
  // End of central directory: the last "PK\5\6" within the final 64 KiB + 22 bytes.
  size_t eocd = std::string::npos;
  for (size_t i = z.size() >= 22 ? z.size() - 22 : 0; i + 22 <= z.size(); --i) {
    if (le32(z, i) == 0x06054b50) {
      eocd = i;
      break;
    }
    if (i == 0 || z.size() - i > 65557) break;
  }
  if (eocd == std::string::npos) throw Error(path + ": not a zip/.npz archive (no end of central directory)");
  const size_t entries = le16(z, eocd + 10);
  size_t at = le32(z, eocd + 16);
  std::map<std::string, std::string> out;
  for (size_t e = 0; e < entries; ++e) {
    if (le32(z, at) != 0x02014b50) throw Error(path + ": corrupt zip central directory");
    const uint16_t method = le16(z, at + 10);
    uint64_t csize = le32(z, at + 20), usize = le32(z, at + 24);
    const uint16_t nlen = le16(z, at + 28), xlen = le16(z, at + 30), clen = le16(z, at + 32);
    uint64_t local = le32(z, at + 42);
    const std::string name = z.substr(at + 46, nlen);
    // Zip64 extra field (id 1): the 64-bit values of the fields saturated at 0xffffffff.
    for (size_t x = at + 46 + nlen; x + 4 <= at + 46 + nlen + xlen;) {
      const uint16_t id = le16(z, x), sz = le16(z, x + 2);
      if (id == 1) {
        size_t p = x + 4;
        if (usize == 0xffffffffu) usize = le64(z, p), p += 8;
        if (csize == 0xffffffffu) csize = le64(z, p), p += 8;
        if (local == 0xffffffffu) local = le64(z, p);
      }
      x += 4 + sz;
    }
    at += 46 + nlen + xlen + clen;
    if (le32(z, local) != 0x04034b50) throw Error(path + ": corrupt zip local header for " + name);
    const size_t data = local + 30 + le16(z, local + 26) + le16(z, local + 28);
    if (data + csize > z.size()) throw Error(path + ": truncated member " + name);
    const std::string raw = z.substr(data, csize);
    const std::string origin = path + ":" + name;
    if (method == 0)
      out[name] = raw;
    else if (method == 8)
      out[name] = inflate(raw, usize, origin);
    else
      throw Error(origin + ": unsupported zip compression method " + std::to_string(method));
  }
  return out;
}

}  // namespace nova::io
