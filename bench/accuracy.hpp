#pragma once
// The pieces of `nova-bench accuracy` that need no device: the scene list (named sets, scene
// names and their evaluation protocol), per-scene results, the aggregates per set, and the
// table, CSV and JSON (with the CSV read back, for tests and re-aggregation). Defined in
// bench/accuracy.cpp, which nova_tests links too, so that tests/test_accuracy.cpp checks the
// code nova-bench runs.
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace nova::accuracy {

// ---- scenes -------------------------------------------------------------------------------

// The seeded synthetic family (`nova synth --preset family --seed S`), split once and for all:
// `dev` seeds are for choosing methods and defaults; `test` seeds are only ever reported, never
// tuned on (a default chosen on dev is checked on test). Change neither list to make a number
// look better: add a new set instead.
inline const std::vector<uint32_t> kDevSeeds = {1, 2, 3, 4};
inline const std::vector<uint32_t> kTestSeeds = {101, 102, 103, 104};
// The sets a scene can belong to (SceneSpec::set), in the order tables and plots show them.
inline const std::vector<std::string> kSetOrder = {"dev", "test", "deforming", "real", "other"};
// The real scenes of the shared data folder, in the order the set `real` lists them.
inline const std::vector<std::string> kRealScenes = {"balloon", "fern", "lego"};

// One scene to train and score, with the protocol it is evaluated under.
struct SceneSpec {
  std::string name;  // canonical: family:S, synth:PRESET:S, balloon, fern, lego
  std::string set;   // dev, test, deforming (synth:deforming:S), real, or other (a synthetic
                     // scene in none of those)
  bool synthetic = false;
  std::string preset;  // synthetic: the nova synth preset
  uint32_t seed = 0;   // synthetic: its seed
  std::string folder;  // real: the folder under --data
  // The evaluation protocol: nova train options every run of the scene gets (before --set).
  std::vector<std::pair<std::string, std::string>> protocol;
  std::string eval_split;  // evaluate the frames of this split (lego: test), else held-out views
  bool named = false;      // named in --scenes itself (not only through a set)
  // A folder name for OUT/scenes and OUT/runs: the name with ':' -> '-'.
  std::string dir_name() const;
};

// The set a family seed belongs to: dev, test, or other.
std::string set_of_seed(uint32_t seed);

// A seed from 0 to 2^32 - 1; error naming `scene` on anything else.
uint32_t parse_seed(const std::string& text, const std::string& scene);

constexpr const char* kSceneSyntax =
    "a set (dev, test, deforming, real, all), family:SEED, synth:PRESET:SEED, balloon, fern or lego";

// One scene name (no set). Error (exit 2) naming it when it is none of kSceneSyntax.
SceneSpec parse_scene(const std::string& text);

// The scenes a named set holds, or nothing when `name` is no set.
std::vector<std::string> set_members(const std::string& name);

// A comma list of sets and scene names -> scenes in order of first mention, duplicates
// removed (a scene named directly and through a set is `named`). Error on an unknown name or
// an empty list.
std::vector<SceneSpec> parse_scene_list(const std::string& text);

// ---- results ------------------------------------------------------------------------------

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// What one scene's run scored and cost, or why it has no score.
struct SceneResult {
  std::string name, set;
  std::string status = "ok";  // ok, reused (training skipped), skipped: WHY, failed: WHY
  long steps = 0;
  double train_s = kNaN, eval_s = kNaN;
  double cam0_psnr = kNaN, cam0_ssim = kNaN;        // camera 0 at every time (synthetic)
  double heldout_psnr = kNaN, heldout_ssim = kNaN;  // held-out cameras / frames / test split
  double compose_psnr = kNaN;                       // composition targets (synthetic)
  // Means over the views whose objects region is known (synthetic ground truth, a real
  // scene's held-out frames; a composition target's region is where its instances are): PSNR
  // inside the objects' masks and outside them (nova eval's columns). The objects' PSNR is in
  // the table and the CSV, the background's in accuracy.json. And how opaque the objects
  // render inside their masks (nova eval's opacity; accuracy.json only).
  double cam0_object_psnr = kNaN, cam0_background_psnr = kNaN;
  double heldout_object_psnr = kNaN, heldout_background_psnr = kNaN;
  double compose_object_psnr = kNaN;
  double cam0_object_opacity = kNaN, heldout_object_opacity = kNaN, compose_object_opacity = kNaN;
  int cam0_views = 0, heldout_views = 0, compose_views = 0;
  // What `nova eval` reports by default: camera 0 where the scene has it, else held-out views.
  double psnr() const { return std::isfinite(cam0_psnr) ? cam0_psnr : heldout_psnr; }
  // The same views' PSNR inside the objects (NaN where no objects region is known).
  double object_psnr() const { return std::isfinite(cam0_psnr) ? cam0_object_psnr : heldout_object_psnr; }
  bool scored() const { return status == "ok" || status == "reused"; }
};

// The aggregates of one set's scored scenes.
struct SetSummary {
  std::string set;  // dev, test, real, other, or "all" (every scene, when there is more than one set)
  int scenes = 0;   // scored scenes
  double mean_cam0_psnr = kNaN, min_cam0_psnr = kNaN, mean_heldout_psnr = kNaN, mean_compose_psnr = kNaN;
  double mean_cam0_object_psnr = kNaN, mean_heldout_object_psnr = kNaN, mean_compose_object_psnr = kNaN;
  double total_train_s = 0;
};

// Mean of the finite values; NaN when there is none.
double finite_mean(const std::vector<double>& v);
double finite_min(const std::vector<double>& v);

SetSummary summarise(const std::string& set, const std::vector<const SceneResult*>& rs);

// One summary per set, in the order dev, test, real, other (those present), then "all" when
// the results span more than one set. Failed and skipped scenes count in none.
std::vector<SetSummary> aggregate(const std::vector<SceneResult>& results);

// ---- text, CSV, JSON ----------------------------------------------------------------------

std::string num(double v, int decimals);
std::string num_or(double v, int decimals, const std::string& none = "-");

std::string table_text(const std::vector<SceneResult>& results, const std::vector<SetSummary>& sets);

inline const char* kCsvHeader =
    "kind,name,set,scenes,steps,train_seconds,eval_seconds,cam0_psnr,cam0_min_psnr,cam0_ssim,heldout_psnr,"
    "heldout_ssim,compose_psnr,cam0_views,heldout_views,compose_views,cam0_object_psnr,heldout_object_psnr,"
    "compose_object_psnr,status";

// A CSV field: quoted when it holds a comma or a quote.
std::string csv_field(const std::string& s);

// Scene rows (kind "scene"), then set rows (kind "set": means, the minimum camera-0 PSNR, the
// total training time). Missing numbers are empty fields.
std::string csv_text(const std::vector<SceneResult>& results, const std::vector<SetSummary>& sets);

std::vector<std::string> split_csv_line(const std::string& line);

// Reads csv_text back (scene rows into `results`, set rows into `sets`). Error naming the line
// on anything else.
void parse_csv(const std::string& text, std::vector<SceneResult>* results, std::vector<SetSummary>* sets);

// {"configuration": {...}, "scenes": [...], "sets": [...]}; missing numbers are null.
// `settings`: the configuration every scene got (preset, config file, --set), as given.
std::string json_text(const std::vector<std::pair<std::string, std::string>>& settings,
                      const std::vector<SceneResult>& results, const std::vector<SetSummary>& sets);

}  // namespace nova::accuracy
