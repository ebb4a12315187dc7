// Inflating .npz members (through zlib) on known streams (fixed and dynamic Huffman blocks),
// the errors of damaged ones naming the file, and the tiny D-NeRF .npz when a data folder
// beside the repository has it.
#include <boost/test/unit_test.hpp>
#include <filesystem>

#include "io/zip.hpp"
#include "nova/data/scene_io.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

namespace {

std::string unhex(const std::string& h) {
  std::string out;
  for (size_t i = 0; i + 1 < h.size(); i += 2) out += char(std::stoi(h.substr(i, 2), nullptr, 16));
  return out;
}

// zlib.compressobj(9, DEFLATED, -15) of "nova nova nova nova! " * 20 (one fixed block).
const char* kFixed = "cbcb2f4b54c8432114d1f8a382032c0800";

// The same settings on 4000 bytes from a small alphabet (a dynamic-Huffman block); the input
// is regenerated below with the same LCG.
const char* kDynamic =
    "45575b96ec3808fb67156ccd3cf6bf85d68354f7d4995b49c536084990ad37bdeff57bf1eabdb7d13bb82a5e14ffdecb"
    "f7a62a3af0bd70f1e645ad7fe79ddac2daed2c2cdcadc6bfa9ddb82916943e5ca927ab9b3feb81e49115f892d80ceb1b"
    "07e1279c553ba15bf84d8f970e2f1e318b187081d81909f7c433db5d0ffbe04ee2566031960f029ba790271c46a40e77"
    "08cca219336148ae74c8cdb0aa75506bd31ac112bce11d3619533762022ad82483bb29b4c113383001a90f41de77249e"
    "7d8abfb86f5587f1a83028e5cdf7298297ad65d890a55a05bbe128114032292f61ec386594f1f29cf27fb18494d021c9"
    "e0397525d727106921bd6459b10153171e3c7b142ee17bde11892a32fdb104c5ac37bf653c5cb5c47138a3c525400848"
    "94008f481309459eb70304064009b232af88277f2860ccb53a434034084af85919a1bccfdcd4c7896a83e032156a46f5"
    "05498b1091a284811991b58872c1621509978c1b67d5b85ac3222dd98454330e21dc4620e2439157ddda14c8e02e0a4a"
    "5c54bd1560fc890837c1c3d9c738a228b424a8f7298fe7307846cfc7452f28305b806b99abf26ef195df1f93a33e9171"
    "0ba75f826d43f0a662c096bc9d6029c1540542e586122de9272c547165455114853f049e2c556a44365b1a41ceeb6a9d"
    "53109296518c515a69960c1486d38217da4a4b5d0bf1e88ccda4884538a92faf126094cdc9473cb97bf887e511239e44"
    "42b530637d18adc0686101669e81456993456c5cdf361f99cc489ec44a840baa88b58fa506c844d4febf92e0759cceaf"
    "1865f160a75441107832f59f17c95a8de7cf22f7a73a57eef4c47d97c6e5d551e60e14870ce41843f7991cf29ae20929"
    "c7cc99302f8765d481309d4e735bdcc3179a06cb4321d8f9ce3264a7f6296565d7a14f07114d75850118ef6c0817953a"
    "151ce84b4a165bd76a2264b09d3af3dda1ef480e7045c03c69879c47551497c0cf3ddf2673d43f4208e38491647ca2ca"
    "21bf7b3e3af754c83053ea90e14b83b2383155f9b5002372a51620a08ce7ba0786b4985f525a79219335f4c83816cb3b"
    "66f6787c6544fef0a8b403972062f562d454f034cb11aa46cb99dc5232d5ead652666c22c61a49422173fb3a33aa9331"
    "ef78b7a28265354752af6db7560e096d0333f97eca533b45789f2885eaba42162d97e633a4d451a358dda69cc5b96a97"
    "b70c1baeda3cb5aafe8fab558b907b6d994dc46174205d82cc49c7cb935b455b5c47cf895a89abff30079274f45d7623"
    "cf9a74ae2bc09467921d0ac838b2c86975c76052120d942da9d3634e3747aa314599fb9e664eadcb0d97a0d30053da59"
    "8d250c0182a5fac6f514d223637cdf1f3b0c9a22dbbc6aaae53ac2440d4d032eb9b8e0194a4c3a512c9b8ecc9e1ded59"
    "f69c5e38d730eab63f518a9bb61baadd3d07c6d7ac49d21d35d480c7c4faf3261a7d5c279bfa2c90c2c12e801d0ee5f1"
    "c94ead0d8c3c7315a7e373701d574778195958e815c3bd89173b07e9dc4c6b7f488d1d8429b5fb7c7f439bb5559e239e"
    "ecadbb5cff3262a9c16625aceb299ed880096d73a3dc5bcc0d8794e79521383c25a9bbcde9742c94b277962d95a89677"
    "7fa60b6d4265b4eb9499802e467c80fcb38b36f110c7aa3cf568c1dab93eff988531cfa975ddb66403e6984cf4d10fd0"
    "bb3db733bcd43400bdc2b3c6ec6af1e6467f5be433b47590f7d74149b474419b2bb82f7b7b69c6b646f9ff15234fc72c"
    "16b91c39ef6bd061076587ed75a7366fd85c924391039e6927f2ec146a6cecdf66e182775679dd8c438bd0a8f639994c"
    "a9f53282b5f2788fe4f5b9b346077635b60d0d05b679d1876d347f9cbe171edb49dde8f14eaf805655e58cd199dfb4cb"
    "09a96ef3fa5aa75ece60477bce7416c0e72a1c79dba8a31dba5a943b1e95a1e19416ed312ccfc0e39b0d576e78ef035b"
    "5ff09ade381e8b3969af2ecff4f99bc17ef3cd3d15ec12dbb6f1a1282123bff8190d16954a75f7d94bfd3aa49055e1af"
    "21c92fd3ef6c0ce7eae77981914b3e2e319be6bb89fdb5df3425697dbd1ae86c8ab03da712d3f15b935b8ebbff0f9f70"
    "cb27d20af97a54a5df2e61820aa805495b3632f451816e96f6642a48d36e77a3be4625207a35251c7adeefc158f507";

std::string lcg_text() {
  const std::string alphabet = "aaaaaaabbbbccde\n ";
  uint64_t x = 12345;
  std::string out;
  for (int i = 0; i < 4000; ++i) {
    x = (x * 1103515245u + 12345u) % 2147483648u;
    out += alphabet[(x >> 16) % 17];
  }
  return out;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(zip)

BOOST_AUTO_TEST_CASE(inflate_fixed_block) {
  std::string want;
  for (int i = 0; i < 20; ++i) want += "nova nova nova nova! ";
  BOOST_TEST(io::inflate(unhex(kFixed), want.size(), "fixed") == want);
}

BOOST_AUTO_TEST_CASE(inflate_dynamic_block) {
  const std::string want = lcg_text();
  BOOST_TEST(io::inflate(unhex(kDynamic), want.size(), "dynamic") == want);
}

BOOST_AUTO_TEST_CASE(inflate_errors) {
  const std::string z = unhex(kFixed);
  expect_error([&] { io::inflate(z.substr(0, 8), 420, "cut.npz"); }, {"cut.npz", "truncated"});
  expect_error([&] { io::inflate(z, 421, "size.npz"); }, {"size.npz", "expected 421"});
  expect_error([&] { io::inflate(z, 419, "long.npz"); }, {"long.npz", "more than the 419 bytes"});
  expect_error([&] { io::inflate(std::string(1, '\x07'), 1, "type.npz"); }, {"block type"});
}

// A real .npz scene from a data folder beside the repository, when there is one (reported as
// skipped by Boost.Test where it is absent).
std::filesystem::path lego_dir() {
  return std::filesystem::path(NOVA_SOURCE_DIR).parent_path() / "shared" / "data" / "dnerf_lego_tiny";
}

BOOST_AUTO_TEST_CASE(dnerf_npz_if_available,
                     *boost::unit_test::precondition([](auto) { return std::filesystem::exists(lego_dir()); })) {
  const std::filesystem::path dir = lego_dir();
  const Scene s = load_scene(dir.string());
  BOOST_TEST(s.format == "dnerf-npz");
  BOOST_TEST(s.frames.size() == 50u);
  BOOST_TEST(s.frames[0].camera.width == 100);
  BOOST_TEST(std::abs(s.frames[0].camera.fx - 138.8889) < 1e-3);
}

BOOST_AUTO_TEST_SUITE_END()
