// A run's config.ini is how `--resume`, `nova render` and `nova eval` rebuild its training
// configuration, so every option must read back exactly what was written, and floats must
// read as a person typed them.
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <cstring>
#include <random>
#include <string>

#include "nova/runtime/error.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/train/train_config.hpp"
#include "train/step_batch.hpp"

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

BOOST_AUTO_TEST_CASE(the_hash_box_comes_from_the_scene) {
  for (const std::string& name : preset_names()) {
    const TrainConfig c = preset_config(name);
    BOOST_TEST(c.field.hash.bound == 0.0f, name);
    RayGeometry metric;  // a Blender-like scene: cameras up to 4.03 from the origin
    metric.extent = 4.03f;
    BOOST_TEST(scene_field(c.field, metric).hash.bound == 4.03f, name);
    RayGeometry ndc;
    ndc.ndc = true;
    BOOST_TEST(scene_field(c.field, ndc).hash.bound == 1.0f, name);
  }
}

BOOST_AUTO_TEST_CASE(a_run_written_before_an_option_existed_keeps_its_behaviour) {
  // An older run's config.ini: quick, without the options added since, whose quick values
  // would change the model it renders (object grid) or how it resumes (the two priors).
  std::string text = format_config(preset_config("quick"));
  for (const char* key : {"hash-object-max-res", "static-background-only", "w-free-space",
                          "free-space-behind"}) {
    const size_t at = text.find(std::string("\n") + key + " = ");
    BOOST_REQUIRE(at != std::string::npos);
    text.erase(at + 1, text.find('\n', at + 1) - at);
  }
  const TrainConfig run = parse_config_text(text, "config.ini", nullptr, ConfigFile::RunFile);
  BOOST_TEST(run.field.object_max_resolution == 0);
  BOOST_TEST(!run.static_background_only);
  BOOST_TEST(run.w_free_space == 0.0f);
  BOOST_TEST(run.free_space_behind == 0.0f);
  BOOST_TEST(run.field.hash_time_auto);  // written in the file: kept
  // A partial file the user wrote takes the preset's values for what it leaves out.
  const TrainConfig partial = parse_config_text(text, "mine.ini");
  BOOST_TEST(partial.field.object_max_resolution == 32);
  BOOST_TEST(partial.static_background_only);
  BOOST_TEST(partial.w_free_space == 1.0f);
  // A current run's file names every option: nothing falls back.
  const TrainConfig now = parse_config_text(format_config(preset_config("quick")), "config.ini",
                                            nullptr, ConfigFile::RunFile);
  BOOST_TEST(format_config(now) == format_config(preset_config("quick")));
}

// Augmentation from augment-start on, every augment-every-th joint step, until augment-stop
// (0: to the end); a stop at or before the start would augment nothing and is refused.
BOOST_AUTO_TEST_CASE(augmentation_stops_where_augment_stop_says) {
  TrainConfig c = preset_config("quick");
  c.augment_start = 200;
  c.augment_every = 2;
  c.augment_stop = 1200;
  BOOST_TEST(!detail::augmented_step(c, true, 199));
  BOOST_TEST(detail::augmented_step(c, true, 200));
  BOOST_TEST(!detail::augmented_step(c, true, 201));
  BOOST_TEST(detail::augmented_step(c, true, 1198));
  BOOST_TEST(!detail::augmented_step(c, true, 1200));
  BOOST_TEST(!detail::augmented_step(c, true, 1202));
  BOOST_TEST(!detail::augmented_step(c, false, 200));  // pretraining
  c.augment_stop = 0;
  BOOST_TEST(detail::augmented_step(c, true, 1202));
  validate(c);
  c.augment_stop = 200;
  try {
    validate(c);
    BOOST_ERROR("augment-stop 200 with augment-start 200 was accepted");
  } catch (const Error& e) {
    BOOST_TEST(std::string(e.what()).find("option 'augment-stop': 200 is not after augment-start 200") !=
               std::string::npos, e.what());
  }
  c.augment = false;
  validate(c);  // nothing to stop
}

BOOST_AUTO_TEST_SUITE_END()
