// The device-free pieces of `nova-bench accuracy` (bench/accuracy.hpp).
#include "accuracy.hpp"

#include <algorithm>
#include <cstdio>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "nova/runtime/error.hpp"

namespace nova::accuracy {

std::string SceneSpec::dir_name() const {
  std::string d = name;
  std::replace(d.begin(), d.end(), ':', '-');
  return d;
}

std::string set_of_seed(uint32_t seed) {
  if (std::find(kDevSeeds.begin(), kDevSeeds.end(), seed) != kDevSeeds.end()) return "dev";
  if (std::find(kTestSeeds.begin(), kTestSeeds.end(), seed) != kTestSeeds.end()) return "test";
  return "other";
}

uint32_t parse_seed(const std::string& text, const std::string& scene) {
  if (text.empty() || text.size() > 10 || text.find_first_not_of("0123456789") != std::string::npos ||
      std::stoull(text) > 0xffffffffull)
    throw Error("scene '" + scene + "': seed '" + text + "' is not a number from 0 to 4294967295");
  return static_cast<uint32_t>(std::stoull(text));
}

SceneSpec parse_scene(const std::string& text) {
  SceneSpec s;
  if (text.rfind("family:", 0) == 0) {
    s.synthetic = true;
    s.preset = "family";
    s.seed = parse_seed(text.substr(7), text);
    s.name = "family:" + std::to_string(s.seed);
    s.set = set_of_seed(s.seed);
  } else if (text.rfind("synth:", 0) == 0) {
    const std::string rest = text.substr(6);
    const size_t colon = rest.find(':');
    if (colon == std::string::npos || colon == 0)
      throw Error("scene '" + text + "' is not synth:PRESET:SEED (e.g. synth:tiny:0)");
    s.synthetic = true;
    s.preset = rest.substr(0, colon);
    s.seed = parse_seed(rest.substr(colon + 1), text);
    s.name = "synth:" + s.preset + ":" + std::to_string(s.seed);
    s.set = s.preset == "deforming" ? "deforming" : "other";
  } else if (text == "balloon") {
    // NVIDIA Balloon1 at 240x135, every 4th frame held out: novel views at novel times.
    s = {"balloon", "real", false, "", 0, "nvidia_balloon1", {{"factor", "4"}, {"holdout", "4"}}, "", false};
  } else if (text == "fern") {
    // LLFF fern, every 8th frame held out (the LLFF protocol).
    s = {"fern", "real", false, "", 0, "llff_fern", {{"holdout", "8"}}, "", false};
  } else if (text == "lego") {
    // The tiny D-NeRF lego: trained on its train split, scored on its test split.
    s = {"lego", "real", false, "", 0, "dnerf_lego_tiny", {}, "test", false};
  } else {
    throw Error("unknown scene '" + text + "' (expected " + kSceneSyntax + ")");
  }
  return s;
}

std::vector<std::string> set_members(const std::string& name) {
  std::vector<std::string> out;
  const auto family = [&](const std::vector<uint32_t>& seeds) {
    for (uint32_t s : seeds) out.push_back("family:" + std::to_string(s));
  };
  if (name == "dev" || name == "all") family(kDevSeeds);
  if (name == "test" || name == "all") family(kTestSeeds);
  // The test seeds' worlds with objects that change shape: reported beside `test`.
  if (name == "deforming")
    for (uint32_t seed : kTestSeeds) out.push_back("synth:deforming:" + std::to_string(seed));
  if (name == "real" || name == "all") out.insert(out.end(), kRealScenes.begin(), kRealScenes.end());
  return out;
}

std::vector<SceneSpec> parse_scene_list(const std::string& text) {
  std::vector<SceneSpec> out;
  std::stringstream items(text);
  for (std::string item; std::getline(items, item, ',');) {
    const size_t a = item.find_first_not_of(" \t"), b = item.find_last_not_of(" \t");
    item = a == std::string::npos ? "" : item.substr(a, b - a + 1);
    if (item.empty()) continue;
    const std::vector<std::string> members = set_members(item);
    const bool is_set = !members.empty();
    for (const std::string& m : is_set ? members : std::vector<std::string>{item}) {
      SceneSpec s = parse_scene(m);
      s.named = !is_set;
      const auto same = std::find_if(out.begin(), out.end(), [&](const SceneSpec& o) { return o.name == s.name; });
      if (same == out.end()) out.push_back(s);
      else same->named = same->named || s.named;
    }
  }
  if (out.empty()) throw Error("--scenes '" + text + "' names no scene (expected a comma list of " + kSceneSyntax + ")");
  return out;
}

double finite_mean(const std::vector<double>& v) {
  double s = 0;
  int n = 0;
  for (double x : v)
    if (std::isfinite(x)) s += x, ++n;
  return n ? s / n : kNaN;
}

double finite_min(const std::vector<double>& v) {
  double m = kNaN;
  for (double x : v)
    if (std::isfinite(x) && !(m <= x)) m = x;
  return m;
}

SetSummary summarise(const std::string& set, const std::vector<const SceneResult*>& rs) {
  SetSummary s;
  s.set = set;
  std::vector<double> cam0, held, comp, cam0_obj, held_obj, comp_obj;
  for (const SceneResult* r : rs) {
    if (!r->scored()) continue;
    ++s.scenes;
    cam0.push_back(r->cam0_psnr);
    held.push_back(r->heldout_psnr);
    comp.push_back(r->compose_psnr);
    cam0_obj.push_back(r->cam0_object_psnr);
    held_obj.push_back(r->heldout_object_psnr);
    comp_obj.push_back(r->compose_object_psnr);
    if (std::isfinite(r->train_s)) s.total_train_s += r->train_s;
  }
  s.mean_cam0_psnr = finite_mean(cam0);
  s.min_cam0_psnr = finite_min(cam0);
  s.mean_heldout_psnr = finite_mean(held);
  s.mean_compose_psnr = finite_mean(comp);
  s.mean_cam0_object_psnr = finite_mean(cam0_obj);
  s.mean_heldout_object_psnr = finite_mean(held_obj);
  s.mean_compose_object_psnr = finite_mean(comp_obj);
  return s;
}

std::vector<SetSummary> aggregate(const std::vector<SceneResult>& results) {
  std::vector<SetSummary> out;
  int sets = 0;
  for (const std::string& set : kSetOrder) {
    std::vector<const SceneResult*> rs;
    for (const SceneResult& r : results)
      if (r.set == set) rs.push_back(&r);
    if (rs.empty()) continue;
    ++sets;
    out.push_back(summarise(set, rs));
  }
  if (sets > 1) {
    std::vector<const SceneResult*> rs;
    for (const SceneResult& r : results) rs.push_back(&r);
    out.push_back(summarise("all", rs));
  }
  return out;
}

std::string num(double v, int decimals) {
  if (!std::isfinite(v)) return "";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

std::string num_or(double v, int decimals, const std::string& none) {
  return std::isfinite(v) ? num(v, decimals) : none;
}

// The objects' PSNR leads each pair: objects are a few percent of a frame, and the whole
// frame's PSNR hides them.
std::string table_text(const std::vector<SceneResult>& results, const std::vector<SetSummary>& sets) {
  std::ostringstream o;
  // Columns as wide as their longest entry and a space, so that no name runs into the next.
  int name_w = 6, set_w = 4;
  for (const SceneResult& r : results) {
    name_w = std::max(name_w, static_cast<int>(r.name.size()) + 1);
    set_w = std::max(set_w, static_cast<int>(r.set.size()) + 1);
  }
  for (const SetSummary& s : sets) set_w = std::max(set_w, static_cast<int>(s.set.size()) + 1);
  o << std::left << std::setw(name_w) << "scene" << std::setw(set_w) << "set" << std::right << std::setw(7) << "steps"
    << std::setw(9) << "train s" << std::setw(8) << "eval s" << std::setw(10) << "cam0 obj" << std::setw(7) << "cam0"
    << std::setw(7) << "SSIM" << std::setw(10) << "held obj" << std::setw(9) << "held-out" << std::setw(7) << "SSIM"
    << std::setw(10) << "comp obj" << std::setw(9) << "compose" << "  status\n";
  for (const SceneResult& r : results)
    o << std::left << std::setw(name_w) << r.name << std::setw(set_w) << r.set << std::right << std::setw(7) << r.steps
      << std::setw(9) << num_or(r.train_s, 1) << std::setw(8) << num_or(r.eval_s, 1) << std::setw(10)
      << num_or(r.cam0_object_psnr, 2) << std::setw(7) << num_or(r.cam0_psnr, 2) << std::setw(7)
      << num_or(r.cam0_ssim, 3) << std::setw(10) << num_or(r.heldout_object_psnr, 2) << std::setw(9)
      << num_or(r.heldout_psnr, 2) << std::setw(7) << num_or(r.heldout_ssim, 3) << std::setw(10)
      << num_or(r.compose_object_psnr, 2) << std::setw(9) << num_or(r.compose_psnr, 2) << "  " << r.status << "\n";
  o << "\n"
    << std::left << std::setw(set_w) << "set" << std::right << std::setw(7) << "scenes" << std::setw(10) << "cam0 obj"
    << std::setw(11) << "cam0 mean" << std::setw(10) << "cam0 min" << std::setw(10) << "held obj" << std::setw(15)
    << "held-out mean" << std::setw(10) << "comp obj" << std::setw(14) << "compose mean" << std::setw(10) << "train s"
    << "\n";
  for (const SetSummary& s : sets)
    o << std::left << std::setw(set_w) << s.set << std::right << std::setw(7) << s.scenes << std::setw(10)
      << num_or(s.mean_cam0_object_psnr, 2) << std::setw(11) << num_or(s.mean_cam0_psnr, 2) << std::setw(10)
      << num_or(s.min_cam0_psnr, 2) << std::setw(10) << num_or(s.mean_heldout_object_psnr, 2) << std::setw(15)
      << num_or(s.mean_heldout_psnr, 2) << std::setw(10) << num_or(s.mean_compose_object_psnr, 2) << std::setw(14)
      << num_or(s.mean_compose_psnr, 2) << std::setw(10) << num_or(s.total_train_s, 1) << "\n";
  o << "PSNR in dB (OpenCV's, 8-bit), as nova eval; obj: inside the objects' masks (a composition "
       "target's: where its instances are); '-': the scene has no such views\n";
  return o.str();
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string o = "\"";
  for (char c : s) o += c == '"' ? std::string("\"\"") : std::string(1, c);
  return o + "\"";
}

std::string csv_text(const std::vector<SceneResult>& results, const std::vector<SetSummary>& sets) {
  std::string o = std::string(kCsvHeader) + "\n";
  for (const SceneResult& r : results)
    o += "scene," + csv_field(r.name) + "," + r.set + ",1," + std::to_string(r.steps) + "," + num(r.train_s, 3) + "," +
         num(r.eval_s, 3) + "," + num(r.cam0_psnr, 4) + "," + num(r.cam0_psnr, 4) + "," + num(r.cam0_ssim, 5) + "," +
         num(r.heldout_psnr, 4) + "," + num(r.heldout_ssim, 5) + "," + num(r.compose_psnr, 4) + "," +
         std::to_string(r.cam0_views) + "," + std::to_string(r.heldout_views) + "," + std::to_string(r.compose_views) +
         "," + num(r.cam0_object_psnr, 4) + "," + num(r.heldout_object_psnr, 4) + "," + num(r.compose_object_psnr, 4) +
         "," + csv_field(r.status) + "\n";
  for (const SetSummary& s : sets)
    o += "set," + s.set + "," + s.set + "," + std::to_string(s.scenes) + ",," + num(s.total_train_s, 3) + ",," +
         num(s.mean_cam0_psnr, 4) + "," + num(s.min_cam0_psnr, 4) + ",," + num(s.mean_heldout_psnr, 4) + ",," +
         num(s.mean_compose_psnr, 4) + ",,,," + num(s.mean_cam0_object_psnr, 4) + "," +
         num(s.mean_heldout_object_psnr, 4) + "," + num(s.mean_compose_object_psnr, 4) + ",\n";
  return o;
}

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> out(1);
  bool quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') out.back() += '"', ++i;
      else if (c == '"') quoted = false;
      else out.back() += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      out.emplace_back();
    } else {
      out.back() += c;
    }
  }
  return out;
}

