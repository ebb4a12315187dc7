// The scene readers on a tiny synthetic scene (exact expectations), the layout variants
// (DynamicNeRF single mask folder, static-only, LLFF), and one test per bad-input case: each
// must be a nova::Error with exit code 2 naming the file and the problem.
#include <algorithm>
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <limits>

#include "nova/eval/evaluation.hpp"
#include "nova/io/image_io.hpp"
#include "nova/data/llff_poses.hpp"
#include "nova/io/npy.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/model/field_graphs.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

namespace {

// Sets one value of poses_bounds.npy (row r, column c).
void poke_pose(const fs::path& scene, size_t r, size_t c, double v) {
  const auto file = (scene / "poses_bounds.npy").string();
  NpyArray a = read_npy(file);
  a.values[r * 17 + c] = v;
  write_npy_f64(file, a.shape, a.values);
}

// Whether one of the scene's notes contains `part`.
bool noted(const Scene& scene, const std::string& part) {
  return std::any_of(scene.notes.begin(), scene.notes.end(),
                     [&](const std::string& n) { return n.find(part) != std::string::npos; });
}

}  // namespace

BOOST_AUTO_TEST_SUITE(scene_io)

BOOST_AUTO_TEST_CASE(reads_synthetic_scene) {
  const fs::path dir = cached_tiny_scene();
  BOOST_TEST(detect_format(dir.string()) == "nova");
  const Scene s = load_scene(dir.string());
  const SynthWorld world("tiny", 7);
  const int n = world.preset().frames;
  BOOST_TEST(s.frames.size() == size_t(n));
  BOOST_TEST(s.num_objects == 2);
  BOOST_TEST(s.ndc);
  BOOST_TEST(s.bd_factor == 0.9);
  BOOST_TEST(s.gt_views.size() == size_t(3 * n));
  BOOST_TEST(s.compose.targets.size() == 4u);
  BOOST_TEST(s.compose_gt.size() == 4u);
  for (int i = 0; i < n; ++i) {
    const Frame& f = s.frames[i];
    BOOST_TEST(f.time == frame_time(i, n));
    BOOST_TEST(f.masks.size() == 3u);
    BOOST_TEST(!f.disparity.empty());
    BOOST_TEST(f.camera.width == 64);
    BOOST_TEST(f.camera.fx == world.preset().focal);
    // Pixels are exactly what the generator rendered (PNG is lossless).
    const SynthRender r = world.render(world.camera(i), f.time);
    BOOST_TEST((f.rgb.data == r.rgb.data));
    for (int k = 0; k < 3; ++k) BOOST_TEST((f.masks[k].data == r.masks[k].data));
    BOOST_TEST(f.near >= 1.0);  // scaled by 1 / (p5(near) * 0.9): NDC's near plane is 1
  }
  // Recentring puts the average camera at the origin, looking along -z.
  double mean[3] = {0, 0, 0}, back[3] = {0, 0, 0};
  for (const auto& f : s.frames)
    for (int r = 0; r < 3; ++r) {
      mean[r] += f.camera.position(r) / n;
      back[r] += f.camera.rotation(r, 2);
    }
  for (int r = 0; r < 3; ++r) BOOST_TEST(std::abs(mean[r]) < 1e-9);
  BOOST_TEST(std::abs(back[0]) < 1e-9);
  BOOST_TEST(std::abs(back[1]) < 1e-9);
  BOOST_TEST(back[2] > 0);
  // Camera 0's ground-truth views share frame 0's processed camera.
  for (int k = 0; k < 12; ++k)
    BOOST_TEST(std::abs(s.gt_views[0].camera.c2w[k] - s.frames[0].camera.c2w[k]) < 1e-12);
  BOOST_TEST((s.gt_views[0].rgb.data == s.frames[0].rgb.data));
  BOOST_TEST(scene_summary(s).find("3 (1 static + 2 objects)") != std::string::npos);
  // Every ground-truth view of the tiny scene has its objects region.
  const std::string regions = "ground truth " + std::to_string(s.gt_views.size()) + " views (" +
                              std::to_string(s.gt_views.size()) + " with objects regions)";
  BOOST_TEST(scene_summary(s).find(regions) != std::string::npos, scene_summary(s));
}

