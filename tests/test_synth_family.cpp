// The synthetic scene family (`nova synth --preset family`): determinism, coverage of the
// sampler, exact shape intersections, masks that follow the first hit, loading through the
// scene reader, and the imperfect training inputs against the exact ground truth. The fixed
// presets' bytes are pinned too, since reference numbers depend on them.
#include <algorithm>
#include <boost/test/unit_test.hpp>
#include <cmath>
#include <map>
#include <set>

#include "data/synth_geometry.hpp"
#include "io/image_codec.hpp"
#include "nova/io/image_io.hpp"
#include "nova/io/npy.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/data/synth.hpp"
#include "scene_test_util.hpp"

using namespace nova;
using namespace nova::test;

namespace {

std::map<std::string, std::string> all_files(const fs::path& root) {
  std::map<std::string, std::string> out;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file()) out[fs::relative(e.path(), root).string()] = read_all(e.path());
  return out;
}

bool is_objects_region(const std::string& name) {
  return name.size() > 12 && name.substr(name.size() - 12) == "_objects.png";
}

// FNV-1a over (path, NUL, content) of every file in path order but the ground-truth views'
// objects regions (added later, beside files that kept their bytes); the content is the
// file's bytes, or with `pixels` a PNG's decoded size, type and pixels (the same under any codec).
uint64_t tree_hash(const fs::path& root, bool pixels = false) {
  uint64_t h = 0xcbf29ce484222325ull;
  auto feed = [&](const std::string& s) {
    for (unsigned char c : s) h = (h ^ c) * 0x100000001b3ull;
  };
  for (const auto& [name, bytes] : all_files(root)) {
    if (is_objects_region(name)) continue;
    feed(name);
    feed(std::string(1, '\0'));
    if (pixels && name.size() > 4 && name.substr(name.size() - 4) == ".png") {
      const cv::Mat m = detail::decode_image(std::vector<unsigned char>(bytes.begin(), bytes.end()),
                                             detail::image_codec());
      feed(std::to_string(m.cols) + "x" + std::to_string(m.rows) + "x" + std::to_string(m.type()));
      for (int y = 0; y < m.rows; ++y)
        feed(std::string(reinterpret_cast<const char*>(m.ptr(y)), m.cols * m.elemSize()));
    } else {
      feed(bytes);
    }
  }
  return h;
}

// The first seed from 0 whose drawn scene satisfies `pred`.
template <class P>
uint32_t find_seed(P pred) {
  for (uint32_t s = 0; s < 500; ++s)
    if (pred(draw_family_scene(s))) return s;
  BOOST_FAIL("no family seed below 500 has the wanted property");
  return 0;
}

// The world-space ray of pixel (i, j) (camera.hpp: direction R ((i-cx)/fx, -(j-cy)/fy, -1)).
std::array<SynthVec, 2> pixel_ray(const Camera& c, int i, int j) {
  const SynthVec dc{(i - c.cx) / c.fx, -(j - c.cy) / c.fy, -1.0};
  SynthVec d{};
  for (int r = 0; r < 3; ++r) d[size_t(r)] = c.c2w[r * 4 + 0] * dc[0] + c.c2w[r * 4 + 1] * dc[1] + c.c2w[r * 4 + 2] * dc[2];
  return {SynthVec{c.c2w[3], c.c2w[7], c.c2w[11]}, d};
}

double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  double ma = 0, mb = 0;
  for (size_t i = 0; i < a.size(); ++i) ma += a[i], mb += b[i];
  ma /= double(a.size());
  mb /= double(b.size());
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  return sab / std::sqrt(saa * sbb);
}

