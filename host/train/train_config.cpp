// The option registry of TrainConfig: every `nova train` option with its help, its parser
// and its range, and the checks across options.
#include "nova/train/train_config.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <sstream>

#include "nova/runtime/error.hpp"
#include "runtime/parse_number.hpp"
#include "train/config_trim.hpp"

namespace nova {
namespace {

using detail::trim;

[[noreturn]] void bad_value(const std::string& key, const std::string& value, const std::string& why) {
  throw Error("option '" + key + "': '" + value + "' " + why);
}

long parse_int(const std::string& key, const std::string& text, long lo, long hi) {
  const std::string v = trim(text);
  long x = 0;
  auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), x);
  if (ec != std::errc() || end != v.data() + v.size() || v.empty())
    bad_value(key, text, "is not an integer");
  if (x < lo || x > hi)
    bad_value(key, text, "is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
  return x;
}

float parse_float(const std::string& key, const std::string& text, double lo, double hi) {
  const std::string v = trim(text);
  const std::optional<double> parsed = parse_whole_double(v);
  if (!parsed) bad_value(key, text, "is not a number");
  const double x = *parsed;
  if (!std::isfinite(x)) bad_value(key, text, "is not finite");
  std::ostringstream range;
  range << "is out of range [" << lo << ", " << hi << "]";
  if (x < lo || x > hi) bad_value(key, text, range.str());
  // Read straight to float where the syntax allows (no leading '+'): rounding through double
  // could move a shortest-form value written by fmt() to the neighbouring float.
  float f = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), f);
  if (ec == std::errc() && end == v.data() + v.size()) return f;
  return static_cast<float>(x);
}

bool parse_bool(const std::string& key, const std::string& text) {
  const std::string v = trim(text);
  if (v == "1" || v == "true" || v == "on" || v == "yes") return true;
  if (v == "0" || v == "false" || v == "off" || v == "no") return false;
  bad_value(key, text, "is not a boolean (true/false, on/off, 1/0)");
}

// The shortest text that reads back as the same float: config.ini must restore a run exactly
// (resume) and read as typed (0.05, not 0.0500000007).
std::string fmt(float x) {
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, x);
  return ec == std::errc() ? std::string(buf, end) : std::to_string(x);
}

// Table builders: a member (reached through `field`) and its admissible range.
template <class F>
ConfigOption int_option(std::string key, std::string help, long lo, long hi, F field) {
  return {key, std::move(help),
          [field](const TrainConfig& c) { return std::to_string(field(const_cast<TrainConfig&>(c))); },
          [field, key, lo, hi](TrainConfig& c, const std::string& v) {
            field(c) = static_cast<std::remove_reference_t<decltype(field(c))>>(parse_int(key, v, lo, hi));
          }};
}

template <class F>
ConfigOption float_option(std::string key, std::string help, double lo, double hi, F field) {
  return {key, std::move(help),
          [field](const TrainConfig& c) { return fmt(field(const_cast<TrainConfig&>(c))); },
          [field, key, lo, hi](TrainConfig& c, const std::string& v) { field(c) = parse_float(key, v, lo, hi); }};
}

template <class F>
ConfigOption bool_option(std::string key, std::string help, F field) {
  return {key, std::move(help),
          [field](const TrainConfig& c) { return std::string(field(const_cast<TrainConfig&>(c)) ? "true" : "false"); },
          [field, key](TrainConfig& c, const std::string& v) { field(c) = parse_bool(key, v); }};
}

// A switch between nova's own convention (false) and the reference code's (true), written as
// one of two words; `before` is nova's word (what a run file without the key meant).
template <class F>
ConfigOption convention_option(std::string key, std::string help, std::string nova_word,
                               std::string reference_word, F field) {
  ConfigOption o{key, std::move(help),
                 [field, nova_word, reference_word](const TrainConfig& c) {
                   return field(const_cast<TrainConfig&>(c)) ? reference_word : nova_word;
                 },
                 [field, key, nova_word, reference_word](TrainConfig& c, const std::string& v) {
                   const std::string t = trim(v);
                   if (t == nova_word) field(c) = false;
                   else if (t == reference_word) field(c) = true;
                   else bad_value(key, v, "is not one of " + nova_word + ", " + reference_word);
                 }};
  o.before = nova_word;
  return o;
}

