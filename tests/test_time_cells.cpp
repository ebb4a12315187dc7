// The object NeRFs' cells along time follow the scene's frame count when hash-time-res is
// auto (quick's default): the count comes from the spacing of frame times, so holding frames
// out (training) and loading them all (evaluation) give the same grid.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <string>

#include "nova/runtime/error.hpp"
#include "nova/model/fields.hpp"
#include "nova/model/field_graphs.hpp"
#include "nova/train/train_config.hpp"

using namespace nova;

namespace {

// A scene of `n` frames at the reference's times 2 i / n - 1 (only what ray_geometry reads).
Scene video(int n, bool has_time = true) {
  Scene s;
  s.name = "video";
  s.has_time = has_time;
  s.near = 1.0;
  s.far = 5.0;
  for (int i = 0; i < n; ++i) {
    Frame f;
    f.time = has_time ? frame_time(i, n) : 0.0;
    s.frames.push_back(f);
  }
  return s;
}

int resolved_time_cells(const TrainConfig& c, const Scene& s) {
  return scene_field(c.field, ray_geometry(s)).hash.time_max_resolution;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(time_cells)

BOOST_AUTO_TEST_CASE(frames_come_from_the_time_spacing) {
  BOOST_TEST(ray_geometry(video(24)).frames == 24);
  BOOST_TEST(ray_geometry(video(12)).frames == 12);
  BOOST_TEST(ray_geometry(video(1)).frames == 0);
  BOOST_TEST(ray_geometry(video(5, false)).frames == 0);
  // Frames held out keep the axis: scene_io's held_out_frames_keep_the_time_axis.
  // Frames out of order (a reader that lists them newest first) count the same.
  Scene reversed = video(24);
  std::reverse(reversed.frames.begin(), reversed.frames.end());
  BOOST_TEST(ray_geometry(reversed).frames == 24);
}

BOOST_AUTO_TEST_CASE(auto_is_about_three_frames_per_cell) {
  TrainConfig c = preset_config("quick");
  BOOST_REQUIRE(c.field.hash_time_auto);
  BOOST_TEST(resolved_time_cells(c, video(24)) == 8);  // the default synthetic scene
  BOOST_TEST(resolved_time_cells(c, video(12)) == 4);  // nvidia_balloon1
  BOOST_TEST(resolved_time_cells(c, video(2)) == 1);   // never 0 ("as space") for a video
  BOOST_TEST(resolved_time_cells(c, video(200)) == 67);
  BOOST_TEST(!scene_field(c.field, ray_geometry(video(24))).hash_time_auto);
  // A count set by hand is kept whatever the scene.
  c.field.hash_time_auto = false;
  c.field.hash.time_max_resolution = 5;
  BOOST_TEST(resolved_time_cells(c, video(24)) == 5);
  c.field.hash.time_max_resolution = 0;
  BOOST_TEST(resolved_time_cells(c, video(24)) == 0);
}

BOOST_AUTO_TEST_CASE(option_reads_and_writes_auto) {
  TrainConfig c = preset_config("reference");
  BOOST_TEST(!c.field.hash_time_auto);
  const ConfigOption* opt = nullptr;
  for (const ConfigOption& o : config_options())
    if (o.key == "hash-time-res") opt = &o;
  BOOST_REQUIRE(opt);
  BOOST_TEST(opt->get(c) == "0");
  set_config_value(c, "hash-time-res", " auto ");
  BOOST_TEST(c.field.hash_time_auto);
  BOOST_TEST(opt->get(c) == "auto");
  set_config_value(c, "hash-time-res", "6");
  BOOST_TEST(!c.field.hash_time_auto);
  BOOST_TEST(c.field.hash.time_max_resolution == 6);
  BOOST_TEST(opt->get(c) == "6");
  // A config.ini written with auto reads back as auto (the reference preset it names is not).
  TrainConfig written = preset_config("reference");
  written.field.hash_time_auto = true;
  const TrainConfig back = parse_config_text(format_config(written), "config.ini");
  BOOST_TEST(back.preset == "reference");
  BOOST_TEST(back.field.hash_time_auto);
  for (const char* bad : {"automatic", "-1", "2.5", ""}) {
    try {
      set_config_value(c, "hash-time-res", bad);
      BOOST_FAIL("hash-time-res '" << bad << "' was accepted");
    } catch (const Error& e) {
      BOOST_TEST(std::string(e.what()).find("hash-time-res") != std::string::npos);
    }
  }
}

BOOST_AUTO_TEST_SUITE_END()