size_t area(const Image8& m) {
  size_t n = 0;
  for (uint8_t v : m.data) n += v != 0;
  return n;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(synth_family)

BOOST_AUTO_TEST_CASE(fixed_presets_keep_their_bytes) {
  // Hash of every file of `--preset tiny --seed 3` as written before the family existed
  // (the same listing md5sum gave): the reference numbers of the project depend on it. The
  // bytes are libpng's (OpenCV's codec); any codec must give the same pixels.
  TempDir tmp("synth-family");
  write_synthetic_scene((tmp / "tiny3").string(), "tiny", 3);
  const auto files = all_files(tmp / "tiny3");
  const auto regions = std::count_if(files.begin(), files.end(), [](const auto& f) { return is_objects_region(f.first); });
  BOOST_TEST(files.size() - regions == 89u);
  BOOST_TEST(regions == 34);  // camera 0 and two held-out cameras at each of 10 times, 4 composition targets
  if (detail::image_codec() == detail::ImageCodec::OpenCV)
    BOOST_TEST(tree_hash(tmp / "tiny3") == 0x2ddaf7a9ddd0652full);
  BOOST_TEST(tree_hash(tmp / "tiny3", true) == 0x67eef2b1c6e0235aull);
  BOOST_TEST(read_all(tmp / "tiny3" / "synth.txt").find("camera") == std::string::npos);
}

BOOST_AUTO_TEST_CASE(same_seed_same_bytes_other_seed_other_scene) {
  TempDir tmp("synth-family");
  write_synthetic_scene((tmp / "a").string(), "family", 5);
  write_synthetic_scene((tmp / "b").string(), "family", 5);
  write_synthetic_scene((tmp / "c").string(), "family", 6);
  const auto a = all_files(tmp / "a"), b = all_files(tmp / "b"), c = all_files(tmp / "c");
  BOOST_TEST(a.size() == b.size());
  BOOST_TEST(a.size() > 80u);
  for (const auto& [name, bytes] : a) BOOST_TEST((b.count(name) && b.at(name) == bytes), name);
  BOOST_TEST(a.at("synth.txt") != c.at("synth.txt"));
  BOOST_TEST(a.at("images/000.png") != c.at("images/000.png"));
  // Different seeds draw different scenes, not only different textures.
  std::set<std::string> descriptions;
  for (uint32_t s = 0; s < 50; ++s) descriptions.insert(describe_synth_scene(draw_family_scene(s)));
  BOOST_TEST(descriptions.size() == 50u);
}

BOOST_AUTO_TEST_CASE(sampler_covers_the_family) {
  std::map<SynthShapeKind, int> shapes;
  std::map<SynthCameraKind, int> paths;
  std::map<size_t, int> counts;
  int eroded = 0, dilated = 0, jagged = 0, disparity = 0, exposure = 0, clean = 0, leaving = 0;
  std::set<std::pair<int, int>> sizes;
  for (uint32_t seed = 0; seed < 200; ++seed) {
    const SynthScene s = draw_family_scene(seed);
    const SynthPreset& p = s.preset;
    BOOST_TEST_CONTEXT("seed " << seed) {
      BOOST_TEST((p.frames >= 12 && p.frames <= 16));
      BOOST_TEST((p.width * p.height >= 12000 && p.width * p.height <= 21000));
      const double fov = 2 * std::atan(0.5 * p.width / p.focal) * 180 / synth::kPi;
      BOOST_TEST((fov >= 45 - 1e-9 && fov <= 65 + 1e-9));
      BOOST_TEST(int(s.camera.positions.size()) == p.frames);
      BOOST_TEST(s.camera.heldout.size() == 2u);
      // Forward-facing: every camera looks along -z at the wall (within 30 degrees).
      for (const auto& c : s.camera.positions) {
        const SynthVec v = synth::normalize(synth::sub(s.camera.target, c));
        BOOST_TEST(v[2] < -std::cos(30 * synth::kPi / 180));
        BOOST_TEST(s.camera.target[2] > s.background.wall_z);
      }
      if (s.camera.kind == SynthCameraKind::rig) {
        const int c = s.camera.rig_cameras;
        BOOST_TEST((c >= 4 && c <= 8));
        for (int i = 0; i < p.frames; ++i)
          BOOST_TEST((s.camera.positions[size_t(i)] == s.camera.positions[size_t(i % c)]));
        BOOST_TEST((s.camera.positions[0] != s.camera.positions[1]));
      }
      // Props: 1-3, apart from one another, in front of the wall, resting on the floor.
      const auto& props = s.background.props;
      BOOST_TEST((props.size() >= 1u && props.size() <= 3u));
      for (size_t a = 0; a < props.size(); ++a) {
        const double ra = synth_bounding_radius(props[a].shape);
        BOOST_TEST(props[a].centre[2] - ra > s.background.wall_z);
        for (size_t b = 0; b < a; ++b) {
          const SynthVec d = synth::sub(props[a].centre, props[b].centre);
          BOOST_TEST(std::sqrt(synth::dot(d, d)) > ra + synth_bounding_radius(props[b].shape));
        }
      }
      // Objects: in front of the wall, beyond 1.4 from the cameras' plane, above the floor.
      for (const auto& o : s.objects) {
        const double r = synth_bounding_radius(o.shape);
        for (const auto& q : {o.motion.p0, o.motion.p2}) {
          BOOST_TEST(-q[2] - r >= 1.4 - 1e-9);
          BOOST_TEST(q[2] - r > s.background.wall_z);
          BOOST_TEST(q[1] - r > s.background.floor_y);
        }
        shapes[o.shape.kind]++;
        const double half_w = -o.motion.p0[2] * 0.5 * p.width / p.focal;
        leaving += std::abs(o.motion.p0[0]) > 0.9 * half_w || std::abs(o.motion.p2[0]) > 0.9 * half_w;
      }
    }
    sizes.insert({p.width, p.height});
    paths[s.camera.kind]++;
    counts[s.objects.size()]++;
    const SynthImperfections& imp = s.imperfections;
    eroded += imp.mask_grow < 0;
    dilated += imp.mask_grow > 0;
    jagged += imp.mask_jagged;
    disparity += imp.disparity;
    exposure += !imp.gains.empty();
    clean += !imp.any();
  }
  BOOST_TEST(shapes.size() == 8u);
  for (const auto& [k, n] : shapes) BOOST_TEST(n >= 10, synth_shape_name(k) << ": " << n);
  BOOST_TEST(paths.size() == 3u);
  BOOST_TEST(paths.count(SynthCameraKind::legacy_slide) == 0u);
  for (const auto& [k, n] : paths) BOOST_TEST(n >= 30, synth_camera_name(k) << ": " << n);
  BOOST_TEST(counts.size() == 3u);
  for (size_t k = 1; k <= 3; ++k) BOOST_TEST(counts[k] >= 30, k << " objects: " << counts[k]);
  BOOST_TEST(sizes.size() == 6u);
  BOOST_TEST_MESSAGE("eroded " << eroded << " dilated " << dilated << " jagged " << jagged
                     << " disparity " << disparity << " exposure " << exposure << " clean "
                     << clean << " paths leaving the frame " << leaving);
  for (int n : {eroded, dilated, jagged, disparity, exposure, clean, leaving}) BOOST_TEST(n >= 10);
}

BOOST_AUTO_TEST_CASE(shape_intersections_are_exact) {
  using K = SynthShapeKind;
  struct Case {
    SynthShape shape;
    SynthVec o, d;
    double t;      // expected hit, -1 for a miss
    SynthVec n;    // expected normal at the hit
  };
  const std::vector<Case> cases = {
      {{K::sphere, {0.5, 0.5, 0.5}}, {0, 0, 5}, {0, 0, -1}, 4.5, {0, 0, 1}},
      {{K::sphere, {0.5, 0.5, 0.5}}, {0, 0, 5}, {0, 0, -2}, 2.25, {0, 0, 1}},  // t scales with |d|
      {{K::sphere, {0.5, 0.5, 0.5}}, {0.6, 0, 5}, {0, 0, -1}, -1, {}},
      {{K::box, {0.3, 0.4, 0.5}}, {0, 0, 5}, {0, 0, -1}, 4.5, {0, 0, 1}},
      {{K::box, {0.3, 0.4, 0.5}}, {5, 0.1, 0.1}, {-1, 0, 0}, 4.7, {1, 0, 0}},
      {{K::box, {0.3, 0.4, 0.5}}, {0, 0.45, 5}, {0, 0, -1}, -1, {}},
      {{K::cylinder, {0.4, 0.6, 0}}, {5, 0, 0}, {-1, 0, 0}, 4.6, {1, 0, 0}},
      {{K::cylinder, {0.4, 0.6, 0}}, {0, 5, 0}, {0, -1, 0}, 4.4, {0, 1, 0}},
      {{K::cylinder, {0.4, 0.6, 0}}, {5, 0.7, 0}, {-1, 0, 0}, -1, {}},
      // Torus (major 0.6, minor 0.2): through the tube along z; along y through the hole.
      {{K::torus, {0.6, 0.2, 0}}, {0, 0, 5}, {0, 0, -1}, 4.2, {0, 0, 1}},
      {{K::torus, {0.6, 0.2, 0}}, {0.6, 5, 0}, {0, -1, 0}, 4.8, {0, 1, 0}},
      {{K::torus, {0.6, 0.2, 0}}, {0, 5, 0}, {0, -1, 0}, -1, {}},
      {{K::torus, {0.6, 0.2, 0}}, {0, 0.25, 5}, {0, 0, -1}, -1, {}},
      {{K::disc, {0.5, 0.03, 0}}, {0, 5, 0}, {0, -1, 0}, 4.97, {0, 1, 0}},
      {{K::disc, {0.5, 0.03, 0}}, {5, 0.05, 0}, {-1, 0, 0}, -1, {}},
      {{K::rod, {0.05, 0.8, 0}}, {5, 0, 0}, {-1, 0, 0}, 4.95, {1, 0, 0}},
      {{K::rod, {0.05, 0.8, 0}}, {5, 0, 0.06}, {-1, 0, 0}, -1, {}},
      // Dumbbell (balls 0.3 at x = +-0.6, bar 0.1): a ball, the bar, beside the bar.
      {{K::dumbbell, {0.3, 0.6, 0.1}}, {0.6, 5, 0}, {0, -1, 0}, 4.7, {0, 1, 0}},
      {{K::dumbbell, {0.3, 0.6, 0.1}}, {0, 5, 0}, {0, -1, 0}, 4.9, {0, 1, 0}},
      {{K::dumbbell, {0.3, 0.6, 0.1}}, {0, 5, 0.15}, {0, -1, 0}, -1, {}},
      {{K::dumbbell, {0.3, 0.6, 0.1}}, {5, 0, 0}, {-1, 0, 0}, 4.1, {1, 0, 0}},
      // L (x half 0.5, y half 0.6, bars 0.2 thick, corner at -x -y): a ray into the notch
      // misses (non-convex); from above, x = 0.3 lands on the foot, x = -0.4 on the upright.
      {{K::ell, {0.5, 0.6, 0.1}}, {0.3, 0.3, 5}, {0, 0, -1}, -1, {}},
      {{K::ell, {0.5, 0.6, 0.1}}, {0.3, 5, 0}, {0, -1, 0}, 5.4, {0, 1, 0}},
      {{K::ell, {0.5, 0.6, 0.1}}, {-0.4, 5, 0}, {0, -1, 0}, 4.4, {0, 1, 0}},
      {{K::ell, {0.5, 0.6, 0.1}}, {5, 0.3, 0}, {-1, 0, 0}, 5.3, {1, 0, 0}},
  };
  for (const auto& c : cases) {
    BOOST_TEST_CONTEXT(synth_shape_name(c.shape.kind) << " from (" << c.o[0] << "," << c.o[1] << ","
                                                       << c.o[2] << ")") {
      const synth::ShapeHit h = synth::intersect_shape(c.shape, c.o, c.d);
      BOOST_TEST(synth_intersect(c.shape, c.o, c.d) == h.t);
      if (c.t < 0) {
        BOOST_TEST(h.t == -1.0);
        continue;
      }
      // Closed forms are exact to rounding; the torus marches to a distance below 1e-10.
      BOOST_TEST(std::abs(h.t - c.t) < 1e-9, "t " << h.t << " want " << c.t);
      const SynthVec n = synth::shape_normal(c.shape, synth::add(c.o, synth::mul(c.d, h.t)), h.part);
      for (int k = 0; k < 3; ++k) BOOST_TEST(std::abs(n[size_t(k)] - c.n[size_t(k)]) < 1e-6);
    }
  }
  // Grazing the sphere from outside its radius misses; a ray starting inside hits the far side.
  BOOST_TEST(synth_intersect({K::sphere, {1, 1, 1}}, {0, 0, 0}, {1, 0, 0}) == 1.0);
  BOOST_TEST(synth_intersect({K::box, {1, 1, 1}}, {0, 0, 5}, {0, 0, 1}) == -1.0);  // behind
}

// Per pixel, the owner is recomputed from the shapes' own intersections (object frames from
// object_pose, axes scaled by object_stretch) against the background-only depth; the render's
// masks and depth must agree. A scene with three objects exercises the occlusion order.
static void check_masks_follow_the_first_hit(const SynthWorld& w, uint32_t seed) {
  const int n = w.preset().frames;
  size_t mismatched = 0, object_pixels = 0, occluded_pairs = 0;
  for (int frame : {0, n / 2, n - 1}) {
    const double time = frame_time(frame, n);
    const Camera cam = w.camera(frame);
    const SynthRender r = w.render(cam, time);
    const SynthRender bg = w.render_instances(cam, true, {});
    BOOST_TEST(r.masks.size() == 4u);
    for (int j = 0; j < cam.height; ++j)
      for (int i = 0; i < cam.width; ++i) {
        const auto [o, d] = pixel_ray(cam, i, j);
        double best = bg.depth.data[size_t(j) * cam.width + i];
        BOOST_TEST(best > 0);  // the wall is behind everything
        int owner = 0, hits = 0;
        for (int k = 1; k <= 3; ++k) {
          const Pose34 m = w.object_pose(k, time);
          const SynthVec st = w.object_stretch(k, time);
          // Into the object frame: R^T (o - c) / stretch, R^T d / stretch.
          SynthVec ol{}, dl{};
          for (int a = 0; a < 3; ++a) {
            ol[size_t(a)] = (m[0 * 4 + a] * (o[0] - m[3]) + m[1 * 4 + a] * (o[1] - m[7]) + m[2 * 4 + a] * (o[2] - m[11])) / st[size_t(a)];
            dl[size_t(a)] = (m[0 * 4 + a] * d[0] + m[1 * 4 + a] * d[1] + m[2 * 4 + a] * d[2]) / st[size_t(a)];
          }
          const double t = synth_intersect(w.scene().objects[size_t(k - 1)].shape, ol, dl);
          hits += t > 0 && t < bg.depth.data[size_t(j) * cam.width + i];
          if (t > 0 && t < best) best = t, owner = k;
        }
        occluded_pairs += hits >= 2;
        object_pixels += owner > 0;
        bool ok = r.masks[size_t(owner)].at(i, j) == 255;
        for (int k = 0; k <= 3; ++k) ok = ok && ((r.masks[size_t(k)].at(i, j) == 255) == (k == owner));
        ok = ok && std::abs(r.depth.data[size_t(j) * cam.width + i] - float(best)) <= 1e-5f * float(best);
        mismatched += !ok;
      }
  }
  BOOST_TEST_MESSAGE("seed " << seed << ": " << object_pixels << " object pixels, "
                     << occluded_pairs << " with two objects on the ray");
  BOOST_TEST(object_pixels > 200u);
  // Our own change of frame rounds differently from the tracer's (1e-16 relative): a ray
  // grazing a silhouette may flip, nothing more.
  BOOST_TEST(mismatched <= 3u);
}

BOOST_AUTO_TEST_CASE(masks_follow_the_first_hit) {
  const uint32_t seed = find_seed([](const SynthScene& s) { return s.objects.size() == 3; });
  check_masks_follow_the_first_hit(SynthWorld(draw_family_scene(seed)), seed);
}

BOOST_AUTO_TEST_CASE(deforming_objects_follow_the_first_hit) {
  const uint32_t seed = find_seed([](const SynthScene& s) { return s.objects.size() == 3; });
  check_masks_follow_the_first_hit(SynthWorld(draw_deforming_scene(seed)), seed);
}

BOOST_AUTO_TEST_CASE(deforming_is_the_family_scene_with_objects_changing_shape) {
  // Same seed: the same world but for the objects' stretch, so the frames agree wherever
  // neither render shows an object, and the objects' areas change over time where the
  // family's rigid ones keep theirs up to the spin and the perspective.
  const uint32_t seed = 104;
  const SynthScene fs = draw_family_scene(seed), ds = draw_deforming_scene(seed);
  BOOST_TEST(ds.preset.name == "deforming");
  BOOST_TEST(ds.preset.width == fs.preset.width);
  BOOST_TEST(ds.preset.frames == fs.preset.frames);
  BOOST_TEST(ds.objects.size() == fs.objects.size());
  for (size_t k = 0; k < ds.objects.size(); ++k) {
    const SynthMotion &a = fs.objects[k].motion, &b = ds.objects[k].motion;
    BOOST_TEST(a.spin_rate == b.spin_rate);
    BOOST_TEST(a.p2[0] == b.p2[0]);
    BOOST_TEST((a.stretch == SynthVec{0, 0, 0}));
    // One axis stretches by 25-45 %, the other two shrink by half as much.
    const double big = *std::max_element(b.stretch.begin(), b.stretch.end());
    BOOST_TEST(big >= 0.25);
    BOOST_TEST(big <= 0.45);
    BOOST_TEST(b.stretch[0] + b.stretch[1] + b.stretch[2] == 0.0, boost::test_tools::tolerance(1e-12));
  }
  const SynthWorld fw(fs), dw(ds);
  const int n = fw.preset().frames;
  size_t differ_outside = 0, compared = 0;
  const size_t K = ds.objects.size();
  std::vector<double> min_ratio(K + 1, 1e9), max_ratio(K + 1, 0);
  for (int frame = 0; frame < n; ++frame) {
    const double t = frame_time(frame, n);
    const SynthRender a = fw.render(fw.camera(frame), t), b = dw.render(dw.camera(frame), t);
    for (int j = 0; j < a.rgb.height; ++j)
      for (int i = 0; i < a.rgb.width; ++i)
        if (a.masks[0].at(i, j) == 255 && b.masks[0].at(i, j) == 255) {
          ++compared;
          for (int c = 0; c < 3; ++c) differ_outside += a.rgb.at(i, j, c) != b.rgb.at(i, j, c);
        }
    for (size_t k = 1; k <= K; ++k) {
      size_t area_a = 0, area_b = 0;
      for (size_t p = 0; p < a.masks[k].data.size(); ++p) area_a += a.masks[k].data[p] == 255, area_b += b.masks[k].data[p] == 255;
      if (area_a < 40) continue;  // mostly hidden or out of the frame: the ratio is noise
      min_ratio[k] = std::min(min_ratio[k], double(area_b) / area_a);
      max_ratio[k] = std::max(max_ratio[k], double(area_b) / area_a);
    }
  }
  BOOST_TEST(compared > 1000u);
  BOOST_TEST(differ_outside == 0u);
  double widest = 0;
  for (size_t k = 1; k <= K; ++k) {
    BOOST_TEST_MESSAGE("object " << k << "'s area, deforming / family: " << min_ratio[k] << " to " << max_ratio[k]);
    widest = std::max(widest, max_ratio[k] - min_ratio[k]);
  }
  BOOST_TEST(widest > 0.2);
  BOOST_TEST(describe_synth_scene(ds).find("stretch") != std::string::npos);
  BOOST_TEST(describe_synth_scene(fs).find("stretch") == std::string::npos);
}

BOOST_AUTO_TEST_CASE(written_scene_loads) {
  const uint32_t seed = find_seed([](const SynthScene& s) {
    return s.objects.size() == 3 && s.camera.kind == SynthCameraKind::rig && s.imperfections.disparity;
  });
  const SynthScene drawn = draw_family_scene(seed);
  TempDir tmp("synth-family");
  write_synthetic_scene((tmp / "scene").string(), "family", seed);
  const Scene s = load_scene((tmp / "scene").string());
  BOOST_TEST(s.format == "nova");
  BOOST_TEST(s.num_objects == 3);
  BOOST_TEST(int(s.frames.size()) == drawn.preset.frames);
  BOOST_TEST(s.ndc);
  BOOST_TEST(s.gt_views.size() == size_t(3 * drawn.preset.frames));
  BOOST_TEST(s.compose.targets.size() == 4u);
  BOOST_TEST(s.compose_gt.size() == 4u);
  for (const Frame& f : s.frames) {
    BOOST_TEST(f.rgb.width == drawn.preset.width);
    BOOST_TEST(f.rgb.height == drawn.preset.height);
    BOOST_TEST(f.masks.size() == 4u);
    BOOST_REQUIRE(!f.disparity.empty());
    size_t bad = 0;
    for (float v : f.disparity.data) bad += !(std::isfinite(v) && v > 0);
    BOOST_TEST(bad == 0u, f.name);
  }
  // Rig: frames C apart come from the same camera.
  const int c = drawn.camera.rig_cameras;
  BOOST_TEST((s.frames[0].camera.c2w == s.frames[size_t(c)].camera.c2w));
  BOOST_TEST((s.frames[0].camera.c2w != s.frames[1].camera.c2w));
  BOOST_TEST(read_all(tmp / "scene" / "synth.txt").find("camera rig of " + std::to_string(c)) !=
             std::string::npos);
}

BOOST_AUTO_TEST_CASE(imperfect_inputs_exact_ground_truth) {
  // Disparity: written = scale * blur(exact) + shift, so it correlates with the exact inverse
  // depth (> 0.9; blur only softens silhouettes) and matches the affine map on average, yet
  // differs from it at edges. Masks: dilated ones contain the exact mask, eroded ones lie
  // within it. Images carry the frame's gain; gt/cam0 stays the exact render.
  const uint32_t seed = find_seed([](const SynthScene& s) {
    return s.imperfections.disparity && s.imperfections.mask_grow > 0 && !s.imperfections.mask_jagged &&
           !s.imperfections.gains.empty();
  });
  const SynthWorld w(draw_family_scene(seed));
  const SynthImperfections& imp = w.scene().imperfections;
  TempDir tmp("synth-family");
  write_synthetic_scene((tmp / "scene").string(), "family", seed);
  const int n = w.preset().frames, frame = n / 2;
  const SynthRender r = w.render(w.camera(frame), frame_time(frame, n));
  const std::string name = std::string(frame < 10 ? "00" : "0") + std::to_string(frame);
  const NpyArray disp = read_npy((tmp / "scene" / "disp" / (name + ".npy")).string());
  std::vector<double> exact, mapped;
  double max_dev = 0, mean_written = 0, mean_mapped = 0;
  for (size_t p = 0; p < r.depth.data.size(); ++p) {
    exact.push_back(1.0 / r.depth.data[p]);
    mapped.push_back(imp.disp_scale * exact.back() + imp.disp_shift);
    mean_written += disp.values[p];
    mean_mapped += mapped.back();
    max_dev = std::max(max_dev, std::abs(disp.values[p] - mapped.back()));
  }
  const double corr = correlation(exact, disp.values);
  BOOST_TEST_MESSAGE("seed " << seed << ": disparity correlation " << corr << ", max deviation "
                     << max_dev << " (mean mapped " << mean_mapped / double(exact.size()) << ")");
  BOOST_TEST(corr > 0.9);
  BOOST_TEST(std::abs(mean_written - mean_mapped) < 0.02 * mean_mapped);
  BOOST_TEST(max_dev > 0.05 * mean_mapped / double(exact.size()));  // blurred at silhouettes

  // A clean scene's disparity is the exact inverse depth.
  const uint32_t clean = find_seed([](const SynthScene& s) { return !s.imperfections.any(); });
  ImageF inv = r.depth;
  for (float& v : inv.data) v = 1.0f / v;
  BOOST_TEST((synth_training_disparity(inv, draw_family_scene(clean).imperfections).data == inv.data));

  for (int k = 1; k <= w.objects(); ++k) {
    const Image8 m = read_mask((tmp / "scene" / "motion_masks" / std::to_string(k) / (name + ".png")).string());
    size_t missing = 0;
    for (size_t p = 0; p < m.data.size(); ++p) missing += r.masks[size_t(k)].data[p] && !m.data[p];
    BOOST_TEST(missing == 0u);
    if (area(r.masks[size_t(k)]) > 0) BOOST_TEST(area(m) > area(r.masks[size_t(k)]));
  }
  // Erosion keeps masks inside the exact one and shrinks them.
  SynthImperfections erode;
  erode.mask_grow = -2;
  const std::vector<Image8> eroded = synth_training_masks(r.masks, erode, frame);
  for (int k = 1; k <= w.objects(); ++k) {
    size_t outside = 0;
    for (size_t p = 0; p < eroded[size_t(k)].data.size(); ++p)
      outside += eroded[size_t(k)].data[p] && !r.masks[size_t(k)].data[p];
    BOOST_TEST(outside == 0u);
    if (area(r.masks[size_t(k)]) > 30) BOOST_TEST(area(eroded[size_t(k)]) < area(r.masks[size_t(k)]));
  }

  const Image8 img = read_rgb((tmp / "scene" / "images" / (name + ".png")).string());
  double sum_img = 0, sum_exact = 0;
  for (size_t p = 0; p < img.data.size(); ++p) sum_img += img.data[p], sum_exact += r.rgb.data[p];
  BOOST_TEST(std::abs(sum_img / sum_exact - imp.gains[size_t(frame)]) < 0.01);
  const SynthRender r0 = w.render(w.camera(0), frame_time(0, n));
  BOOST_TEST((read_rgb((tmp / "scene" / "gt" / "cam0" / "000.png").string()).data == r0.rgb.data));
}

BOOST_AUTO_TEST_SUITE_END()
