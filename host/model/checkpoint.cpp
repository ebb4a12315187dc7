// The checkpoint file (layout in include/nova/model/checkpoint.hpp). The whole file is built in, or
// read into, memory: checkpoints are tens of MB, and a single buffer makes the length and
// CRC checks happen before any field is trusted.
#include "nova/model/checkpoint.hpp"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <set>
#include <unistd.h>

#include "nova/runtime/error.hpp"
#include "model/crc32.hpp"

namespace nova {
namespace {

constexpr char kMagic[8] = {'N', 'O', 'V', 'A', 'C', 'K', 'P', 'T'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 8 + 4 + 8;  // magic, version, payload size
constexpr size_t kCrcBytes = 4;

std::string hex32(uint32_t v) {
  char buf[11];
  std::snprintf(buf, sizeof buf, "0x%08x", v);
  return buf;
}

std::string shape_text(const std::vector<size_t>& shape) {
  std::string s = "[";
  for (size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + "]";
}

// Product of the dims, or false on overflow (a corrupt or hostile shape).
bool element_count(const std::vector<size_t>& shape, uint64_t& count) {
  count = 1;
  for (size_t d : shape) {
    if (d != 0 && count > std::numeric_limits<uint64_t>::max() / d) return false;
    count *= d;
  }
  return true;
}

void put_u32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out += char((v >> (8 * i)) & 0xffu);
}
void put_u64(std::string& out, uint64_t v) {
  for (int i = 0; i < 8; ++i) out += char((v >> (8 * i)) & 0xffu);
}
void put_string(std::string& out, const std::string& s, const std::string& what) {
  if (s.size() > std::numeric_limits<uint32_t>::max())
    throw Error(what + " is longer than 4 GiB");
  put_u32(out, uint32_t(s.size()));
  out += s;
}
void put_floats(std::string& out, const std::vector<float>& v) {
  const size_t at = out.size();
  out.resize(at + 4 * v.size());
  if constexpr (std::endian::native == std::endian::little) {
    if (!v.empty()) std::memcpy(&out[at], v.data(), 4 * v.size());
  } else {
    for (size_t i = 0; i < v.size(); ++i) {
      const uint32_t bits = std::bit_cast<uint32_t>(v[i]);
      for (int b = 0; b < 4; ++b) out[at + 4 * i + b] = char((bits >> (8 * b)) & 0xffu);
    }
  }
}

std::string encode_payload(const Checkpoint& ckpt) {
  std::string out;
  if (ckpt.meta.size() > std::numeric_limits<uint32_t>::max() ||
      ckpt.arrays.size() > std::numeric_limits<uint32_t>::max())
    throw Error("more than 2^32 meta entries or arrays");
  put_u32(out, uint32_t(ckpt.meta.size()));
  for (const auto& [key, value] : ckpt.meta) {
    put_string(out, key, "meta key '" + key.substr(0, 40) + "'");
    put_string(out, value, "meta value of '" + key + "'");
  }
  put_u32(out, uint32_t(ckpt.arrays.size()));
  std::set<std::string> names;
  for (const auto& a : ckpt.arrays) {
    if (!names.insert(a.name).second)
      throw Error("array name '" + a.name + "' appears twice");
    uint64_t count = 0;
    if (!element_count(a.shape, count) || count != a.values.size())
      throw Error("array '" + a.name + "' has shape " + shape_text(a.shape) +
                  " but " + std::to_string(a.values.size()) + " values");
    put_string(out, a.name, "array name '" + a.name.substr(0, 40) + "'");
    put_u32(out, uint32_t(a.shape.size()));
    for (size_t d : a.shape) put_u64(out, d);
    put_u64(out, count);
    put_floats(out, a.values);
  }
  return out;
}

// Bounds-checked little-endian reads over the payload. The CRC has already matched, so a
// failure here means the writer produced an inconsistent file, not that bytes were damaged.
class PayloadReader {
 public:
  PayloadReader(const std::string& bytes, size_t begin, size_t end, const std::string& path)
      : b_(bytes), pos_(begin), end_(end), path_(path) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw Error(path_ + ": inconsistent checkpoint payload: " + problem);
  }
  void need(uint64_t n, const std::string& what) const {
    if (n > end_ - pos_)
      fail(what + " needs " + std::to_string(n) + " bytes, " + std::to_string(end_ - pos_) +
           " are left in the payload");
  }
  uint64_t uint(int bytes, const std::string& what) {
    need(bytes, what);
    uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= uint64_t(uint8_t(b_[pos_ + i])) << (8 * i);
    pos_ += bytes;
    return v;
  }
  std::string str(const std::string& what) {
    const uint64_t n = uint(4, what + " length");
    need(n, what);
    std::string s = b_.substr(pos_, n);
    pos_ += n;
    return s;
  }
  std::vector<float> floats(uint64_t count, const std::string& what) {
    if (count > (end_ - pos_) / 4)
      fail(what + " needs " + std::to_string(count) + " floats, " + std::to_string(end_ - pos_) +
           " bytes are left in the payload");
    std::vector<float> v(count);
    if constexpr (std::endian::native == std::endian::little) {
      if (count) std::memcpy(v.data(), b_.data() + pos_, 4 * count);
    } else {
      for (size_t i = 0; i < count; ++i) {
        uint32_t bits = 0;
        for (int k = 0; k < 4; ++k) bits |= uint32_t(uint8_t(b_[pos_ + 4 * i + k])) << (8 * k);
        v[i] = std::bit_cast<float>(bits);
      }
    }
    pos_ += 4 * count;
    return v;
  }
  size_t left() const { return end_ - pos_; }

 private:
  const std::string& b_;
  size_t pos_, end_;
  const std::string& path_;
};

std::string errno_text() { return std::strerror(errno); }

std::string read_file(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) throw Error(path + ": cannot open checkpoint (" + errno_text() + ")");
  std::string bytes;
  char buf[1 << 16];
  size_t n;
  while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) bytes.append(buf, n);
  const bool bad = std::ferror(f);
  std::fclose(f);
  if (bad) throw Error(path + ": read error on checkpoint (" + errno_text() + ")");
  return bytes;
}

