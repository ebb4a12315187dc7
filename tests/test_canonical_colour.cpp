// A rigid object's canonical field may give its colour a time input (canonical-colour-time-
// freqs): the shade of a turning object changes under a fixed light. The shape must stay one
// shape: density and blend may not read time, colour must, and without the option the field
// is the position-only one with its old parameters (checkpoints written before it still load).
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <string>

#include "field_test_util.hpp"
#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/fields.hpp"
#include "nova/runtime/error.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;
using namespace nova::test;

namespace {

FieldConfig rigid_field(int time_freqs) {
  FieldConfig f = small_hash_field(32, ObjectMotion::Rigid);
  f.canonical_colour_time_freqs = time_freqs;
  return f;
}

// Every parameter drawn from one seed sequence (10, 11, ... in graph order).
FieldRun run_field(const FieldConfig& f, const std::vector<float>& times) {
  unsigned seed = 10;
  return run_object_fields(f, times, [&](const std::string&) { return std::optional<unsigned>(seed++); });
}

}  // namespace

BOOST_AUTO_TEST_SUITE(canonical_colour)

BOOST_AUTO_TEST_CASE(time_reaches_colour_and_never_density) {
  const size_t rows = 2 * 40;
  const std::vector<float> early(rows, -0.6f), late(rows, 0.7f);
  const FieldRun a = run_field(rigid_field(3), early), b = run_field(rigid_field(3), late);
  double colour_change = 0.0;
  for (size_t r = 0; r < rows; ++r) {
    for (int c = 0; c < 3; ++c) colour_change = std::max(colour_change, double(std::abs(a.raw[r * 5 + c] - b.raw[r * 5 + c])));
    // Same points, same parameters, another time: the same density and blend, bit for bit.
    BOOST_TEST(a.raw[r * 5 + 3] == b.raw[r * 5 + 3]);
    BOOST_TEST(a.raw[r * 5 + 4] == b.raw[r * 5 + 4]);
  }
  // Weights in +-1 over an 8-wide head: a time change of 1.3 moves colour by order 0.1-1.
  BOOST_TEST(colour_change > 1e-2);
  for (const char* name : {"objects.sigma_blend.w", "objects.colour.w", "objects.rgb.w"})
    BOOST_TEST(std::count(a.names.begin(), a.names.end(), name) == 1, name);
}

BOOST_AUTO_TEST_CASE(without_the_option_the_field_reads_position_alone) {
  const size_t rows = 2 * 40;
  const FieldRun a = run_field(rigid_field(-1), std::vector<float>(rows, -0.6f));
  const FieldRun b = run_field(rigid_field(-1), std::vector<float>(rows, 0.7f));
  BOOST_TEST(a.raw == b.raw, boost::test_tools::per_element());
  // The position-only layout: hash table and trunk only, as checkpoints before the option.
  for (const std::string& name : a.names)
    BOOST_TEST((name.rfind("objects.hash", 0) == 0 || name.rfind("objects.trunk.", 0) == 0), name);
}

BOOST_AUTO_TEST_CASE(option_reads_and_checks_its_range) {
  TrainConfig c = preset_config("quick");
  set_config_value(c, "canonical-colour-time-freqs", "4");
  BOOST_TEST(c.field.canonical_colour_time_freqs == 4);
  BOOST_CHECK_THROW(set_config_value(c, "canonical-colour-time-freqs", "-2"), Error);
  BOOST_CHECK_THROW(set_config_value(c, "canonical-colour-time-freqs", "25"), Error);
  BOOST_TEST(preset_config("reference").field.canonical_colour_time_freqs == -1);
}

BOOST_AUTO_TEST_SUITE_END()
