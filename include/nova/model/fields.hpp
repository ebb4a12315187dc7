#pragma once
// The two NeRF fields of NOVA as graph builders: the static background NeRF and the
// time-conditioned object NeRFs (one per object, run together as batched GEMMs). Both emit
// the raw rows render_composite reads: [rgb(3), sigma, blend], pre-activation.
//
// The input encoding is the paper's positional encoding (PE) or a multiresolution hash grid
// (hash_grid.hpp; 3-D for the static NeRF, 4-D xyzt for the objects) in its place.
//
//   static:  [PE_L(xyz)] -> trunk (depth x width, input re-fed after layer `skip`) -> feature
//            feature -> sigma, blend;  [feature, PE_Ld(viewdir)] -> width/2 ReLU -> rgb
//            (with view_dirs off the rgb head reads the feature alone)
//   object:  [PE_L(xyzt)] -> trunk -> rgb, sigma, blend (view-independent, as the reference's
//            dynamic NeRF); with a rigid motion [PE_L(xyz)] of the canonical position alone,
//            and with canonical_colour_time_freqs >= 0 the static field's layout with time in
//            place of the view direction: trunk -> feature -> sigma, blend;
//            [feature, PE(t)] -> width/2 ReLU -> rgb; with deform_width > 0 the canonical
//            position first moves by a bounded deformation of (position, t)
// Parameter names: "static.*" and "objects.*"; object parameters carry a leading object
// dimension [K, ...] when K > 1, so one object's weights are a slice of them.
#include <string>
#include "nova/graph/graph.hpp"
#include "nova/ops/encoding/hash_encoding.hpp"
#include "nova/sampling/rigid_motion.hpp"