// Writes all of `bytes` to `tmp` and makes it durable; false (with errno set) on failure.
bool write_durably(const std::string& tmp, const std::string& bytes, std::string& problem) {
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) {
    problem = "cannot create " + tmp + " (" + errno_text() + ")";
    return false;
  }
  bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size();
  ok = ok && std::fflush(f) == 0;
  // fsync before the rename: otherwise a crash can leave the new name on an empty file.
  ok = ok && ::fsync(::fileno(f)) == 0;
  if (!ok) problem = "cannot write " + tmp + " (" + errno_text() + ")";
  if (std::fclose(f) != 0 && ok) {
    problem = "cannot close " + tmp + " (" + errno_text() + ")";
    ok = false;
  }
  return ok;
}

}  // namespace

const CheckpointArray& Checkpoint::array(const std::string& name) const {
  for (const auto& a : arrays)
    if (a.name == name) return a;
  std::string have;
  for (const auto& a : arrays) have += (have.empty() ? "" : ", ") + a.name;
  throw Error("checkpoint has no array '" + name + "' (it has: " +
              (have.empty() ? "none" : have) + ")");
}

const std::string& Checkpoint::get(const std::string& key) const {
  const auto it = meta.find(key);
  if (it != meta.end()) return it->second;
  std::string have;
  for (const auto& [k, v] : meta) have += (have.empty() ? "" : ", ") + k;
  throw Error("checkpoint has no entry '" + key + "' (it has: " +
              (have.empty() ? "none" : have) + ")");
}

void write_checkpoint(const std::string& path, const Checkpoint& ckpt) {
  std::string payload;
  try {
    payload = encode_payload(ckpt);
  } catch (const Error& e) {
    throw Error(path + ": cannot write checkpoint: " + e.what(), e.exit_code());
  }
  std::string file(kMagic, sizeof kMagic);
  put_u32(file, kVersion);
  put_u64(file, payload.size());
  file += payload;
  put_u32(file, crc32(payload.data(), payload.size()));

  const std::string tmp = path + ".tmp";
  std::string problem;
  bool ok = write_durably(tmp, file, problem);
  if (ok) {
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);  // atomic replacement on POSIX
    if (ec) {
      problem = "cannot rename " + tmp + " to " + path + " (" + ec.message() + ")";
      ok = false;
    }
  }
  if (!ok) {
    std::error_code ignored;
    std::filesystem::remove(tmp, ignored);
    throw Error(path + ": cannot write checkpoint: " + problem);
  }
}