void parse_csv(const std::string& text, std::vector<SceneResult>* results, std::vector<SetSummary>* sets) {
  std::stringstream lines(text);
  std::string line;
  if (!std::getline(lines, line) || line != kCsvHeader) throw Error("accuracy CSV: the header is not '" + std::string(kCsvHeader) + "'");
  const auto number = [](const std::string& f) { return f.empty() ? kNaN : std::stod(f); };
  for (int n = 2; std::getline(lines, line); ++n) {
    if (line.empty()) continue;
    const std::vector<std::string> f = split_csv_line(line);
    if (f.size() != 20) throw Error("accuracy CSV line " + std::to_string(n) + ": " + std::to_string(f.size()) + " fields, not 20");
    try {
      if (f[0] == "scene") {
        SceneResult r;
        r.name = f[1], r.set = f[2], r.steps = std::stol(f[4]), r.train_s = number(f[5]), r.eval_s = number(f[6]);
        r.cam0_psnr = number(f[7]), r.cam0_ssim = number(f[9]), r.heldout_psnr = number(f[10]);
        r.heldout_ssim = number(f[11]), r.compose_psnr = number(f[12]);
        r.cam0_views = std::stoi(f[13]), r.heldout_views = std::stoi(f[14]), r.compose_views = std::stoi(f[15]);
        r.cam0_object_psnr = number(f[16]), r.heldout_object_psnr = number(f[17]), r.compose_object_psnr = number(f[18]);
        r.status = f[19];
        results->push_back(r);
      } else if (f[0] == "set") {
        SetSummary s;
        s.set = f[1], s.scenes = std::stoi(f[3]), s.total_train_s = number(f[5]);
        s.mean_cam0_psnr = number(f[7]), s.min_cam0_psnr = number(f[8]), s.mean_heldout_psnr = number(f[10]);
        s.mean_compose_psnr = number(f[12]);
        s.mean_cam0_object_psnr = number(f[16]), s.mean_heldout_object_psnr = number(f[17]);
        s.mean_compose_object_psnr = number(f[18]);
        sets->push_back(s);
      } else {
        throw Error("kind '" + f[0] + "' is not scene or set");
      }
    } catch (const std::logic_error&) {
      throw Error("accuracy CSV line " + std::to_string(n) + ": a field is not a number");
    }
  }
}