BOOST_AUTO_TEST_CASE(dynamicnerf_single_mask_folder) {
  TempDir tmp("dnerf");
  const fs::path dir = copy_tiny_scene(tmp);
  // DynamicNeRF: motion_masks/NNN.png = the moving region (objects 1 and 2 together).
  const fs::path mm = dir / "motion_masks";
  for (const auto& e : fs::directory_iterator(mm / "0")) {
    const auto name = e.path().filename();
    Image8 a = read_mask((mm / "1" / name).string()), b = read_mask((mm / "2" / name).string());
    for (size_t i = 0; i < a.data.size(); ++i) a.data[i] = a.data[i] | b.data[i];
    write_png((mm / name).string(), a);
  }
  for (const char* k : {"0", "1", "2"}) fs::remove_all(mm / k);
  const Scene s = load_scene(dir.string());
  BOOST_TEST(s.num_objects == 1);
  const Scene ref = load_scene(cached_tiny_scene().string());
  BOOST_TEST((s.frames[3].masks[0].data == ref.frames[3].masks[0].data));
}

BOOST_AUTO_TEST_CASE(missing_masks_need_static_only) {
  TempDir tmp("nomask");
  const fs::path dir = copy_tiny_scene(tmp);
  fs::remove_all(dir / "motion_masks");
  expect_error([&] { load_scene(dir.string()); }, {"motion_masks", "missing", "--static-only"});
  LoadOptions opt;
  opt.static_only = true;
  const Scene s = load_scene(dir.string(), opt);
  BOOST_TEST(s.num_objects == 0);
  BOOST_TEST(s.frames[0].masks.size() == 1u);
  BOOST_TEST(s.frames[0].masks[0].data[0] == 255);
}

BOOST_AUTO_TEST_CASE(llff_static_layout) {
  TempDir tmp("llff");
  const fs::path dir = copy_tiny_scene(tmp);
  for (const char* d : {"motion_masks", "disp", "gt"}) fs::remove_all(dir / d);
  BOOST_TEST(detect_format(dir.string()) == "llff");
  const Scene s = load_scene(dir.string());
  BOOST_TEST(s.format == "llff");
  BOOST_TEST(s.num_objects == 0);
  BOOST_TEST(s.bd_factor == 0.75);
  BOOST_TEST(!s.has_time);
}

BOOST_AUTO_TEST_CASE(factor_downscales_images) {
  LoadOptions opt;
  opt.factor = 2;
  const Scene s = load_scene(cached_tiny_scene().string(), opt);
  BOOST_TEST(s.frames[0].camera.width == 32);
  BOOST_TEST(s.frames[0].camera.fx == SynthWorld("tiny", 7).preset().focal / 2);
  BOOST_TEST(s.frames[0].masks[1].width == 32);
  BOOST_TEST(s.frames[0].disparity.width == 32);
}

BOOST_AUTO_TEST_CASE(blender_json_with_time) {
  TempDir tmp("blender");
  const fs::path dir = tmp.path();
  fs::create_directories(dir / "train");
  Image8 img(8, 6, 3, 100);
  write_png((dir / "train" / "r_0.png").string(), img);
  write_png((dir / "train" / "r_1.png").string(), img);
  write_all(dir / "transforms_train.json",
            R"({"camera_angle_x": 0.6911112, "frames": [
  {"file_path": "./train/r_0", "time": 0.0, "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]},
  {"file_path": "./train/r_1", "time": 0.5, "transform_matrix": [[1,0,0,1],[0,1,0,0],[0,0,1,4],[0,0,0,1]]}]})");
  BOOST_TEST(detect_format(dir.string()) == "blender");
  const Scene s = load_scene(dir.string());
  BOOST_TEST(s.frames.size() == 2u);
  BOOST_TEST(s.has_time);
  BOOST_TEST(s.frames[1].time == 0.0);
  BOOST_TEST(s.frames[1].camera.position(0) == 1.0);
  BOOST_TEST(std::abs(s.frames[0].camera.fx - 0.5 * 8 / std::tan(0.5 * 0.6911112)) < 1e-9);
  BOOST_TEST(!s.ndc);
  BOOST_TEST(!noted(s, "RGBA"));  // plain RGB frames: nothing composited
  // Masks beside a Blender json are not used, and the summary says so.
  fs::create_directories(dir / "motion_masks" / "1");
  BOOST_TEST(noted(load_scene(dir.string()), "motion_masks/ ignored"));
}

