// A run's config.ini is how `--resume`, `nova render` and `nova eval` rebuild its training
// configuration, so every option must read back exactly what was written, and floats must
// read as a person typed them.
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <cstring>
#include <random>
#include <string>

#include "nova/error.hpp"
#include "nova/train_config.hpp"

using namespace nova;

namespace {

const ConfigOption& option(const std::string& key) {
  for (const ConfigOption& o : config_options())
    if (o.key == key) return o;
  throw Error("no option " + key);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(train_config)

BOOST_AUTO_TEST_CASE(both_presets_round_trip_through_config_text) {
  for (const std::string& name : preset_names()) {
    const TrainConfig c = preset_config(name);
    const std::string text = format_config(c);
    const TrainConfig back = parse_config_text(text, "config.ini");
    BOOST_TEST(format_config(back) == text);
    for (const ConfigOption& o : config_options()) BOOST_TEST(o.get(back) == o.get(c), o.key);
  }
}

BOOST_AUTO_TEST_CASE(floats_print_as_typed_and_read_back_bit_exact) {
  TrainConfig c = preset_config("quick");
  const ConfigOption& margin = option("free-space-margin");
  for (const char* typed : {"0.05", "0.1", "5e-05", "1", "0.3333", "1e-06"}) {
    margin.set(c, typed);
    BOOST_TEST(margin.get(c) == typed);
  }
  // Random floats from 1e-9 to 6e4 (w-depth allows up to 1e6): what get() writes, set()
  // restores to the same bits (resume must continue the same run).
  const ConfigOption& weight = option("w-depth");
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> mantissa(1.0f, 2.0f);
  std::uniform_int_distribution<int> exponent(-30, 15);
  for (int i = 0; i < 2000; ++i) {
    TrainConfig d = c;
    d.w_depth = std::ldexp(mantissa(rng), exponent(rng));
    const std::string text = weight.get(d);
    weight.set(c, text);
    BOOST_TEST(std::memcmp(&c.w_depth, &d.w_depth, sizeof(float)) == 0,
               text << " read back as " << c.w_depth << " for " << d.w_depth);
  }
  // A leading '+' (which std::from_chars refuses) still reads.
  margin.set(c, "+0.25");
  BOOST_TEST(c.free_space_margin == 0.25f);
}

BOOST_AUTO_TEST_SUITE_END()