Checkpoint read_checkpoint(const std::string& path) {
  const std::string bytes = read_file(path);
  const size_t size = bytes.size();
  const auto truncated = [&](const std::string& detail) {
    return Error(path + ": truncated checkpoint (" + std::to_string(size) + " bytes, " + detail +
                 ")");
  };
  const size_t magic_len = std::min(size, sizeof kMagic);
  if (std::memcmp(bytes.data(), kMagic, magic_len) != 0)
    throw Error(path + ": not a nova checkpoint (the file does not start with NOVACKPT)");
  if (size < kHeaderBytes)
    throw truncated("the header alone needs " + std::to_string(kHeaderBytes));
  PayloadReader header(bytes, sizeof kMagic, kHeaderBytes, path);
  const uint64_t version = header.uint(4, "version");
  if (version != kVersion)
    throw Error(path + ": unsupported checkpoint version " + std::to_string(version) +
                " (this build reads version " + std::to_string(kVersion) + ")");
  const uint64_t payload_bytes = header.uint(8, "payload size");
  const std::string expected = "the header announces a payload of " +
                               std::to_string(payload_bytes) + " bytes, " +
                               std::to_string(kHeaderBytes + kCrcBytes) + " more around it";
  const uint64_t after_header = size - kHeaderBytes;
  if (after_header < kCrcBytes || payload_bytes > after_header - kCrcBytes)
    throw truncated(expected);
  if (payload_bytes != after_header - kCrcBytes)
    throw Error(path + ": corrupt checkpoint (" + std::to_string(size) + " bytes, " + expected +
                ")");
  const size_t end = kHeaderBytes + payload_bytes;
  uint32_t stored = 0;
  for (size_t i = 0; i < kCrcBytes; ++i) stored |= uint32_t(uint8_t(bytes[end + i])) << (8 * i);
  const uint32_t computed = crc32(bytes.data() + kHeaderBytes, payload_bytes);
  if (stored != computed)
    throw Error(path + ": corrupt checkpoint (CRC-32 mismatch: stored " + hex32(stored) +
                ", computed " + hex32(computed) + ")");

  PayloadReader in(bytes, kHeaderBytes, end, path);
  Checkpoint ckpt;
  const uint64_t meta_count = in.uint(4, "meta count");
  for (uint64_t i = 0; i < meta_count; ++i) {
    std::string key = in.str("meta key " + std::to_string(i));
    std::string value = in.str("meta value of '" + key + "'");
    if (!ckpt.meta.emplace(key, std::move(value)).second)
      in.fail("meta key '" + key + "' repeats");
  }
  const uint64_t array_count = in.uint(4, "array count");
  std::set<std::string> names;
  for (uint64_t i = 0; i < array_count; ++i) {
    CheckpointArray a;
    a.name = in.str("array name " + std::to_string(i));
    if (!names.insert(a.name).second) in.fail("array name '" + a.name + "' repeats");
    const uint64_t rank = in.uint(4, "rank of '" + a.name + "'");
    in.need(rank * 8, "shape of '" + a.name + "'");
    for (uint64_t d = 0; d < rank; ++d)
      a.shape.push_back(in.uint(8, "shape of '" + a.name + "'"));
    const uint64_t count = in.uint(8, "value count of '" + a.name + "'");
    uint64_t want = 0;
    if (!element_count(a.shape, want) || want != count)
      in.fail("array '" + a.name + "' has shape " + shape_text(a.shape) + " but " +
              std::to_string(count) + " values");
    a.values = in.floats(count, "values of '" + a.name + "'");
    ckpt.arrays.push_back(std::move(a));
  }
  if (in.left()) in.fail(std::to_string(in.left()) + " bytes after the last array");
  return ckpt;
}

}  // namespace nova