// Real scenes from a data folder beside the repository, when there is one: reported as
// skipped by Boost.Test where it is absent (the suite never needs them).
fs::path data_dir() { return fs::path(NOVA_SOURCE_DIR).parent_path() / "shared" / "data"; }
boost::test_tools::assertion_result has_data(const char* scene) {
  boost::test_tools::assertion_result r(fs::exists(data_dir() / scene / "poses_bounds.npy"));
  r.message() << scene << " not found in " << data_dir().string();
  return r;
}

BOOST_AUTO_TEST_CASE(llff_fern_if_available, *boost::unit_test::precondition([](auto) { return has_data("llff_fern"); })) {
  const Scene s = load_scene((data_dir() / "llff_fern").string());
  BOOST_TEST(s.format == "llff");
  BOOST_TEST(s.frames.size() == 20u);
  BOOST_TEST(s.frames[0].camera.width == 504);
  BOOST_TEST(std::abs(s.frames[0].camera.fx - 3260.526 / 8) < 0.01);
}

BOOST_AUTO_TEST_CASE(nvidia_balloon1_if_available,
                     *boost::unit_test::precondition([](auto) { return has_data("nvidia_balloon1"); })) {
  LoadOptions opt;
  opt.factor = 2;
  opt.static_only = !fs::exists(data_dir() / "nvidia_balloon1" / "motion_masks");
  const Scene s = load_scene((data_dir() / "nvidia_balloon1").string(), opt);
  BOOST_TEST(s.frames.size() == 12u);
  BOOST_TEST(s.frames[0].camera.width == 480);
  BOOST_TEST(s.frames[0].camera.height == 270);
  BOOST_TEST(!s.frames[0].disparity.empty());
}

// ---- bad input: one test per case ----------------------------------------------------

// The LLFF evaluation split. The time axis is counted from the spacing of frame times
// (time_cells), so a scene with frames held out trains with the axis of the whole video.
BOOST_AUTO_TEST_CASE(held_out_frames_keep_the_time_axis) {
  Scene held;
  held.name = "video";
  held.has_time = true;
  held.near = 1.0;
  held.far = 5.0;
  for (int i = 0; i < 12; ++i) {
    Frame f;
    f.time = frame_time(i, 12);
    held.frames.push_back(f);
  }
  // Every 4th frame held out (frames 0, 4, 8, ...): neighbours remain, the axis is the same.
  hold_out_frames(held, 4);
  BOOST_REQUIRE(held.frames.size() == 9u);
  BOOST_TEST(ray_geometry(held).frames == 12);
  BOOST_REQUIRE(held.gt_views.size() == 3u);
  BOOST_TEST(held.gt_views[1].name == "frame_004");
  BOOST_TEST(held.gt_views[1].kind == "heldout");
  BOOST_TEST(held.gt_views[1].time_index == 4);
  BOOST_TEST(held.gt_views[1].time == frame_time(4, 12));
  // Camera indices count the folder's frames, held-out ones in their places; a ground-truth
  // camera that never was a folder frame (a synthetic scene's held-out cameras, kind
  // "heldout" too) takes none. Cameras are told apart by their focal length here.
  {
    Scene s;
    s.name = "indices";
    for (int i = 0; i < 6; ++i) {
      Frame f;
      f.time = frame_time(i, 6);
      f.camera.fx = 100.0 + i;
      s.frames.push_back(f);
    }
    for (int i = 0; i < 6; ++i) {  // two extra cameras per time, as `nova synth` writes them
      GroundTruthView v;
      v.kind = "heldout";
      v.name = "heldout1/" + std::to_string(i);
      v.time = frame_time(i, 6);
      v.camera.fx = 500.0 + i;
      s.gt_views.push_back(v);
    }
    hold_out_frames(s, 4);  // folder frames 0 and 4
    const std::vector<FolderFrame> frames = folder_frames(s);
    BOOST_REQUIRE(frames.size() == 6u);
    for (int i = 0; i < 6; ++i) {
      BOOST_TEST(frames[i].camera.fx == 100.0 + i, "folder frame " << i);
      BOOST_TEST(frames[i].time == frame_time(i, 6));
    }
  }
  held.frames.resize(1);
  BOOST_CHECK_THROW(hold_out_frames(held, 2), Error);
  // Holding out every frame (1), or all but one (2 of 3 frames), leaves nothing to train on.
  for (auto [frames, every] : {std::pair{5, 1}, std::pair{3, 2}}) {
    Scene few;
    few.name = "few";
    few.frames.resize(static_cast<size_t>(frames));
    try {
      hold_out_frames(few, every);
      BOOST_ERROR("holdout " << every << " of " << frames << " frames was accepted");
    } catch (const Error& e) {
      BOOST_TEST(std::string(e.what()).find("to train on") != std::string::npos, e.what());
      BOOST_TEST(e.exit_code() == kExitUsage);
    }
  }
  Scene four;
  four.frames.resize(4);
  hold_out_frames(four, 2);  // frames 1 and 3 remain: enough
  BOOST_TEST(four.frames.size() == 2u);
}