namespace nova {

enum class Encoding { Frequency, HashGrid };
const char* encoding_name(Encoding e);  // "frequency", "hashgrid"

// A time cell shared by about three neighbouring frames ties each object NeRF to three
// viewpoints of a monocular video: on the default synthetic scene (24 frames) 8 cells gave
// 25.36 dB camera-0 PSNR against 24.03 with a cell per frame and more at fine levels, on
// nvidia_balloon1 (12 frames, novel times) 4 cells 18.59 dB against 17.01 (docs/training.md, docs/accuracy-studies.md).
inline constexpr double kFramesPerTimeCell = 3.0;

// Frequencies of the positional encodings a deformation network reads (position and time):
// a deformation smooth in both, as a body's is between frames.
inline constexpr int kDeformFrequencies = 4;

struct FieldConfig {
  Encoding encoding = Encoding::Frequency;
  // With Encoding::HashGrid. hash.bound <= 0 (the default): resolved from the scene by
  // scene_field, the training rays' extent in NDC, the cameras' extent otherwise; HashGridConfig's own bound of 1 had
  // clamped metric scenes (Blender, D-NeRF) to [-1, 1]^3 (dnerf_lego_tiny 18.51 dB; from the
  // scene 20.47). A field built from an unresolved config is refused by the encoding.
  HashGridConfig hash{.bound = 0.0f};
  // hash.time_max_resolution resolved from the scene's frames, about kFramesPerTimeCell
  // frames per cell (scene_field in nova_graphs.hpp); false: hash.time_max_resolution as set.
  bool hash_time_auto = false;
  // In NDC, hash.bound <= 0 resolves to 1, the reference camera's frustum [-1, 1]^3; with
  // true, x and y instead take the half-sizes of the box that holds every training ray
  // (RayGeometry::box: more than 1 where the camera moves sideways), z stays [-1, 1]. The
  // unit box clamps what moved cameras see beyond it (streaks at the image edge).
  bool ndc_box_from_rays = false;
  // Half-size of the cube the occupancy grids cover, resolved by scene_field (0 until then):
  // the hash grid's box, or with hash.extend every training ray's extent, so that what the
  // extended levels encode beyond the box has cells of its own to be found occupied in.
  float occupancy_bound = 0.0f;
  // Finest cells per dimension of the object NeRFs' hash grid (0: hash.max_resolution). An
  // object is seen from one camera per time, so fine levels it cannot constrain fill with
  // hash-collision noise when it is viewed from elsewhere.
  int object_max_resolution = 0;
  // The same for a rigid object's canonical field (0: object_max_resolution). Every frame's
  // camera sees that one shape, so it can use finer cells than a field of (x, y, z, t).
  int canonical_max_resolution = 0;
  // A rigid object's colour as a function of time as well as of its canonical position: the
  // positional encoding's frequencies of t (< 0: colour of the position alone). The light
  // stays put in the world while the object turns, so a face's shade changes from frame to
  // frame; a colour fixed in canonical space can only average those shades. Density and blend
  // never read time, so the shape stays one shape.
  int canonical_colour_time_freqs = -1;
  // A rigid object that also changes shape (a person, a balloon): a deformation network of
  // deform_width (0: none) moves each canonical sample by at most deform_bound (NDC units,
  // or the metric scene's) before the canonical field reads it, as a function of the sample
  // and of time; one hidden ReLU layer over the positional encodings (kDeformFrequencies) of
  // both, the output layer starting at zero. The bound keeps the shape near the rigid one,
  // which every frame's camera still constrains.
  int deform_width = 0;
  float deform_bound = 0.05f;
  // A rigid object's canonical field encodes a box of its own around the object (parameter
  // "objects.box", set from the masks and the disparity when joint training starts, never
  // learned) instead of the scene's box: its grid's cells are sized by the object. In the
  // scene's box a small object spans a few cells, and in NDC fewer still in depth, which a
  // turning object shows sideways as blur.
  bool object_box = false;
  // With object_box and empty-space skipping (inert without either): an object NeRF has no
  // density outside its box (its occupancy grid holds no occupied cell there, so those
  // samples never reach its MLP). Otherwise a point beyond the box reads the features of the
  // box's face, and density there extends along every ray that leaves the box.
  bool object_box_bounded = false;
  // How an object NeRF sees time: the paper's field of (x, y, z, t), or one canonical shape of
  // (x, y, z) moved by a learned rigid motion per frame (motion.hpp).
  ObjectMotion motion = ObjectMotion::None;
  int depth = 8;
  int width = 256;
  int skip = 4;        // 0-based trunk layer whose output gets the encoded input appended
  int pos_freqs = 10;  // L of the positional encoding of xyz (and t for objects)
  int dir_freqs = 4;   // L of the view-direction encoding
  bool view_dirs = true;  // static colour depends on the view direction
};

// positions [M, 3], viewdirs [M, 3] (unused without view_dirs) -> raw [M, 5].
Tensor build_static_field(Tensor positions, Tensor viewdirs, const FieldConfig& config);

// The object NeRFs' hash grid: `hash` with object_max_resolution (a rigid canonical field:
// canonical_max_resolution, when set) in place of its finest level; with object_box the
// cube [-1, 1]^3 of the object's own box.
HashGridConfig object_hash_config(const FieldConfig& config);

// positions [B, M, 3] (or [M, 3] for B = 1), times of the same shape with 1 column -> raw
// [B, M, 5] (or [M, 5]). B object networks with independent weights. With a rigid motion the
// positions are canonical and the times are not read (but by a time-dependent colour).
// level_window [levels * features] (data; a hash grid only): the encoding's columns scaled by
// it before the trunk, training's coarse-to-fine window (level_window in step_graphs.hpp).
Tensor build_object_fields(Tensor positions, Tensor times, const FieldConfig& config, Tensor level_window = {});

// The name of the object boxes' parameter ([K, 6] or [6]; box_coordinates' rows).
inline const char* const kObjectBoxName = "objects.box";
// How far past its box an object NeRF's samples may reach (object_box_bounded): a deformation
// moves a sample by up to deform_bound before the canonical field reads it.
inline float object_box_margin(const FieldConfig& c) { return c.deform_width > 0 ? c.deform_bound : 0.0f; }

// Parameter name prefixes, for checkpoints and the inference renderer.
inline const std::string kStaticPrefix = "static.";
inline const std::string kObjectPrefix = "objects.";

}  // namespace nova
