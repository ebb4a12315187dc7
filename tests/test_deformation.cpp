// A rigid object that also changes shape (deform-width): its canonical samples move by a
// bounded deformation of (position, time) before the canonical field reads them. Training
// must start from the rigid shape (the deformation's output layer is zero), time must then
// reach the density too, and the option needs the rigid model.
#include <boost/test/unit_test.hpp>
#include <functional>
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

FieldConfig deforming_field(int width) {
  FieldConfig f = small_hash_field(32, ObjectMotion::Rigid);
  f.canonical_colour_time_freqs = 2;
  f.deform_width = width;
  f.deform_bound = 0.2f;
  return f;
}

// Every parameter the field shares with the rigid one gets values drawn from its name, so that
// a field with and one without the deformation agree on them; the deformation's own
// parameters keep their initial values unless `draw_deformation`.
std::vector<float> run_field(const FieldConfig& f, const std::vector<float>& times, bool draw_deformation,
                             std::vector<std::string>* names = nullptr) {
  FieldRun run = run_object_fields(f, times, [&](const std::string& name) -> std::optional<unsigned> {
    if (name.rfind("objects.deform.", 0) == 0 && !draw_deformation) return std::nullopt;
    return static_cast<unsigned>(std::hash<std::string>{}(name) & 0xffff);
  });
  if (names) *names = run.names;
  return run.raw;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(deformation)

BOOST_AUTO_TEST_CASE(starts_as_the_rigid_shape) {
  // The output layer starts at zero: offset bound * tanh(0) = 0, so the deformed field is the
  // rigid one bit for bit, at every time.
  const std::vector<float> times(2 * 30, 0.4f);
  std::vector<std::string> names;
  const std::vector<float> rigid = run_field(deforming_field(0), times, false);
  const std::vector<float> deformed = run_field(deforming_field(8), times, false, &names);
  BOOST_TEST(rigid == deformed, boost::test_tools::per_element());
  for (const char* name : {"objects.deform.hidden.w", "objects.deform.out.w", "objects.deform.out.b"})
    BOOST_TEST(std::count(names.begin(), names.end(), name) == 1, name);
}

BOOST_AUTO_TEST_CASE(time_reaches_the_shape_once_it_deforms) {
  // With a trained (here: random) deformation the density at one canonical point changes with
  // time; without one it never does (the rigid field's density does not read time).
  const size_t rows = 2 * 30;
  const std::vector<float> early(rows, -0.6f), late(rows, 0.7f);
  const auto density_change = [&](int width) {
    const std::vector<float> a = run_field(deforming_field(width), early, true);
    const std::vector<float> b = run_field(deforming_field(width), late, true);
    double change = 0;
    for (size_t r = 0; r < rows; ++r) change = std::max(change, double(std::abs(a[r * 5 + 3] - b[r * 5 + 3])));
    return change;
  };
  BOOST_TEST(density_change(0) == 0.0);
  BOOST_TEST(density_change(8) > 1e-3);
}

BOOST_AUTO_TEST_CASE(options_read_and_need_the_rigid_model) {
  TrainConfig c = preset_config("quick");
  set_config_value(c, "deform-width", "32");
  set_config_value(c, "deform-bound", "0.1");
  BOOST_TEST(c.field.deform_width == 32);
  BOOST_TEST(c.field.deform_bound == 0.1f);
  BOOST_CHECK_NO_THROW(validate(c));
  BOOST_CHECK_THROW(set_config_value(c, "deform-width", "-1"), Error);
  BOOST_CHECK_THROW(set_config_value(c, "deform-bound", "0"), Error);
  set_config_value(c, "object-motion", "none");
  try {
    validate(c);
    BOOST_FAIL("deform-width with object-motion none was accepted");
  } catch (const Error& e) {
    BOOST_TEST(std::string(e.what()).find("deform-width") != std::string::npos, e.what());
    BOOST_TEST(std::string(e.what()).find("object-motion rigid") != std::string::npos, e.what());
  }
  BOOST_TEST(preset_config("reference").field.deform_width == 0);
}

BOOST_AUTO_TEST_SUITE_END()