// A held-out frame keeps where its objects are (the largest object mask per pixel), so
// nova eval can score objects and background apart; a frame without object masks keeps none.
BOOST_AUTO_TEST_CASE(held_out_frames_keep_their_objects_region) {
  Scene s;
  s.name = "regions";
  for (int i = 0; i < 4; ++i) {
    Frame f;
    f.time = frame_time(i, 4);
    f.masks = {Image8(3, 1, 1, 255), Image8(3, 1, 1, 0), Image8(3, 1, 1, 0)};
    f.masks[1].data = {200, 10, 0};
    f.masks[2].data = {0, 130, 127};
    s.frames.push_back(f);
  }
  s.frames[2].masks.resize(1);  // the background's alone
  hold_out_frames(s, 2);        // frames 0 and 2
  BOOST_REQUIRE(s.gt_views.size() == 2u);
  const std::vector<uint8_t> expected{200, 130, 127};
  BOOST_TEST(s.gt_views[0].objects.data == expected, boost::test_tools::per_element());
  BOOST_TEST(s.gt_views[0].objects.channels == 1);
  BOOST_TEST(s.gt_views[1].objects.empty());
}

// nova synth writes each ground-truth view's exact objects region beside its image; the
// reader keeps it (every view of the tiny scene sees an object), a view without one keeps
// none, and one of another size than its image is refused naming the file.
BOOST_AUTO_TEST_CASE(ground_truth_views_read_their_objects_region) {
  BOOST_TEST(ground_truth_objects_name("cam0/000.png") == "cam0/000_objects.png");
  BOOST_TEST(ground_truth_objects_name("a.b/c") == "a.b/c_objects.png");
  TempDir tmp("gt-objects");
  const fs::path dir = copy_tiny_scene(tmp);
  {
    const Scene s = load_scene(dir.string());
    BOOST_REQUIRE(!s.gt_views.empty());
    for (const GroundTruthView& v : s.gt_views) {
      BOOST_TEST_REQUIRE(v.objects.width == v.rgb.width, v.name);
      BOOST_TEST(v.objects.height == v.rgb.height, v.name);
      BOOST_TEST(std::count(v.objects.data.begin(), v.objects.data.end(), 255) > 0, v.name);
    }
  }
  fs::remove(dir / "gt" / "cam0" / "001_objects.png");
  write_png((dir / "gt" / "cam0" / "002_objects.png").string(), Image8(5, 4, 1, 255));
  expect_error([&] { load_scene(dir.string()); }, {"002_objects.png", "5x4", "not the size of its image"});
  write_all(dir / "gt" / "cam0" / "002_objects.png", "not a png");
  expect_error([&] { load_scene(dir.string()); }, {"002_objects.png"});
  fs::remove(dir / "gt" / "cam0" / "002_objects.png");
  const Scene s = load_scene(dir.string());
  for (const GroundTruthView& v : s.gt_views)
    BOOST_TEST(v.objects.empty() == (v.name == "cam0/001.png" || v.name == "cam0/002.png"), v.name);
}

