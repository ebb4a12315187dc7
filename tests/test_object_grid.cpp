// The object NeRFs' hash grid may stop at a coarser finest level than the static NeRF's
// (hash-object-max-res): the object field must encode with that grid, the static field must
// not, and the checkpoint layout (table shapes) must not change with it.
#include <boost/test/unit_test.hpp>
#include <string>

#include "field_test_util.hpp"
#include "harness.hpp"
#include "nova/runtime/error.hpp"
#include "nova/graph/executor.hpp"
#include "nova/model/fields.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;
using namespace nova::test;

namespace {

// A field's output for fixed inputs with every parameter set from one seed (tables in +-1,
// so the encoding dominates the output).
std::vector<float> field_output(const FieldConfig& f, bool object) {
  const size_t M = 50;
  Graph g;
  Tensor p = g.input("p", Shape{M, 3});
  Tensor t = g.input("t", Shape{M, 1});
  Tensor d = g.input("d", Shape{M, 3});
  Tensor out = object ? build_object_fields(p, t, f) : build_static_field(p, d, f);
  g.keep(out);
  Executor ex(runtime(), g);
  ex.set(p, random_floats(M * 3, -0.9f, 0.9f, 1));
  ex.set(t, random_floats(M, -1.0f, 1.0f, 2));
  ex.set(d, random_floats(M * 3, -1.0f, 1.0f, 3));
  unsigned seed = 10;
  for (Tensor w : g.parameters()) ex.set(w, random_floats(w.shape().numel(), -1.0f, 1.0f, seed++));
  ex.forward();
  return ex.get(out);
}

}  // namespace

BOOST_AUTO_TEST_SUITE(object_grid)

BOOST_AUTO_TEST_CASE(object_fields_use_their_own_finest_level) {
  FieldConfig fine = small_hash_field(64);
  FieldConfig coarse_objects = fine;
  coarse_objects.object_max_resolution = 16;
  FieldConfig coarse_everywhere = fine;
  coarse_everywhere.hash.max_resolution = 16;

  BOOST_TEST(object_hash_config(fine).max_resolution == 64);
  BOOST_TEST(object_hash_config(coarse_objects).max_resolution == 16);
  BOOST_TEST(hash_grid_table_shape(object_hash_config(coarse_objects), 2).str() ==
             hash_grid_table_shape(fine.hash, 2).str());

  // Objects: the coarse-object field is the all-coarse one (same bits), not the fine one.
  const auto obj_coarse = field_output(coarse_objects, true);
  BOOST_TEST(obj_coarse == field_output(coarse_everywhere, true), boost::test_tools::per_element());
  BOOST_TEST(obj_coarse != field_output(fine, true));
  // Static: unchanged by the object setting.
  BOOST_TEST(field_output(coarse_objects, false) == field_output(fine, false), boost::test_tools::per_element());
  BOOST_TEST(field_output(coarse_everywhere, false) != field_output(fine, false));
}

BOOST_AUTO_TEST_CASE(option_is_checked_against_the_coarsest_level) {
  BOOST_TEST(preset_config("reference").field.object_max_resolution == 0);
  TrainConfig c = preset_config("quick");
  BOOST_TEST(c.field.object_max_resolution == 32);
  set_config_value(c, "object-motion", "none");  // the (x, y, z, t) field's grid
  set_config_value(c, "hash-object-max-res", "128");
  BOOST_TEST(c.field.object_max_resolution == 128);
  validate(c);
  set_config_value(c, "hash-object-max-res", "8");  // below hash-min-res 16
  try {
    validate(c);
    BOOST_FAIL("an object grid finer at its coarsest level than at its finest was accepted");
  } catch (const Error& e) {
    BOOST_TEST(std::string(e.what()).find("hash-") != std::string::npos, e.what());
  }
}

// A rigid object's canonical field takes hash-canonical-max-res; the (x, y, z, t) field keeps
// hash-object-max-res whatever it says, and 0 falls back to hash-object-max-res (what a run
// written before the option meant).
BOOST_AUTO_TEST_CASE(canonical_fields_use_their_own_finest_level) {
  FieldConfig f = small_hash_field(64);
  f.object_max_resolution = 16;
  f.canonical_max_resolution = 32;
  BOOST_TEST(object_hash_config(f).max_resolution == 16);
  f.motion = ObjectMotion::Rigid;
  BOOST_TEST(object_hash_config(f).max_resolution == 32);
  f.canonical_max_resolution = 0;
  BOOST_TEST(object_hash_config(f).max_resolution == 16);

  TrainConfig c = preset_config("quick");
  BOOST_TEST(c.field.canonical_max_resolution == 128);
  BOOST_TEST(preset_config("reference").field.canonical_max_resolution == 0);
  set_config_value(c, "object-motion", "rigid");
  set_config_value(c, "hash-canonical-max-res", "8");  // below hash-min-res 16
  BOOST_CHECK_THROW(validate(c), Error);
  set_config_value(c, "hash-canonical-max-res", "64");
  validate(c);
  BOOST_TEST(object_hash_config(c.field).max_resolution == 64);
}

BOOST_AUTO_TEST_SUITE_END()
