// ZIP reading and DEFLATE decoding for .npz files (see zip.hpp). The decoder follows the
// RFC 1951 description directly: canonical Huffman codes decoded one bit at a time (slow
// but small; an .npz of a few MB inflates in well under a second).
#include "data/zip.hpp"

#include <array>
#include <cstdint>
#include <fstream>
#include <sstream>
#include <vector>

#include "nova/error.hpp"

namespace nova::data {
namespace {

struct BitReader {
  const std::string& in;
  const std::string& origin;
  size_t pos = 0;
  uint32_t buf = 0;
  int count = 0;

  uint32_t bits(int n) {
    while (count < n) {
      if (pos >= in.size()) throw Error(origin + ": truncated DEFLATE stream");
      buf |= uint32_t(static_cast<unsigned char>(in[pos++])) << count;
      count += 8;
    }
    const uint32_t v = buf & ((1u << n) - 1u);
    buf >>= n;
    count -= n;
    return v;
  }
  void align() {
    buf = 0;
    count = 0;
  }
};

// A canonical Huffman code: how many codes of each length, and the symbols in code order.
struct Huffman {
  std::array<uint16_t, 16> count{};
  std::vector<uint16_t> symbol;

  Huffman(const uint8_t* lengths, int n, const std::string& origin) {
    for (int s = 0; s < n; ++s) ++count[lengths[s]];
    count[0] = 0;
    int left = 1;
    for (int len = 1; len < 16; ++len) {
      left = (left << 1) - count[len];
      if (left < 0) throw Error(origin + ": bad DEFLATE code lengths (over-subscribed)");
    }
    std::array<uint16_t, 16> offs{};
    for (int len = 1; len < 15; ++len) offs[len + 1] = offs[len] + count[len];
    symbol.assign(size_t(n), 0);
    for (int s = 0; s < n; ++s)
      if (lengths[s]) symbol[offs[lengths[s]]++] = uint16_t(s);
  }

  int decode(BitReader& br, const std::string& origin) const {
    int code = 0, first = 0, index = 0;
    for (int len = 1; len < 16; ++len) {
      code |= int(br.bits(1));
      const int c = count[len];
      if (code - c < first) return symbol[size_t(index + (code - first))];
      index += c;
      first = (first + c) << 1;
      code <<= 1;
    }
    throw Error(origin + ": bad DEFLATE code");
  }
};

const uint16_t kLenBase[29] = {3,  4,  5,  6,  7,  8,  9,  10, 11,  13,  15,  17,  19,  23, 27,
                               31, 35, 43, 51, 59, 67, 83, 99, 115, 131, 163, 195, 227, 258};
const uint8_t kLenExtra[29] = {0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2,
                               2, 3, 3, 3, 3, 4, 4, 4, 4, 5, 5, 5, 5, 0};
const uint16_t kDistBase[30] = {1,   2,   3,   4,   5,   7,    9,    13,   17,   25,
                                33,  49,  65,  97,  129, 193,  257,  385,  513,  769,
                                1025, 1537, 2049, 3073, 4097, 6145, 8193, 12289, 16385, 24577};
const uint8_t kDistExtra[30] = {0, 0, 0, 0, 1, 1, 2, 2,  3,  3,  4,  4,  5,  5,  6,
                                6, 7, 7, 8, 8, 9, 9, 10, 10, 11, 11, 12, 12, 13, 13};

void inflate_block(BitReader& br, std::string& out, const Huffman& lit, const Huffman& dist,
                   const std::string& origin) {
  for (;;) {
    const int sym = lit.decode(br, origin);
    if (sym < 256) {
      out.push_back(char(sym));
    } else if (sym == 256) {
      return;
    } else {
      const int l = sym - 257;
      if (l >= 29) throw Error(origin + ": bad DEFLATE length symbol");
      const size_t len = kLenBase[l] + br.bits(kLenExtra[l]);
      const int d = dist.decode(br, origin);
      if (d >= 30) throw Error(origin + ": bad DEFLATE distance symbol");
      const size_t back = kDistBase[d] + br.bits(kDistExtra[d]);
      if (back > out.size()) throw Error(origin + ": DEFLATE distance beyond the output");
      const size_t from = out.size() - back;
      for (size_t i = 0; i < len; ++i) out.push_back(out[from + i]);
    }
  }
}

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
  std::string out;
  out.reserve(expected_size);
  BitReader br{in, origin};
  bool last = false;
  while (!last) {
    last = br.bits(1);
    const uint32_t type = br.bits(2);
    if (type == 0) {
      br.align();
      if (br.pos + 4 > in.size()) throw Error(origin + ": truncated stored block");
      const uint16_t len = le16(in, br.pos), nlen = le16(in, br.pos + 2);
      if (uint16_t(~nlen) != len) throw Error(origin + ": bad stored block length");
      br.pos += 4;
      if (br.pos + len > in.size()) throw Error(origin + ": truncated stored block");
      out.append(in, br.pos, len);
      br.pos += len;
    } else if (type == 1) {
      static const auto fixed = [] {
        std::array<uint8_t, 288> l{};
        for (int s = 0; s < 288; ++s) l[s] = s < 144 ? 8 : s < 256 ? 9 : s < 280 ? 7 : 8;
        std::array<uint8_t, 30> d{};
        d.fill(5);
        return std::pair{Huffman(l.data(), 288, "fixed"), Huffman(d.data(), 30, "fixed")};
      }();
      inflate_block(br, out, fixed.first, fixed.second, origin);
    } else if (type == 2) {
      const int nlit = int(br.bits(5)) + 257, ndist = int(br.bits(5)) + 1, ncode = int(br.bits(4)) + 4;
      static const int order[19] = {16, 17, 18, 0, 8, 7, 9, 6, 10, 5, 11, 4, 12, 3, 13, 2, 14, 1, 15};
      uint8_t cl[19] = {};
      for (int i = 0; i < ncode; ++i) cl[order[i]] = uint8_t(br.bits(3));
      const Huffman clh(cl, 19, origin);
      std::vector<uint8_t> lengths;
      while (int(lengths.size()) < nlit + ndist) {
        const int sym = clh.decode(br, origin);
        if (sym < 16) {
          lengths.push_back(uint8_t(sym));
        } else {
          int rep = 0;
          uint8_t val = 0;
          if (sym == 16) {
            if (lengths.empty()) throw Error(origin + ": bad DEFLATE repeat");
            val = lengths.back();
            rep = 3 + int(br.bits(2));
          } else if (sym == 17) {
            rep = 3 + int(br.bits(3));
          } else {
            rep = 11 + int(br.bits(7));
          }
          lengths.insert(lengths.end(), size_t(rep), val);
        }
      }
      if (int(lengths.size()) != nlit + ndist) throw Error(origin + ": bad DEFLATE code lengths");
      const Huffman lit(lengths.data(), nlit, origin), dist(lengths.data() + nlit, ndist, origin);
      inflate_block(br, out, lit, dist, origin);
    } else {
      throw Error(origin + ": bad DEFLATE block type");
    }
  }
  if (out.size() != expected_size)
    throw Error(origin + ": inflated to " + std::to_string(out.size()) + " bytes, expected " +
                std::to_string(expected_size));
  return out;
}

std::map<std::string, std::string> read_zip(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open");
  std::stringstream ss;
  ss << f.rdbuf();
  const std::string z = ss.str();
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

}  // namespace nova::data