BOOST_AUTO_TEST_CASE(bad_missing_frame) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  fs::remove(dir / "images" / "005.png");
  expect_error([&] { load_scene(dir.string()); },
               {"images", "9 images", "poses_bounds.npy has 10 rows", "missing frames"});
}

// A transforms_train.json that does not parse, or parses without what the reader needs, is
// refused naming the file (and for a syntax error its line, for a frame its index).
BOOST_AUTO_TEST_CASE(bad_blender_json) {
  TempDir tmp("bad-blender");
  const fs::path dir = tmp.path();
  fs::create_directories(dir / "train");
  write_png((dir / "train" / "r_0.png").string(), Image8(8, 6, 3, 100));
  const std::string json = (dir / "transforms_train.json").string();
  const std::string frame = R"({"file_path": "./train/r_0", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]})";
  const auto expect = [&](const std::string& text, const std::vector<std::string>& parts) {
    write_all(json, text);
    expect_error([&] { load_scene(dir.string()); }, parts);
  };
  expect("{\"camera_angle_x\": 0.69,\n\"frames\": [}\n", {json + ":2: bad JSON ("});
  expect("{\"camera_angle_x\": 0.69, \"frames\": [" + frame, {json + ":1: bad JSON ("});
  expect("[1, 2]", {json, "no numeric camera_angle_x"});
  expect("{\"camera_angle_x\": true, \"frames\": [" + frame + "]}", {json, "no numeric camera_angle_x"});
  expect("{\"camera_angle_x\": 4, \"frames\": [" + frame + "]}", {json, "camera_angle_x 4.000000 is not in (0, pi)"});
  expect("{\"camera_angle_x\": 0.69}", {json, "no frames"});
  expect("{\"camera_angle_x\": 0.69, \"frames\": []}", {json, "no frames"});
  expect("{\"camera_angle_x\": 0.69, \"frames\": [{\"transform_matrix\": []}]}", {json + ": frame 0 has no file_path"});
  expect("{\"camera_angle_x\": 0.69, \"frames\": [{\"file_path\": \"./train/r_0\", \"transform_matrix\": [[1,0,0,0]]}]}",
         {json + ": frame 0: transform_matrix must be 4x4"});
  expect("{\"camera_angle_x\": 0.69, \"frames\": [{\"file_path\": \"./train/r_0\", "
         "\"transform_matrix\": [[1,0,0,0],[0,1,0,0],[0,0,1,\"4\"],[0,0,0,1]]}]}",
         {json + ": frame 0: transform_matrix holds a non-number"});
  expect("{\"camera_angle_x\": 0.69, \"frames\": [" + frame + ", " +
             R"({"file_path": "./train/r_0", "time": 0.5, "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]})" + "]}",
         {json, "only 1 of 2 frames have a time"});
  expect("{\"camera_angle_x\": 0.69, \"frames\": [" +
             std::string(R"({"file_path": "./train/r_0", "time": "abc", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]})") + "]}",
         {json + ": frame 0: time \"abc\" is not a number"});
  write_png((dir / "train" / "r_1.png").string(), Image8(10, 6, 3, 100));
  expect("{\"camera_angle_x\": 0.69, \"frames\": [" + frame + ", " +
             R"({"file_path": "./train/r_1", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,4],[0,0,0,1]]})" + "]}",
         {"r_1.png: size 10x6 differs from the first frame's 8x6"});
}

