#include "train/metrics_log.hpp"

#include <cmath>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

namespace nova::detail {
namespace {

// A metrics value as the record keeps it: 7 significant digits (float32's), which the JSON
// writer prints as the shortest text that reads back the same. Non-finite values are written
// as null (nlohmann's default), so every line stays valid JSON.
double metric_value(double v) {
  if (!std::isfinite(v)) return v;
  std::ostringstream s;
  s << std::setprecision(7) << v;
  return std::stod(s.str());
}

}  // namespace

// ordered_json keeps the keys in insertion order.
std::string metrics_record(const TrainProgress& p) {
  nlohmann::ordered_json r;
  r["step"] = p.step;
  r["phase"] = p.phase;
  r["loss"] = metric_value(p.loss);
  for (const auto& [name, v] : p.terms) r[name] = metric_value(v);
  r["psnr"] = metric_value(p.psnr);
  r["lr"] = metric_value(p.lr);
  r["augmented"] = p.augmented;
  r["rays_per_s"] = metric_value(p.rays_per_s);
  if (p.kept >= 0) {
    r["samples_kept"] = metric_value(p.kept);
    nlohmann::ordered_json occupied = nlohmann::ordered_json::array();
    for (double f : p.occupied) occupied.push_back(metric_value(f));
    r["occupied"] = std::move(occupied);
  }
  r["seconds"] = metric_value(p.seconds);
  return r.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

void truncate_metrics(const std::string& path, long step) {
  std::ifstream in(path);
  if (!in) return;
  std::string line, kept;
  while (std::getline(in, line)) {
    // A line that is not a record (cut short by a crash) goes too.
    const nlohmann::json record = nlohmann::json::parse(line, nullptr, /*allow_exceptions=*/false);
    const auto at = record.is_object() ? record.find("step") : record.end();
    if (at != record.end() && at->is_number_integer() && at->get<long>() <= step) kept += line + "\n";
  }
  in.close();
  std::ofstream(path, std::ios::trunc) << kept;
}

}  // namespace nova::detail
