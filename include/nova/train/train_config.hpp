#pragma once
// Everything `nova train` can be told, as one struct with one option table: the CLI builds
// its --help and parsing from the table, runs write it as RUN/config.ini, and render/eval
// read it back. Two shipped presets: "quick" (the default, sized for a 2-core CPU) and
// "reference" (the paper's networks and schedule; a GPU job).
#include <functional>
#include <string>
#include <vector>

#include "nova/loss/objective.hpp"
#include "nova/model/model_config.hpp"
#include "nova/train/optim.hpp"

namespace nova {

// The model (field, samples, occupancy, occupancy_alpha) is the ModelConfig a renderer reads
// back from the run's config.ini; the rest is how it is trained.
struct TrainConfig : ModelConfig {
  std::string preset = "quick";
  // Rays.
  int rays = 1024;          // rays per step (split over background and objects)
  float noise_std = 1.0f;   // density noise while training
  // Schedule.
  int pretrain_steps = 100000;  // static NeRF alone, background pixels
  int steps = 300000;           // joint training
  float lr = 5e-4f;
  float lr_decay = 0.1f;          // lr(s) = lr * lr_decay^(s / lr_decay_steps), s per phase
  int lr_decay_steps = 300000;
  AdamConfig adam;               // moment decays and epsilon
  // Novel-view augmentation.
  bool augment = true;
  int augment_every = 3;         // every n-th joint step is augmented
  int augment_start = 0;         // joint steps before the first augmented one (warm-up)
  int augment_stop = 0;          // joint step from which none is augmented (0: to the end)
  float augment_degrees = 20.0f;
  // Joint steps: of the background's rays, this share comes from the ring of background pixels
  // within rim_width (a fraction of the image width) of an object's mask (pixel_batch.hpp).
  float rim_rays = 0.0f;
  float rim_width = 0.03f;
  // Background pixels within this many pixels (at 160 px width, scaled with the image) of an
  // object's mask are not drawn in pretraining and in joint steps that are not augmented
  // (pixel_batch.hpp, background_apart; 0: every background pixel).
  float background_gap = 0.0f;
  // Rigid objects' start (AlignmentOptions::depth_reach_px, ::consistency, ::bridge_ratio; 0: off).
  float align_depth_reach = 0.0f;
  float align_consistency = 0.0f;
  float align_bridge = 0.0f;
  // Rigid objects' start: align_depth_reach becomes 1 where the scene's disparity is blurred
  // over the objects' silhouettes (silhouette_step_share below kBlurredStepShare), else 0;
  // chosen when the trainer is made, and the run's config.ini holds the choice.
  bool align_depth_auto = false;
  // Rigid objects' start: a frame pair too thin to align by its interior (a rod) turns as its
  // masks' principal axes do (AlignmentOptions::silhouette_turns; false: unturned).
  bool align_silhouette = false;
  NovelViewLossWeights weights;
  // How the loss terms are normalised and rendered (losses.hpp): nova's own (quick) or the
  // public reference code's (reference); docs/training.md, "Loss conventions".
  LossConventions conventions;
  // Depth up to scale and shift against the scene's disparity maps (disp/), in both phases,
  // as DynamicNeRF (whose code NOVA builds on) does; off without disparity or with 0.
  float w_depth = 0.04f;
  // Pretraining steps before the depth term enters (0: from the first step). The term
  // standardises the rendered depth over the batch, so while the field is still a flat haze
  // its gradient is divided by a near-zero spread and can hold the colours there.
  int depth_start = 0;
  // Pretraining steps from depth_start over which the depth term's weight rises linearly from
  // 0 to w_depth: a weight at full strength from the first steps can hold the field at a
  // haze of the images' mean colour while the colours have formed no surface yet.
  int depth_ramp = 0;
  // The depth term's share of w_depth at pretraining step `phase_step` (0-based).
  double depth_weight_at(long phase_step) const;
  // Distortion loss (losses.hpp) of each object NeRF on its mask's rays in joint training: a
  // prior for one surface per ray against streaks (not in the reference: 0 there).
  float w_distortion = 0.0f;
  // In joint training the static NeRF gets no gradient from rays of object pixels (as in its
  // pretraining): otherwise, wherever an object NeRF is not yet opaque, the composite loss
  // paints the object's colours into the background along its path (not in the reference).
  bool static_background_only = false;
  // With static_background_only, the static NeRF's blend still learns from object pixels: a
  // sample's blends are normalised over the NeRFs, so a static blend left where an object
  // passes caps the object's share of its own opacity there (a static blend of 0.6 holds an
  // opaque object's mask near 0.4).
  bool static_blend_from_objects = false;
  // Free-space loss (losses.hpp) of the object NeRFs in joint training: no weight more than
  // free_space_margin (in the rendered depth's units: NDC t) in front of the depth the
  // disparity gives (not in the reference: 0 there).
  float w_free_space = 0.0f;
  float free_space_margin = 0.05f;
  // Weight more than the margin *behind* that depth costs free_space_behind times as much: an
  // object pushed back along the one camera's rays renders the same training image.
  float free_space_behind = 0.0f;
  // The free-space loss's surface on each ray: false, the disparity in the rendered depth's
  // units by a least-squares fit of the static NeRF's rendered depth over each batch's
  // background rays (it follows the static NeRF, haze and all); true, the disparity placed once
  // by the scene's photometric fit (fit_disparity, as the objects' start), at its NDC t.
  bool free_space_scene_fit = false;
  // With free_space_scene_fit: an object's surface in a frame is its front (the nearest tenth of
  // its mask's surface, detail::to_object_fronts) instead of each pixel's own. A disparity
  // blurred over an object's silhouette places its rim part way to the background, behind the
  // object's front, where a per-pixel surface would count the object's own rim as free space.
  bool free_space_front = false;
  // With a rigid object motion (FieldConfig::motion): weight of the trajectories' smoothness
  // (second differences of the per-frame motion, motion_smoothness).
  float w_motion_smooth = 0.0f;
  // The trajectories' learning rate as a fraction of lr: they start from the frames'
  // alignment, and at the networks' rate they wander to explain what the fields miss.
  float lr_motion = 0.1f;
  // Joint steps over which a rigid object's canonical hash grid opens its levels from coarse to
  // fine (0: every level from the start; unused with the frequency encoding): a shape of coarse levels only changes smoothly with
  // the motion, so the trajectory first aligns the frames on what those levels see.
  int canonical_coarse_to_fine = 0;
  // Empty-space skipping (occupancy.hpp; on with ModelConfig::occupancy): one grid per NeRF,
  // updated from the density every occupancy_every steps once occupancy_warmup steps of a
  // phase have passed; samples in empty cells never reach an MLP.
  int occupancy_res = 64;
  int occupancy_every = 16;
  int occupancy_warmup = 256;
  // Scene loading.
  int factor = 0;   // image downscale (0: the reader's default)
  int holdout = 0;  // every n-th frame is held out for evaluation (0: none; LLFF uses 8)
  bool static_only = false;  // a NOVA-layout folder without motion_masks/ loads with K = 0
  // Run.
  unsigned seed = 1;
  int checkpoint_every = 1000;
  int log_every = 50;
};

TrainConfig preset_config(const std::string& name);  // "quick" or "reference"; Error otherwise
std::vector<std::string> preset_names();

// One entry of the option table: how to read, write and check one field.
struct ConfigOption {
  std::string key;
  std::string help;
  std::function<std::string(const TrainConfig&)> get;
  std::function<void(TrainConfig&, const std::string&)> set;  // parses; Error on a bad value
  // What a run's config.ini written before this option existed meant, for options whose
  // `quick` value changed what such a run did (empty: the preset's value is right).
  std::string before{};
};
const std::vector<ConfigOption>& config_options();

// Sets `key` from text; nova::Error (exit 2) names the key and the value when it is unknown,
// malformed or out of range.
void set_config_value(TrainConfig& c, const std::string& key, const std::string& value);
// Checks the combination (sizes positive, skip < depth, ...); Error on the first problem.
void validate(const TrainConfig& c);

// "key = value" lines with the help as comments (readable by Boost's config-file parser and
// by read_config_text). `extra` lines (e.g. "scene = DIR") are appended as they are.
std::string format_config(const TrainConfig& c, const std::vector<std::string>& extra = {});
// Parses format_config's text: starts from the preset named in it (quick if none), applies
// every known key; unknown keys are returned in `others` (key -> value) when given, else an
// Error. `origin` names the file in errors.
// A run's own config.ini (`RunFile`: resume, render, eval) names every option of the version
// that wrote it, so an option it lacks takes its `before` value, which reproduces that run.
enum class ConfigFile { Partial, RunFile };
TrainConfig parse_config_text(const std::string& text, const std::string& origin,
                              std::vector<std::pair<std::string, std::string>>* others = nullptr,
                              ConfigFile kind = ConfigFile::Partial);

}  // namespace nova