// A mask of another aspect ratio (another video's, or a crop: here a third of the width) is
// refused naming the file and both sizes; one of the same aspect ratio at twice the
// resolution is resized to its frame and loads.
BOOST_AUTO_TEST_CASE(bad_mask_aspect_ratio) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  const fs::path mask = dir / "motion_masks" / "1" / "003.png";
  const Image8 m = read_mask(mask.string());
  Image8 narrow(m.width / 3, m.height, 1);
  for (int y = 0; y < narrow.height; ++y)
    for (int x = 0; x < narrow.width; ++x) narrow.data[size_t(y) * narrow.width + x] = m.at(x, y, 0);
  write_png(mask.string(), narrow);
  const std::string mask_size = std::to_string(narrow.width) + "x" + std::to_string(narrow.height);
  const std::string frame_size = std::to_string(m.width) + "x" + std::to_string(m.height);
  expect_error([&] { load_scene(dir.string()); }, {"003.png", mask_size, frame_size, "aspect ratio"});

  Image8 twice(m.width * 2, m.height * 2, 1);
  for (int y = 0; y < twice.height; ++y)
    for (int x = 0; x < twice.width; ++x) twice.data[size_t(y) * twice.width + x] = m.at(x / 2, y / 2, 0);
  write_png(mask.string(), twice);
  const Scene s = load_scene(dir.string());
  BOOST_TEST(s.frames[3].masks[1].width == m.width);
  BOOST_TEST((s.frames[3].masks[1].data == m.data));  // nearest-neighbour halving of a doubled mask
  BOOST_TEST(noted(s, "motion_masks/1/: 1 mask(s) at " + std::to_string(twice.width) + "x" + std::to_string(twice.height)));
  BOOST_TEST(!noted(s, "motion_masks/2/"));  // its masks are at the frames' size
  BOOST_TEST(!noted(s, "warning"));

  // An object whose masks are empty in every frame is loaded with a warning.
  for (const auto& f : fs::directory_iterator(dir / "motion_masks" / "2"))
    write_png(f.path().string(), Image8(m.width, m.height, 1, 0));
  BOOST_TEST(noted(load_scene(dir.string()), "warning: object 2's masks are empty in every frame"));
}

// An alpha channel in a NOVA folder's frames is dropped, and said so; the colours stay.
BOOST_AUTO_TEST_CASE(alpha_in_frames_is_noted) {
  TempDir tmp("alpha");
  const fs::path dir = copy_tiny_scene(tmp);
  const fs::path frame = dir / "images" / "002.png";
  const Image8 rgb = read_rgb(frame.string());
  Image8 rgba(rgb.width, rgb.height, 4);
  for (size_t p = 0; p < size_t(rgb.width) * rgb.height; ++p) {
    for (int c = 0; c < 3; ++c) rgba.data[p * 4 + c] = rgb.data[p * 3 + c];
    rgba.data[p * 4 + 3] = 7;
  }
  write_png(frame.string(), rgba);
  const Scene s = load_scene(dir.string());
  BOOST_TEST((s.frames[2].rgb.data == rgb.data));
  BOOST_TEST(std::any_of(s.notes.begin(), s.notes.end(), [](const std::string& n) {
    return n == "images: 1 with an alpha channel, dropped (frames are opaque)";
  }));
}

BOOST_AUTO_TEST_CASE(bad_extra_frame) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  fs::copy_file(dir / "images" / "000.png", dir / "images" / "010.png");
  expect_error([&] { load_scene(dir.string()); }, {"images", "11 images", "extra frames"});
}

BOOST_AUTO_TEST_CASE(bad_mask_count) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  fs::remove(dir / "motion_masks" / "1" / "003.png");
  expect_error([&] { load_scene(dir.string()); },
               {"motion_masks/1", "9 masks but 10 images", "mask count"});
}

BOOST_AUTO_TEST_CASE(bad_npy_shape) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  write_npy_f64((dir / "poses_bounds.npy").string(), {10, 16}, std::vector<double>(160, 1.0));
  expect_error([&] { load_scene(dir.string()); }, {"poses_bounds.npy", "shape (10, 16)", "(N, 17)"});
}

BOOST_AUTO_TEST_CASE(bad_npy_dtype) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  write_all(dir / "poses_bounds.npy", npy_bytes("<i8", "(10, 17)", std::string(10 * 17 * 8, '\0')));
  expect_error([&] { load_scene(dir.string()); }, {"poses_bounds.npy", "dtype '<i8'"});
}

BOOST_AUTO_TEST_CASE(bad_disparity_shape) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  write_npy_f32((dir / "disp" / "002.npy").string(), {2, 3, 4}, std::vector<float>(24, 1.0f));
  expect_error([&] { load_scene(dir.string()); }, {"disp/002.npy", "2-D"});
}

BOOST_AUTO_TEST_CASE(bad_unreadable_png) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  write_all(dir / "images" / "002.png", "this is not an image");
  expect_error([&] { load_scene(dir.string()); }, {"images/002.png", "not a PNG"});
}