std::vector<ConfigOption> make_options() {
  constexpr long kBig = 100000000;
  std::vector<ConfigOption> o;
  o.push_back({"preset", "configuration the other values start from: quick (2-core CPU) or reference (the paper's, a GPU job)",
               [](const TrainConfig& c) { return c.preset; },
               [](TrainConfig& c, const std::string& v) { c = preset_config(trim(v)); }});
  o.push_back(int_option("depth", "trunk layers of every NeRF", 1, 32, [](TrainConfig& c) -> int& { return c.field.depth; }));
  o.push_back(int_option("width", "trunk width of every NeRF", 1, 4096, [](TrainConfig& c) -> int& { return c.field.width; }));
  o.push_back(int_option("skip", "0-based trunk layer whose output gets the encoded input re-fed (-1: none)", -1, 31,
                         [](TrainConfig& c) -> int& { return c.field.skip; }));
  o.push_back(int_option("pos-freqs", "positional-encoding frequencies of xyz (and t)", 0, 24,
                         [](TrainConfig& c) -> int& { return c.field.pos_freqs; }));
  o.push_back(int_option("dir-freqs", "positional-encoding frequencies of the view direction", 0, 24,
                         [](TrainConfig& c) -> int& { return c.field.dir_freqs; }));
  o.push_back(bool_option("view-dirs", "static colour depends on the view direction",
                          [](TrainConfig& c) -> bool& { return c.field.view_dirs; }));
  o.push_back({"encoding", "input encoding of xyz (and t): frequency (the paper's) or hashgrid (multiresolution hash grid)",
               [](const TrainConfig& c) { return std::string(encoding_name(c.field.encoding)); },
               [](TrainConfig& c, const std::string& v) {
                 const std::string t = trim(v);
                 if (t == "frequency") c.field.encoding = Encoding::Frequency;
                 else if (t == "hashgrid") c.field.encoding = Encoding::HashGrid;
                 else bad_value("encoding", v, "is not one of frequency, hashgrid");
               }});
  o.push_back(int_option("hash-levels", "hash grid: resolution levels", 1, 32,
                         [](TrainConfig& c) -> int& { return c.field.hash.levels; }));
  o.push_back(int_option("hash-features", "hash grid: features per level", 1, 8,
                         [](TrainConfig& c) -> int& { return c.field.hash.features; }));
  o.push_back(int_option("hash-log2-size", "hash grid: log2 of the table entries per level", 4, 24,
                         [](TrainConfig& c) -> int& { return c.field.hash.log2_size; }));
  o.push_back(int_option("hash-min-res", "hash grid: cells per dimension of the coarsest level", 1, 1 << 20,
                         [](TrainConfig& c) -> int& { return c.field.hash.min_resolution; }));
  o.push_back(int_option("hash-max-res", "hash grid: cells per dimension of the finest level", 1, 1 << 20,
                         [](TrainConfig& c) -> int& { return c.field.hash.max_resolution; }));
  o.push_back({"hash-time-res", "hash grid of the object NeRFs: most cells along time per level (time spans [-1, 1]): auto (about 3 frames per cell), 0 (as space) or a count",
               [](const TrainConfig& c) {
                 return c.field.hash_time_auto ? std::string("auto") : std::to_string(c.field.hash.time_max_resolution);
               },
               [](TrainConfig& c, const std::string& v) {
                 c.field.hash_time_auto = trim(v) == "auto";
                 if (!c.field.hash_time_auto)
                   c.field.hash.time_max_resolution = static_cast<int>(parse_int("hash-time-res", v, 0, 1 << 20));
               }});
  o.push_back(int_option("hash-object-max-res", "hash grid of the object NeRFs: cells per dimension of the finest level (0: hash-max-res)", 0, 1 << 20,
                         [](TrainConfig& c) -> int& { return c.field.object_max_resolution; }));
  o.back().before = "0";
  o.push_back(int_option("hash-canonical-max-res", "hash grid of a rigid object's canonical field (object-motion rigid): cells per dimension of the finest level (0: hash-object-max-res)", 0, 1 << 20,
                         [](TrainConfig& c) -> int& { return c.field.canonical_max_resolution; }));
  o.back().before = "0";
  o.push_back(int_option("canonical-colour-time-freqs", "object-motion rigid: a canonical field's colour also reads time, encoded with this many frequencies, as the shade of a turning object changes under a fixed light (-1: colour of the position alone; density never reads time)", -1, 24,
                         [](TrainConfig& c) -> int& { return c.field.canonical_colour_time_freqs; }));
  o.back().before = "-1";
  o.push_back(int_option("deform-width", "object-motion rigid: width of a deformation network that moves each canonical sample as a function of its position and time, for objects that change shape (0: none, the shape stays rigid)", 0, 1024,
                         [](TrainConfig& c) -> int& { return c.field.deform_width; }));
  o.back().before = "0";
  o.push_back(float_option("deform-bound", "object-motion rigid, deform-width > 0: the most a deformation moves a sample (NDC units; the metric scene's otherwise)", 1e-4, 10.0,
                           [](TrainConfig& c) -> float& { return c.field.deform_bound; }));
  o.back().before = "0.05";
  o.push_back(float_option("hash-bound", "hash grid: half-size of the encoded box (0: from the scene: NDC, the training rays' extent (see hash-ndc-box-from-rays); else the largest camera coordinate)",
                           0.0, 1e6, [](TrainConfig& c) -> float& { return c.field.hash.bound; }));
  o.push_back(bool_option("hash-ndc-box-from-rays", "NDC scenes, hash-bound 0: the encoded box holds every training ray along x and y (more than [-1, 1] where the camera moves sideways); false: [-1, 1]^3",
                          [](TrainConfig& c) -> bool& { return c.field.ndc_box_from_rays; }));
  o.back().before = "false";
  o.push_back(bool_option("hash-extend", "hash grid: fine (hashed) levels encode points outside the box in cells of their own instead of clamping them to its face",
                          [](TrainConfig& c) -> bool& { return c.field.hash.extend; }));
  o.back().before = "false";
  o.push_back(int_option("rays", "rays per step, split evenly over the background and each object", 1, 1 << 20,
                         [](TrainConfig& c) -> int& { return c.rays; }));
  o.push_back(int_option("samples", "stratified samples per ray", 2, 1024, [](TrainConfig& c) -> int& { return c.samples; }));
  o.push_back(float_option("noise-std", "std of the density noise while training", 0.0, 1e3,
                           [](TrainConfig& c) -> float& { return c.noise_std; }));
  o.push_back(int_option("pretrain-steps", "steps of the static NeRF alone on background pixels", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.pretrain_steps; }));
  o.push_back(int_option("steps", "steps of joint training (all NeRFs, all losses)", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.steps; }));
  o.push_back(float_option("lr", "Adam learning rate at the start of each phase", 1e-8, 1.0,
                           [](TrainConfig& c) -> float& { return c.lr; }));
  o.push_back(float_option("lr-decay", "factor the learning rate decays by over lr-decay-steps", 1e-6, 1.0,
                           [](TrainConfig& c) -> float& { return c.lr_decay; }));
  o.push_back(int_option("lr-decay-steps", "steps over which the learning rate falls by lr-decay", 1, kBig,
                         [](TrainConfig& c) -> int& { return c.lr_decay_steps; }));
  o.push_back(float_option("adam-beta2", "Adam's decay of the squared-gradient average", 0.0, 0.999999,
                           [](TrainConfig& c) -> float& { return c.adam.beta2; }));
  o.back().before = "0.999";
  o.push_back(float_option("adam-eps", "Adam's epsilon (added to the root of the squared-gradient average)", 1e-30, 1.0,
                           [](TrainConfig& c) -> float& { return c.adam.eps; }));
  o.back().before = "1e-08";
  o.push_back(bool_option("augment", "novel-view augmentation of the object cameras",
                          [](TrainConfig& c) -> bool& { return c.augment; }));
  o.push_back(int_option("augment-every", "every n-th joint step is augmented", 1, kBig,
                         [](TrainConfig& c) -> int& { return c.augment_every; }));
  o.push_back(int_option("augment-start", "joint steps before the first augmented one", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.augment_start; }));
  o.push_back(int_option("augment-stop", "joint step from which no step is augmented, so that the last steps fit the frames themselves (0: augmented to the end)", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.augment_stop; }));
  o.back().before = "0";
  o.push_back(float_option("augment-degrees", "largest rotation of an object camera (about its x or y axis)", 0.0, 90.0,
                           [](TrainConfig& c) -> float& { return c.augment_degrees; }));
  o.push_back(float_option("w-full-rgb", "weight of the composite RGB loss", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.weights.full_rgb; }));
  o.push_back(float_option("w-nerf-rgb", "weight of the per-NeRF masked RGB loss", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.weights.nerf_rgb; }));
  o.push_back(float_option("w-mask", "weight of the per-NeRF mask loss", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.weights.mask; }));
  o.push_back(float_option("w-blending", "weight of the blending loss (betas sum to 1)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.weights.blending; }));
  o.push_back(float_option("w-alpha", "weight of the alpha loss (no object density outside its mask)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.weights.alpha; }));
  o.push_back(float_option("w-sparsity", "weight of the L1 on object alpha inside its mask (one compact surface per ray; not in the reference)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.weights.sparsity; }));
  o.push_back(float_option("w-order", "weight of the order loss: each object NeRF's depth on background rays is the static NeRF's (the reference's 0.1)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.weights.order; }));
  o.back().before = "0";
  o.push_back(convention_option("mask-loss", "mask loss: mse (mean square over NeRFs and rays) or l1 (per NeRF the mean |M_n - m_n| over rays, summed: the reference code's)",
                                "mse", "l1", [](TrainConfig& c) -> bool& { return c.conventions.mask_l1; }));
  o.push_back(convention_option("nerf-rgb-loss", "per-NeRF RGB loss: mean (masked square error over N R 3, one target colour) or area (per NeRF over its mask's area, each NeRF against its own, on augmented steps warped, view: the reference code's)",
                                "mean", "area", [](TrainConfig& c) -> bool& { return c.conventions.nerf_rgb_area; }));
  o.push_back(convention_option("alpha-loss", "alpha loss: weighted (alpha + blend weighted by 1 - mask, over K R S) or outside (per object the means of blend and alpha over the rays whose mask is not 1: the reference code's)",
                                "weighted", "outside", [](TrainConfig& c) -> bool& { return c.conventions.alpha_outside; }));
  o.push_back(convention_option("mask-render", "opacity of a sample in the rendered masks, depth and acc: union (1 - prod_n (1 - alpha_n b_n)) or sum (sum_n alpha_n b_n: the reference code's)",
                                "union", "sum", [](TrainConfig& c) -> bool& { return c.conventions.mask_sum; }));
  o.push_back(float_option("blend-eps", "epsilon of the blend normalisation b_n / (sum b + eps) in training (1e-6; the reference code's 1e-8)", 1e-30, 1.0,
                           [](TrainConfig& c) -> float& { return c.conventions.blend_eps; }));
  o.back().before = "1e-06";
  o.push_back(convention_option("pretrain-render", "static pretraining rendered as blend (through the blend normalisation) or plain (a plain NeRF, no blend: the reference code's)",
                                "blend", "plain", [](TrainConfig& c) -> bool& { return c.conventions.pretrain_plain; }));
  o.push_back({"object-motion", "object NeRFs: none (the paper's field of x, y, z, t) or rigid (one canonical shape per object of x, y, z, moved by a rigid motion per frame, found by aligning the frames and then learned)",
               [](const TrainConfig& c) { return std::string(object_motion_name(c.field.motion)); },
               [](TrainConfig& c, const std::string& v) {
                 const std::string t = trim(v);
                 if (t == "none") {
                   c.field.motion = ObjectMotion::None;
                   c.field.object_box = false;  // a box of its own is the rigid model's canonical space
                   c.object_samples = 0;
                 } else if (t == "rigid") c.field.motion = ObjectMotion::Rigid;
                 else bad_value("object-motion", v, "is not one of none, rigid");
               }});
  o.back().before = "none";
  // After object-motion, which turns it off with the rigid model: `--object-motion none` on a
  // preset with boxes trains the (x, y, z, t) field, while asking for a box as well is an error.
  o.push_back(bool_option("object-box", "object-motion rigid: each canonical field encodes a box of its own around its object, sized from the masks and the disparity, instead of the scene's box, so the grid's cells are sized by the object (object-motion none turns it off)",
                          [](TrainConfig& c) -> bool& { return c.field.object_box; }));
  o.back().before = "false";
  o.push_back(bool_option("object-box-bounded", "object-box, occupancy: an object NeRF has no density outside its box (those samples never reach its MLP); false: a point beyond the box reads the box's face",
                          [](TrainConfig& c) -> bool& { return c.field.object_box_bounded; }));
  o.back().before = "false";
  // After object-motion too, which turns it off.
  o.push_back(int_option("object-samples", "object-motion rigid, forward-facing scenes: of each ray's samples, how many crowd into the depths within two radii of where each object stands at the view's time, shared evenly by the objects (0: every sample evenly spread; metric scenes always spread them; object-motion none turns it off)", 0, 1023,
                         [](TrainConfig& c) -> int& { return c.object_samples; }));
  o.back().before = "0";
  o.push_back(float_option("rim-rays", "joint steps: of the background's rays, the share drawn from the ring of background pixels within rim-width of an object's mask, where an object's density spread past its silhouette shows (0: spread evenly over the background)", 0.0, 0.95,
                           [](TrainConfig& c) -> float& { return c.rim_rays; }));
  o.back().before = "0";
  o.push_back(float_option("rim-width", "rim-rays: the ring's width as a fraction of the image width (at least one pixel)", 0.0, 0.5,
                           [](TrainConfig& c) -> float& { return c.rim_width; }));
  o.push_back(float_option("background-gap", "background pixels within this many pixels (at 160 px width, scaled with the image) of an object's mask are drawn neither in pretraining nor in joint steps that are not augmented: a mask that misses its object's edge by a pixel or two would teach the static NeRF the object's rim as background (0: every background pixel)", 0.0, 64.0,
                           [](TrainConfig& c) -> float& { return c.background_gap; }));
  o.back().before = "0";
  o.push_back(float_option("align-depth-reach", "object-motion rigid: before the frames' alignment each mask pixel's depth becomes the nearest of the mask's within this many pixels (at 160 px width, scaled with the image), undoing a disparity blurred over the object's rim (0: as given)", 0.0, 64.0,
                           [](TrainConfig& c) -> float& { return c.align_depth_reach; }));
  o.back().before = "0";
  o.push_back(bool_option("align-depth-auto", "object-motion rigid: align-depth-reach 1 where less than 0.7 of the disparity's step falls at the objects' silhouettes (a disparity blurred over them), else 0; the run's config.ini holds the choice",
                          [](TrainConfig& c) -> bool& { return c.align_depth_auto; }));
  o.back().before = "false";
  o.push_back(bool_option("align-silhouette", "object-motion rigid: a frame pair with too few interior pixels to align (a rod a few pixels wide) turns as its masks' principal axes do, the tilt out of the image read from the mask's length; false: the anchors' shift alone, unturned",
                          [](TrainConfig& c) -> bool& { return c.align_silhouette; }));
  o.back().before = "false";
  o.push_back(float_option("align-consistency", "object-motion rigid: each frame pair is also aligned back; a pair whose way back leaves more turn than this fraction of the turn found (and more than 3 degrees) takes no turn, as a symmetric object can give each direction a wrong turn of its own (0: no check)", 0.0, 100.0,
                           [](TrainConfig& c) -> float& { return c.align_consistency; }));
  o.back().before = "0";
  o.push_back(float_option("align-bridge", "object-motion rigid: a frame pair whose alignment leaves more than this many times the median pair's residual, or too few interior pixels to align, between two pairs that aligned well, takes their interpolated turn and a translation aligned under it (0: every pair its own)", 0.0, 1000.0,
                           [](TrainConfig& c) -> float& { return c.align_bridge; }));
  o.back().before = "0";
  o.push_back(float_option("w-motion-smooth", "object-motion rigid: weight of the trajectories' smoothness (second differences of the per-frame motion)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.w_motion_smooth; }));
  o.push_back(int_option("canonical-coarse-to-fine", "object-motion rigid, hash grid (unused with the frequency encoding): joint steps over which the canonical grid's levels open from coarse to fine, so the motion aligns coarse shapes first (0: every level from the start)", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.canonical_coarse_to_fine; }));
  o.back().before = "0";
  o.push_back(float_option("lr-motion", "object-motion rigid: the trajectories' learning rate as a fraction of lr (0: kept where the frames' alignment put them)", 0.0, 1.0,
                           [](TrainConfig& c) -> float& { return c.lr_motion; }));
  o.back().before = "1";
  o.back().before = "0";
  o.push_back(float_option("w-distortion", "weight of the distortion loss: each object NeRF's weight spread along the rays of its mask (streaks; joint training)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.w_distortion; }));
  o.push_back(bool_option("static-background-only", "joint training: the static NeRF learns from background pixels only (object pixels send it no gradient; not in the reference)",
                          [](TrainConfig& c) -> bool& { return c.static_background_only; }));
  o.back().before = "false";
  o.push_back(bool_option("static-blend-from-objects", "static-background-only: the static NeRF's blend still learns from object pixels, so that it gives way where the objects pass (its colour and density stay gated)",
                          [](TrainConfig& c) -> bool& { return c.static_blend_from_objects; }));
  o.back().before = "false";
  o.push_back(float_option("w-free-space", "weight of the free-space loss: object weight in front of the surface the disparity gives, on its mask's rays (joint training; NDC scenes with disp/ only; not in the reference)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.w_free_space; }));
  o.back().before = "0";
  o.push_back(float_option("free-space-margin", "free-space loss: depth (NDC t) in front of the disparity's surface that still counts as the surface", 0.0, 1.0,
                           [](TrainConfig& c) -> float& { return c.free_space_margin; }));
  o.push_back(float_option("free-space-behind", "free-space loss: weight of object weight more than the margin behind the disparity's surface, relative to in front (0: in front only)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.free_space_behind; }));
  o.back().before = "0";
  o.push_back(bool_option("free-space-scene-fit", "free-space loss: each ray's surface is the disparity placed by the scene's photometric fit (the one the objects' start uses) instead of fitted to the static NeRF's rendered depth over each batch",
                          [](TrainConfig& c) -> bool& { return c.free_space_scene_fit; }));
  o.back().before = "false";
  o.push_back(bool_option("free-space-front", "free-space-scene-fit: an object's surface in a frame is its front (the nearest tenth of its mask's placed disparity) instead of each pixel's own",
                          [](TrainConfig& c) -> bool& { return c.free_space_front; }));
  o.back().before = "false";
  o.push_back(int_option("depth-start", "pretraining steps before the depth term enters (0: from the first step)", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.depth_start; }));
  o.back().before = "0";
  o.push_back(int_option("depth-ramp", "pretraining steps from depth-start over which the depth term's weight rises linearly from 0 to w-depth (0: full from depth-start)", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.depth_ramp; }));
  o.back().before = "0";
  o.push_back(float_option("w-depth", "weight of the depth loss against the scene's disparity maps, up to scale and shift (NDC scenes with disp/ only)", 0.0, 1e6,
                           [](TrainConfig& c) -> float& { return c.w_depth; }));
  o.push_back(bool_option("occupancy", "skip empty space: occupancy grids from the density, samples in empty cells never reach an MLP",
                          [](TrainConfig& c) -> bool& { return c.occupancy; }));
  o.push_back(int_option("occupancy-res", "occupancy grid cells per dimension", 1, 512,
                         [](TrainConfig& c) -> int& { return c.occupancy_res; }));
  o.push_back(int_option("occupancy-every", "steps between occupancy grid updates", 1, kBig,
                         [](TrainConfig& c) -> int& { return c.occupancy_every; }));
  o.push_back(int_option("occupancy-warmup", "steps of each phase before the first occupancy update (nothing skipped until then)", 0, kBig,
                         [](TrainConfig& c) -> int& { return c.occupancy_warmup; }));
  o.push_back(float_option("occupancy-alpha", "opacity over one grid cell above which the cell is occupied", 1e-6, 0.999,
                           [](TrainConfig& c) -> float& { return c.occupancy_alpha; }));
  o.push_back(int_option("factor", "image downscale factor when loading the scene (0: the reader's default)", 0, 64,
                         [](TrainConfig& c) -> int& { return c.factor; }));
  o.push_back(int_option("holdout", "hold every n-th frame out of training for evaluation (0: none)", 0, 1000000,
                         [](TrainConfig& c) -> int& { return c.holdout; }));
  o.push_back(bool_option("static-only", "load a NOVA-layout scene that has no motion_masks/ as static-only (no object NeRFs)",
                          [](TrainConfig& c) -> bool& { return c.static_only; }));
  o.push_back(int_option("seed", "seed of the initial weights, pixel batches, jitter and augmentation", 0, 4294967295L,
                         [](TrainConfig& c) -> unsigned& { return c.seed; }));
  o.push_back(int_option("checkpoint-every", "steps between checkpoints (one is always written at the end)", 1, kBig,
                         [](TrainConfig& c) -> int& { return c.checkpoint_every; }));
  o.push_back(int_option("log-every", "steps between progress lines and metrics records", 1, kBig,
                         [](TrainConfig& c) -> int& { return c.log_every; }));
  return o;
}

}  // namespace

const std::vector<ConfigOption>& config_options() {
  static const std::vector<ConfigOption> options = make_options();
  return options;
}

double TrainConfig::depth_weight_at(long phase_step) const {
  if (phase_step < depth_start) return 0.0;
  if (depth_ramp <= 0) return 1.0;
  return std::min(1.0, static_cast<double>(phase_step - depth_start) / depth_ramp);
}

void set_config_value(TrainConfig& c, const std::string& key, const std::string& value) {
  for (const ConfigOption& o : config_options())
    if (o.key == key) return o.set(c, value);
  throw Error("unknown option '" + key + "'");
}

void validate(const TrainConfig& c) {
  if (c.field.encoding == Encoding::HashGrid) {
    HashGridConfig h = c.field.hash;
    if (h.bound == 0.0f) h.bound = 1.0f;  // 0 is resolved from the scene
    try {
      validate(h);
      h.max_resolution = object_hash_config(c.field).max_resolution;
      validate(h);
    } catch (const Error& e) {
      throw Error(std::string("options 'hash-*': ") + e.what());
    }
  }
  if (c.field.skip >= c.field.depth)
    throw Error("option 'skip': " + std::to_string(c.field.skip) + " must be below depth " +
                std::to_string(c.field.depth));
  if (c.field.deform_width > 0 && c.field.motion != ObjectMotion::Rigid)
    throw Error("option 'deform-width': a deformation moves a rigid object's canonical shape; it needs "
                "'object-motion rigid' (object-motion is " + std::string(object_motion_name(c.field.motion)) + ")");
  if (c.field.object_box && c.field.motion != ObjectMotion::Rigid)
    throw Error("option 'object-box': a box of its own is a rigid object's canonical space; it needs "
                "'object-motion rigid' (object-motion is " + std::string(object_motion_name(c.field.motion)) + ")");
  if (c.object_samples >= c.samples)
    throw Error("option 'object-samples': " + std::to_string(c.object_samples) + " must be below samples " +
                std::to_string(c.samples) + " (the rest stay evenly spread for the background)");
  if (c.object_samples > 0 && c.field.motion != ObjectMotion::Rigid)
    throw Error("option 'object-samples': samples crowd about where a rigid object's motion puts it; it needs "
                "'object-motion rigid' (object-motion is " + std::string(object_motion_name(c.field.motion)) + ")");
  if (c.free_space_front && !c.free_space_scene_fit)
    throw Error("option 'free-space-front': an object's front is read from the disparity placed by the scene's fit; "
                "it needs 'free-space-scene-fit true'");
  if (c.augment && c.augment_stop > 0 && c.augment_stop <= c.augment_start)
    throw Error("option 'augment-stop': " + std::to_string(c.augment_stop) + " is not after augment-start " +
                std::to_string(c.augment_start) + ", so no step would be augmented (pass --augment false for that)");
  const NovelViewLossWeights& w = c.weights;
  if (c.steps > 0 && w.full_rgb + w.nerf_rgb + w.mask + w.blending + w.alpha + w.order <= 0)
    throw Error("options 'w-*': every loss weight is 0, joint training would have no loss");
  if (c.pretrain_steps + static_cast<long>(c.steps) <= 0)
    throw Error("options 'pretrain-steps' and 'steps': both are 0, nothing to train");
}

}  // namespace nova