namespace {

// A number as accuracy.json keeps it: rounded to `decimals` as the table and the CSV show it,
// which the JSON writer prints as the shortest text that reads back the same; missing
// (non-finite) numbers are written as null.
double json_number(double v, int decimals) { return std::isfinite(v) ? std::stod(num(v, decimals)) : v; }

}  // namespace

std::string json_text(const std::vector<std::pair<std::string, std::string>>& settings,
                      const std::vector<SceneResult>& results, const std::vector<SetSummary>& sets) {
  nlohmann::ordered_json configuration = nlohmann::ordered_json::object();
  for (const auto& [key, value] : settings) configuration[key] = value;
  nlohmann::ordered_json scenes = nlohmann::ordered_json::array();
  for (const SceneResult& r : results)
    scenes.push_back({{"name", r.name},
                      {"set", r.set},
                      {"status", r.status},
                      {"steps", r.steps},
                      {"train_seconds", json_number(r.train_s, 3)},
                      {"eval_seconds", json_number(r.eval_s, 3)},
                      {"cam0_psnr", json_number(r.cam0_psnr, 4)},
                      {"cam0_ssim", json_number(r.cam0_ssim, 5)},
                      {"cam0_views", r.cam0_views},
                      {"cam0_object_psnr", json_number(r.cam0_object_psnr, 4)},
                      {"cam0_background_psnr", json_number(r.cam0_background_psnr, 4)},
                      {"cam0_object_opacity", json_number(r.cam0_object_opacity, 4)},
                      {"heldout_psnr", json_number(r.heldout_psnr, 4)},
                      {"heldout_ssim", json_number(r.heldout_ssim, 5)},
                      {"heldout_views", r.heldout_views},
                      {"heldout_object_psnr", json_number(r.heldout_object_psnr, 4)},
                      {"heldout_background_psnr", json_number(r.heldout_background_psnr, 4)},
                      {"heldout_object_opacity", json_number(r.heldout_object_opacity, 4)},
                      {"compose_psnr", json_number(r.compose_psnr, 4)},
                      {"compose_object_psnr", json_number(r.compose_object_psnr, 4)},
                      {"compose_object_opacity", json_number(r.compose_object_opacity, 4)},
                      {"compose_views", r.compose_views}});
  nlohmann::ordered_json set_rows = nlohmann::ordered_json::array();
  for (const SetSummary& s : sets)
    set_rows.push_back({{"set", s.set},
                        {"scenes", s.scenes},
                        {"mean_cam0_psnr", json_number(s.mean_cam0_psnr, 4)},
                        {"min_cam0_psnr", json_number(s.min_cam0_psnr, 4)},
                        {"mean_heldout_psnr", json_number(s.mean_heldout_psnr, 4)},
                        {"mean_compose_psnr", json_number(s.mean_compose_psnr, 4)},
                        {"mean_cam0_object_psnr", json_number(s.mean_cam0_object_psnr, 4)},
                        {"mean_heldout_object_psnr", json_number(s.mean_heldout_object_psnr, 4)},
                        {"mean_compose_object_psnr", json_number(s.mean_compose_object_psnr, 4)},
                        {"total_train_seconds", json_number(s.total_train_s, 3)}});
  nlohmann::ordered_json json;
  json["configuration"] = std::move(configuration);
  json["scenes"] = std::move(scenes);
  json["sets"] = std::move(set_rows);
  return json.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

}  // namespace nova::accuracy