BOOST_AUTO_TEST_CASE(bad_truncated_png) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  const std::string bytes = read_all(dir / "images" / "004.png");
  write_all(dir / "images" / "004.png", bytes.substr(0, bytes.size() / 2));
  expect_error([&] { load_scene(dir.string()); }, {"images/004.png", "truncated PNG"});
}

BOOST_AUTO_TEST_CASE(bad_corrupt_png_body) {
  // Valid signature and IEND, garbage in between: the decoder must refuse it.
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  std::string bytes = read_all(dir / "motion_masks" / "2" / "001.png");
  for (size_t i = 40; i + 12 < bytes.size(); ++i) bytes[i] = char(0x5a);
  write_all(dir / "motion_masks" / "2" / "001.png", bytes);
  expect_error([&] { load_scene(dir.string()); }, {"motion_masks/2/001.png", "cannot decode"});
}

BOOST_AUTO_TEST_CASE(bad_nan_in_poses) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  poke_pose(dir, 3, 7, std::numeric_limits<double>::quiet_NaN());
  expect_error([&] { load_scene(dir.string()); }, {"poses_bounds.npy", "row 3 column 7", "NaN"});
}

BOOST_AUTO_TEST_CASE(bad_inf_in_poses) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  poke_pose(dir, 0, 3, std::numeric_limits<double>::infinity());
  expect_error([&] { load_scene(dir.string()); }, {"poses_bounds.npy", "row 0 column 3", "Inf"});
}

// A pose whose 3x3 part is no rotation (all zero here, or scaled) is refused naming the row.
BOOST_AUTO_TEST_CASE(bad_pose_axes) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  for (size_t c : {0, 1, 2, 5, 6, 7, 10, 11, 12}) poke_pose(dir, 4, c, 0.0);
  expect_error([&] { load_scene(dir.string()); }, {"poses_bounds.npy", "row 4", "not orthonormal"});
}

// Disparity maps the depth terms cannot use (flat, or beyond float32's sums) load with a warning.
BOOST_AUTO_TEST_CASE(unusable_disparity_is_warned_about) {
  TempDir tmp("disp");
  const fs::path dir = copy_tiny_scene(tmp);
  BOOST_TEST(!noted(load_scene(dir.string()), "warning: disp/"));
  std::vector<fs::path> maps;
  for (const auto& f : fs::directory_iterator(dir / "disp")) maps.push_back(f.path());
  const auto scale_all = [&](double by, double plus) {
    for (const fs::path& f : maps) {
      NpyArray a = read_npy(f.string());
      for (double& v : a.values) v = v * by + plus;
      write_npy_f64(f.string(), a.shape, a.values);
    }
  };
  scale_all(1e20, 0.0);
  BOOST_TEST(noted(load_scene(dir.string()), "warning: disp/ holds values up to"));
  scale_all(0.0, 0.5);  // constant
  BOOST_TEST(noted(load_scene(dir.string()), "warning: disp/ varies by less than 1e-3"));
}

BOOST_AUTO_TEST_CASE(bad_near_bound) {
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  poke_pose(dir, 6, 15, 0.0);
  expect_error([&] { load_scene(dir.string()); }, {"poses_bounds.npy", "row 6", "near bound 0 <= 0"});
}

// The CLI turns the error into one line and exit code 2 (reported as skipped where the CLI is
// not built).
BOOST_AUTO_TEST_CASE(bad_input_exit_code_from_cli, *boost::unit_test::precondition([](auto) {
                       return fs::exists(fs::path(NOVA_BINARY_DIR) / "nova");
                     })) {
  const fs::path cli = fs::path(NOVA_BINARY_DIR) / "nova";
  TempDir tmp("bad");
  const fs::path dir = copy_tiny_scene(tmp);
  poke_pose(dir, 1, 15, -1.0);
  const std::string cmd = cli.string() + " scene --scene " + dir.string() + " 2>" +
                          (tmp / "err.txt").string() + " >/dev/null";
  const int status = std::system(cmd.c_str());
  BOOST_TEST(WIFEXITED(status));
  BOOST_TEST(WEXITSTATUS(status) == 2);
  const std::string err = read_all(tmp / "err.txt");
  BOOST_TEST(err.find("near bound -1 <= 0") != std::string::npos, err);
}

BOOST_AUTO_TEST_SUITE_END()
