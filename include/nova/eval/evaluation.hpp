#pragma once
// Scoring a trained run against ground truth, the way `nova eval` does it, so that the CLI and
// nova-bench share one implementation: the scene as the run trained on it, the ground-truth
// views of a kind or of a split, each view rendered and scored (PSNR and SSIM on 8-bit images,
// image_metrics.hpp), and the composition targets. Implemented in nova_io (OpenCV).
#include <cmath>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "nova/model/scene.hpp"
#include "nova/train/train_config.hpp"
#include "nova/model/view_renderer.hpp"

namespace nova {

// load_scene with the run's image factor, then the run's hold-out split (every n-th frame
// leaves training and becomes a "heldout" ground-truth view; only for split "train"). Error
// (exit 2) when the folder is missing or bad. What `nova train`, `render` and `eval` load.
Scene load_training_scene(const std::string& dir, const TrainConfig& config, bool load_gt = false,
                          const std::string& split = "train");

// A frame of the scene folder: its camera and time. Camera indices (`nova render --camera`, a
// composition target's camera=) count every frame of the folder in its order, the held-out
// frames of a --holdout run (kept as "heldout" ground-truth views with their folder_index)
// included, and no other ground-truth camera (a synthetic scene's held-out cameras).
struct FolderFrame {
  Camera camera;
  double time;
};
std::vector<FolderFrame> folder_frames(const Scene& scene);

struct ViewScore {
  std::string name;  // the view's name as a file stem ('/' -> '_', no ".png")
  double psnr = 0, ssim = 0;
  // PSNR inside and outside the view's objects (GroundTruthView::objects); NaN where the view
  // has no masks or the region is empty.
  double object_psnr = std::nan(""), background_psnr = std::nan("");
  // How opaque the objects render inside that region: the mean over its pixels of the objects'
  // rendered masks summed (1 where they are solid, less where the background shows through).
  // NaN where the view has no region or no object is drawn.
  double object_opacity = std::nan("");
};

// The frames of a split scene (loaded with load_training_scene(..., split)) as ground-truth
// views named SPLIT_III, kind SPLIT; moves the images out of `split_scene`.
std::vector<GroundTruthView> split_views(Scene& split_scene, const std::string& split);

// The stem `nova eval` names a view's render by: '/' -> '_', a trailing ".png" dropped.
std::string view_stem(const std::string& name);

// Called with every render: its index, the stem (compose targets: "compose_NAME") and the image.
using RenderSink = std::function<void(size_t, const std::string&, const Image8&)>;

// Renders every view (camera, every object at the view's time, learnt blending unless
// `hard_blend`) and scores it against its ground truth.
std::vector<ViewScore> score_views(ViewRenderer& renderer, int num_objects, const std::vector<GroundTruthView>& views,
                                   bool hard_blend, const RenderSink& sink = {});

// Renders every composition target of the scene that has a ground-truth image and scores it.
std::vector<ViewScore> score_compose_targets(ViewRenderer& renderer, const Scene& scene, bool hard_blend,
                                             const RenderSink& sink = {});

// Mean PSNR and SSIM (0, 0 when empty).
std::pair<double, double> mean_scores(const std::vector<ViewScore>& scores);

// Mean object and background PSNR over the views that have them (NaN where none has).
std::pair<double, double> mean_region_scores(const std::vector<ViewScore>& scores);

// Mean object opacity over the views that have one (NaN where none has).
double mean_object_opacity(const std::vector<ViewScore>& scores);

}  // namespace nova
