// The .npy reader/writer: round trips, and every unsupported variant is a clear error.
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <cstring>

#include "nova/io/npy.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

BOOST_AUTO_TEST_SUITE(npy)

BOOST_AUTO_TEST_CASE(round_trip_f64_and_f32) {
  TempDir dir("npy");
  const std::vector<double> v = {1.5, -2.25, 3e-7, 1e30, 0.0, 42.0};
  write_npy_f64((dir / "a.npy").string(), {2, 3}, v);
  const NpyArray a = read_npy((dir / "a.npy").string());
  BOOST_TEST(a.dtype == "<f8");
  BOOST_TEST((a.shape == std::vector<size_t>{2, 3}));
  BOOST_TEST(a.values == v);
  const std::vector<float> f = {0.5f, -1.0f, 7.0f};
  write_npy_f32((dir / "b.npy").string(), {3}, f);
  const NpyArray b = read_npy((dir / "b.npy").string());
  BOOST_TEST(b.dtype == "<f4");
  BOOST_TEST((b.shape == std::vector<size_t>{3}));
  BOOST_TEST(b.values == std::vector<double>({0.5, -1.0, 7.0}));
  // Header padded to 64 bytes, as NumPy >= 1.x writes it.
  BOOST_TEST((read_all(dir / "b.npy").size() - 12u) % 64u == 0u);
}

BOOST_AUTO_TEST_CASE(reads_numpy_written_header) {
  // The exact header numpy.save writes for np.zeros((1, 2)) as float32 (version 1.0).
  std::string payload(8, '\0');
  const float one = 1.0f;
  std::memcpy(&payload[4], &one, 4);
  const NpyArray a = parse_npy(npy_bytes("<f4", "(1, 2)", payload), "mem");
  BOOST_TEST(a.values == std::vector<double>({0.0, 1.0}));
}

BOOST_AUTO_TEST_CASE(rejects_other_dtypes) {
  expect_error([] { parse_npy(npy_bytes("<i8", "(1,)", std::string(8, '\0')), "x.npy"); },
               {"x.npy", "'<i8'", "not supported"});
  expect_error([] { parse_npy(npy_bytes(">f8", "(1,)", std::string(8, '\0')), "x.npy"); },
               {"x.npy", "big-endian"});
  expect_error([] { parse_npy(npy_bytes("<f4", "(2, 2)", std::string(16, '\0'), true), "x.npy"); },
               {"x.npy", "Fortran"});
}

BOOST_AUTO_TEST_CASE(rejects_truncated_and_non_npy) {
  expect_error([] { parse_npy(npy_bytes("<f8", "(4, 17)", std::string(100, '\0')), "t.npy"); },
               {"t.npy", "truncated"});
  expect_error([] { parse_npy("hello world, not numpy", "n.npy"); }, {"n.npy", "magic"});
  expect_error([] { read_npy("/nonexistent/nova/file.npy"); }, {"file.npy", "cannot open"});
}

BOOST_AUTO_TEST_SUITE_END()
