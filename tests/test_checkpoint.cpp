// The checkpoint file: bit-exact round trips, every kind of damage named, and no temporary
// file left behind whether a write succeeds or fails.
#include <bit>
#include <boost/test/unit_test.hpp>
#include <cfloat>
#include <cstring>
#include <limits>

#include "nova/model/checkpoint.hpp"
#include "scene_test_util.hpp"
#include "model/crc32.hpp"

using namespace nova;
using namespace nova::test;

namespace {

float from_bits(uint32_t b) { return std::bit_cast<float>(b); }
uint32_t to_bits(float f) { return std::bit_cast<uint32_t>(f); }

Checkpoint sample() {
  Checkpoint c;
  c.meta["step"] = "1200";
  c.meta["phase"] = "joint";
  c.meta["empty"] = "";
  c.meta["rng"] = std::string("\0\xff\n binary", 10);
  c.arrays.push_back({"weights", {2, 3},
                      {-0.0f, 0.0f, from_bits(0x7fc12345u) /* quiet NaN with payload */,
                       from_bits(0xffa00001u) /* negative signalling NaN */,
                       from_bits(0x00000001u) /* smallest denormal */,
                       from_bits(0x807fffffu) /* largest negative denormal */}});
  c.arrays.push_back({"scalar", {}, {std::numeric_limits<float>::infinity()}});
  c.arrays.push_back({"empty", {0}, {}});
  c.arrays.push_back({"cube", {2, 1, 2}, {FLT_MAX, -FLT_MIN, 1.0f / 3.0f, -1e-30f}});
  return c;
}

std::vector<std::string> folder_names(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

void put(std::string& s, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) s += char((v >> (8 * i)) & 0xff);
}

// A file with a valid header and CRC around any payload, to reach the structural checks.
std::string wrap_payload(const std::string& payload) {
  std::string f = "NOVACKPT";
  put(f, 1, 4);
  put(f, payload.size(), 8);
  f += payload;
  put(f, crc32(payload.data(), payload.size()), 4);
  return f;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(checkpoint)

BOOST_AUTO_TEST_CASE(crc32_check_value) {
  BOOST_TEST(crc32("123456789", 9) == 0xcbf43926u);  // the CRC-32/ISO-HDLC check value
  BOOST_TEST(crc32("", 0) == 0u);
  BOOST_TEST(crc32("56789", 5, crc32("1234", 4)) == 0xcbf43926u);
  // Eight bytes at a time against the bitwise definition, at every length and alignment
  // around the eight-byte steps (and a longer buffer split anywhere).
  std::vector<unsigned char> bytes(1037);
  for (size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<unsigned char>((i * 2654435761u) >> 13);
  const auto bitwise = [](const unsigned char* p, size_t n) {
    uint32_t c = 0xffffffffu;
    for (size_t i = 0; i < n; ++i) {
      c ^= p[i];
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xedb88320u ^ (c >> 1) : c >> 1;
    }
    return ~c;
  };
  for (size_t start = 0; start < 9; ++start)
    for (size_t n = 0; n < 40; ++n) BOOST_TEST(crc32(bytes.data() + start, n) == bitwise(bytes.data() + start, n));
  BOOST_TEST(crc32(bytes.data() + 517, 520, crc32(bytes.data(), 517)) == bitwise(bytes.data(), bytes.size()));
}

BOOST_AUTO_TEST_CASE(round_trip_is_bit_exact) {
  TempDir dir("ckpt");
  const std::string path = (dir / "a.ckpt").string();
  const Checkpoint c = sample();
  write_checkpoint(path, c);
  BOOST_TEST((folder_names(dir.path()) == std::vector<std::string>{"a.ckpt"}));
  const Checkpoint r = read_checkpoint(path);
  BOOST_TEST((r.meta == c.meta));
  BOOST_REQUIRE(r.arrays.size() == c.arrays.size());
  for (size_t i = 0; i < c.arrays.size(); ++i) {
    const auto &a = c.arrays[i], &b = r.arrays[i];
    BOOST_TEST(a.name == b.name);
    BOOST_TEST(a.shape == b.shape);
    BOOST_REQUIRE(a.values.size() == b.values.size());
    for (size_t k = 0; k < a.values.size(); ++k)
      BOOST_TEST(to_bits(a.values[k]) == to_bits(b.values[k]), a.name << "[" << k << "]");
  }
  BOOST_TEST(r.get("step") == "1200");
  BOOST_TEST(r.array("cube").shape == std::vector<size_t>({2, 1, 2}));
  // Overwriting an existing checkpoint replaces it.
  Checkpoint c2;
  c2.meta["step"] = "1300";
  write_checkpoint(path, c2);
  BOOST_TEST(read_checkpoint(path).get("step") == "1300");
  BOOST_TEST(read_checkpoint(path).arrays.empty());
  BOOST_TEST((folder_names(dir.path()) == std::vector<std::string>{"a.ckpt"}));
}

BOOST_AUTO_TEST_CASE(missing_entries_are_named) {
  const Checkpoint c = sample();
  expect_error([&] { c.array("adam_m"); }, {"no array 'adam_m'", "weights"});
  expect_error([&] { c.get("seed"); }, {"no entry 'seed'", "step"});
}

BOOST_AUTO_TEST_CASE(damage_is_named) {
  TempDir dir("ckpt-bad");
  const std::string good_path = (dir / "good.ckpt").string();
  write_checkpoint(good_path, sample());
  const std::string good = read_all(good_path);
  const auto damaged = [&](const std::string& name, const std::string& bytes) {
    const std::string p = (dir / name).string();
    write_all(p, bytes);
    return p;
  };
  const size_t header = 20;

  // One bit in a float, one in the meta count, one in the CRC itself.
  for (size_t at : {good.size() - 10, header + 1, good.size() - 1}) {
    std::string b = good;
    b[at] = char(b[at] ^ 0x10);
    const std::string p = damaged("flip.ckpt", b);
    expect_error([&] { read_checkpoint(p); }, {p, "corrupt", "CRC"});
  }
  const size_t cuts[] = {good.size() - 1, good.size() / 2, 21, 12, 4, 0};
  for (size_t keep : cuts) {
    const std::string p = damaged("short.ckpt", good.substr(0, keep));
    expect_error([&] { read_checkpoint(p); }, {p, "truncated"});
  }
  {
    const std::string p = damaged("long.ckpt", good + "x");
    expect_error([&] { read_checkpoint(p); }, {p, "corrupt"});
  }
  {
    std::string b = good;
    b[0] = 'X';
    const std::string p = damaged("magic.ckpt", b);
    expect_error([&] { read_checkpoint(p); }, {p, "not a nova checkpoint"});
    const std::string q = damaged("text.ckpt", "hello");
    expect_error([&] { read_checkpoint(q); }, {q, "not a nova checkpoint"});
  }
  {
    std::string b = good;
    b[8] = 99;
    const std::string p = damaged("v99.ckpt", b);
    expect_error([&] { read_checkpoint(p); }, {p, "unsupported checkpoint version 99"});
  }
  const std::string missing = (dir / "nothing.ckpt").string();
  expect_error([&] { read_checkpoint(missing); }, {missing, "cannot open", "No such file"});
}

BOOST_AUTO_TEST_CASE(inconsistent_payload_is_named) {
  TempDir dir("ckpt-shape");
  // One array "w" of shape [3] that claims 2 values (and holds 2): a CRC-valid file.
  std::string payload;
  put(payload, 0, 4);  // no meta
  put(payload, 1, 4);  // one array
  put(payload, 1, 4);
  payload += "w";
  put(payload, 1, 4);  // rank 1
  put(payload, 3, 8);  // dim 3
  put(payload, 2, 8);  // 2 values
  put(payload, 0, 8);  // 2 floats of zero bytes
  const std::string p = (dir / "shape.ckpt").string();
  write_all(p, wrap_payload(payload));
  expect_error([&] { read_checkpoint(p); }, {p, "inconsistent", "'w'", "[3]", "2 values"});

  // A count larger than what the payload holds.
  std::string big = payload;
  big[4 + 4 + 4 + 1 + 4] = 9;  // dim 9
  big[4 + 4 + 4 + 1 + 4 + 8] = 9;  // 9 values, but only 8 bytes follow
  write_all(p, wrap_payload(big));
  expect_error([&] { read_checkpoint(p); }, {p, "inconsistent", "'w'", "9 floats"});

  // Trailing payload bytes after the last array.
  write_all(p, wrap_payload(std::string(8, '\0') + "zz"));  // no meta, no arrays, 2 bytes
  expect_error([&] { read_checkpoint(p); }, {p, "inconsistent", "2 bytes after"});
}

BOOST_AUTO_TEST_CASE(failed_writes_leave_nothing) {
  TempDir dir("ckpt-write");
  // Into a folder that does not exist: a clean error, nothing created.
  const std::string nowhere = (dir / "missing" / "a.ckpt").string();
  expect_error([&] { write_checkpoint(nowhere, sample()); },
               {nowhere, "cannot write checkpoint", "No such file"});
  BOOST_TEST(folder_names(dir.path()).empty());
  // Onto an existing folder: the .tmp is written, the rename fails, the .tmp is removed.
  fs::create_directory(dir / "taken");
  const std::string taken = (dir / "taken").string();
  expect_error([&] { write_checkpoint(taken, sample()); }, {taken, "cannot rename"});
  BOOST_TEST((folder_names(dir.path()) == std::vector<std::string>{"taken"}));
  // Shape vs values and repeated names are refused before anything is written.
  Checkpoint bad;
  bad.arrays.push_back({"w", {2, 2}, {1.0f, 2.0f, 3.0f}});
  const std::string p = (dir / "bad.ckpt").string();
  expect_error([&] { write_checkpoint(p, bad); }, {p, "'w'", "[2, 2]", "3 values"});
  Checkpoint twice;
  twice.arrays.push_back({"w", {1}, {1.0f}});
  twice.arrays.push_back({"w", {1}, {2.0f}});
  expect_error([&] { write_checkpoint(p, twice); }, {p, "'w'", "twice"});
  BOOST_TEST((folder_names(dir.path()) == std::vector<std::string>{"taken"}));
}

BOOST_AUTO_TEST_SUITE_END()
