// nova-bench devices: every OpenCL device of the node (or a list) side by side, in speed and
// in error, from one run. Each device runs in a child process of its own (this program with
// --one), so a device whose driver fails to compile, runs out of memory or crashes is a row
// that says so and the others go on. Per device:
//   - the paper's MLP (63 -> depth x width ReLU -> 4), forward + backward at --batch rows:
//     samples/s and GFLOP/s (median of --repeats after a warm-up);
//   - its error: outputs and every parameter gradient at --check-rows rows against a float64
//     host evaluation of the same network and weights (largest difference over the largest
//     reference value);
//   - the compositing op (render_composite) of 1 + 2 NeRFs at --composite-rays rays x 64
//     samples, forward + backward: samples/s (median of --repeats);
//   - a short fixed training of a scene (the tiny synthetic scene unless --scene): seconds
//     per step after the first, device memory of the joint step, seconds per rendered camera-0 view, camera-0
//     PSNR, and its difference from the first device that trained.
// Writes a Markdown table (stdout), devices.csv, devices.json and devices.png into --out; exits
// 1 when a device failed (its row says where and why), 2 for bad options or scene.
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "bench.hpp"
#include "composite_problem.hpp"
#include "harness.hpp"
#include "nova/graph/executor.hpp"
#include "nova/eval/evaluation.hpp"
#include "nova/io/image_io.hpp"
#include "nova/data/scene_io.hpp"
#include "nova/data/synth.hpp"
#include "nova/io/charts.hpp"
#include "nova/model/mlp.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/loss/terms.hpp"
#include "nova/runtime/runtime.hpp"
#include "nova/train/trainer.hpp"
#include "options.hpp"

namespace nova::bench {
namespace {

namespace fs = std::filesystem;
using Result = std::map<std::string, std::string>;

constexpr size_t kIn = 63, kOut = 4;

struct MlpGraph {
  Graph g;
  Tensor x, target, y, loss;
  std::vector<Tensor> w, b;  // per layer
};

// x -> depth x (dense ReLU width) -> dense identity 4; loss = mse(y, target).
std::unique_ptr<MlpGraph> mlp_graph(size_t rows, int depth, int width) {
  auto m = std::make_unique<MlpGraph>();
  m->x = m->g.input("x", Shape{rows, kIn});
  m->target = m->g.input("target", Shape{rows, kOut});
  Tensor h = m->x;
  for (int l = 0; l <= depth; ++l) {
    const bool last = l == depth;
    h = dense_layer(h, last ? static_cast<int>(kOut) : width, last ? Activation::Identity : Activation::ReLU,
                    "l" + std::to_string(l));
  }
  m->y = h;
  m->g.keep(m->y);
  m->loss = mse(m->y, m->target);
  m->g.set_loss(m->loss);
  for (Tensor p : m->g.parameters()) (p.info().name.find(".w") != std::string::npos ? m->w : m->b).push_back(p);
  return m;
}

// Largest |a - ref| over the largest |ref|.
double relative_error(const std::vector<float>& a, const std::vector<double>& ref) {
  double diff = 0, scale = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    diff = std::max(diff, std::fabs(static_cast<double>(a[i]) - ref[i]));
    scale = std::max(scale, std::fabs(ref[i]));
  }
  return scale > 0 ? diff / scale : diff;
}

// The MLP's forward and backward in float64 on the host, with the device's weights: returns
// the output error and the largest gradient error over all parameters.
std::pair<double, double> mlp_error(Runtime& rt, size_t rows, int depth, int width) {
  auto m = mlp_graph(rows, depth, width);
  Executor ex(rt, m->g);
  const auto x = test::random_floats(rows * kIn, -1, 1, 3), t = test::random_floats(rows * kOut, 0, 1, 4);
  ex.set(m->x, x);
  ex.set(m->target, t);
  ex.forward();
  ex.backward();
  const size_t L = m->w.size();
  std::vector<std::vector<float>> W(L), Bv(L);
  std::vector<size_t> n_in(L), n_out(L);
  for (size_t l = 0; l < L; ++l) {
    W[l] = ex.get(m->w[l]);
    Bv[l] = ex.get(m->b[l]);
    n_in[l] = m->w[l].shape()[0];
    n_out[l] = m->w[l].shape()[1];
  }
  // Forward, keeping every layer's output.
  std::vector<std::vector<double>> act(L + 1);
  act[0].assign(x.begin(), x.end());
  for (size_t l = 0; l < L; ++l) {
    act[l + 1].assign(rows * n_out[l], 0.0);
    for (size_t r = 0; r < rows; ++r)
      for (size_t o = 0; o < n_out[l]; ++o) {
        double s = Bv[l][o];
        for (size_t i = 0; i < n_in[l]; ++i) s += act[l][r * n_in[l] + i] * W[l][i * n_out[l] + o];
        act[l + 1][r * n_out[l] + o] = l + 1 < L ? std::max(0.0, s) : s;
      }
  }
  const double out_err = relative_error(ex.get(m->y), act[L]);
  // Backward of mean((y - t)^2).
  std::vector<double> dy(rows * kOut);
  for (size_t i = 0; i < dy.size(); ++i) dy[i] = 2.0 * (act[L][i] - t[i]) / static_cast<double>(dy.size());
  double grad_err = 0;
  for (size_t l = L; l-- > 0;) {
    std::vector<double> dw(n_in[l] * n_out[l], 0.0), db(n_out[l], 0.0), dx(rows * n_in[l], 0.0);
    for (size_t r = 0; r < rows; ++r)
      for (size_t o = 0; o < n_out[l]; ++o) {
        const double g = dy[r * n_out[l] + o];
        if (g == 0.0) continue;
        db[o] += g;
        for (size_t i = 0; i < n_in[l]; ++i) {
          dw[i * n_out[l] + o] += act[l][r * n_in[l] + i] * g;
          dx[r * n_in[l] + i] += W[l][i * n_out[l] + o] * g;
        }
      }
    grad_err = std::max({grad_err, relative_error(ex.get_grad(m->w[l]), dw), relative_error(ex.get_grad(m->b[l]), db)});
    if (l > 0)  // through the ReLU of the layer below
      for (size_t i = 0; i < dx.size(); ++i) dx[i] = act[l][i] > 0 ? dx[i] : 0.0;
    dy = std::move(dx);
  }
  return {out_err, grad_err};
}

// Forward + backward samples/s of the MLP at `rows`.
double mlp_speed(Runtime& rt, size_t rows, int depth, int width, int repeats) {
  auto m = mlp_graph(rows, depth, width);
  Executor ex(rt, m->g);
  ex.set(m->x, test::random_floats(rows * kIn, -1, 1, 5));
  ex.set(m->target, test::random_floats(rows * kOut, 0, 1, 6));
  const double secs = time_median(repeats, [&] {
    ex.forward();
    ex.backward();
    rt.finish();
  });
  return static_cast<double>(rows) / secs;
}

// One device, in this process: writes `key=value` lines into `path` as results come in, so a
// crash part-way still tells the parent how far the device got.
int run_one(const Options& o) {
  const std::string path = o.str("result");
  std::ofstream out(path, std::ios::app);
  auto put = [&](const std::string& k, const std::string& v) { out << k << "=" << v << "\n" << std::flush; };
  auto num = [](double v) {
    std::ostringstream s;
    s << std::setprecision(9) << v;
    return s.str();
  };
  const DeviceInfo d = select_device(o.str("one"));
  put("name", d.name);
  put("driver", d.driver_version);
  put("units", std::to_string(d.compute_units));
  put("memory_mb", std::to_string(d.global_mem_bytes >> 20));
  put("stage", "runtime");
  Runtime rt(d, false);
  const int depth = static_cast<int>(o.integer("depth")), width = static_cast<int>(o.integer("width"));
  put("stage", "mlp");
  const double sps = mlp_speed(rt, static_cast<size_t>(o.integer("batch")), depth, width, static_cast<int>(o.integer("repeats")));
  const double flops = 6.0 * (kIn * width + (depth - 1.0) * width * width + width * kOut);  // fwd + bwd per row
  put("mlp_samples_s", num(sps));
  put("mlp_gflops", num(sps * flops * 1e-9));
  put("stage", "mlp check");
  const auto [eo, eg] = mlp_error(rt, static_cast<size_t>(o.integer("check-rows")), depth, width);
  put("mlp_out_err", num(eo));
  put("mlp_grad_err", num(eg));
  put("stage", "compositing");
  {
    CompositeProblem p(rt, 3, static_cast<size_t>(o.integer("composite-rays")), 64);
    const int repeats = static_cast<int>(o.integer("repeats"));
    const double secs = p.forward_seconds(repeats) + p.backward_seconds(repeats);
    put("composite_samples_s", num(static_cast<double>(p.rays() * p.samples()) / secs));
  }

  put("stage", "training");
  TrainConfig c = preset_config("quick");
  c.pretrain_steps = static_cast<int>(o.integer("pretrain-steps"));
  c.steps = static_cast<int>(o.integer("steps"));
  c.log_every = 1000000;
  c.checkpoint_every = 1000000;
  Scene scene = load_training_scene(o.str("scene"), c, true);
  const fs::path run = fs::path(path).parent_path() / ("run-" + std::to_string(::getpid()));
  Trainer t(rt, scene, c, run.string());
  // Timed after the first step (graph building, kernel compiles) up to the last step's
  // progress report, which comes before run() writes its closing checkpoint.
  t.run({}, 1);
  rt.finish();
  const auto a = std::chrono::steady_clock::now();
  auto b = a;
  t.run([&](const TrainProgress&) { b = std::chrono::steady_clock::now(); });
  put("train_s_per_step", num(std::chrono::duration<double>(b - a).count() / (t.total_steps() - 1)));
  put("device_mb", num(static_cast<double>(t.device_bytes()) / (1 << 20)));
  put("stage", "evaluation");
  const Checkpoint ck = t.checkpoint();  // the renderer keeps a reference to it
  ViewRenderer renderer(rt, c, ray_geometry(scene), ck);
  std::vector<GroundTruthView> views;
  for (const GroundTruthView& v : scene.gt_views)
    if (v.kind == "cam0") views.push_back(v);
  const auto v0 = std::chrono::steady_clock::now();
  put("psnr", num(mean_scores(score_views(renderer, scene.num_objects, views, false)).first));
  put("view_s", num(std::chrono::duration<double>(std::chrono::steady_clock::now() - v0).count() /
                    static_cast<double>(std::max<size_t>(1, views.size()))));
  std::error_code ec;
  fs::remove_all(run, ec);
  put("stage", "done");
  return 0;
}

Result read_result(const fs::path& p) {
  Result r;
  std::ifstream in(p);
  for (std::string line; std::getline(in, line);) {
    const size_t eq = line.find('=');
    if (eq != std::string::npos) r[line.substr(0, eq)] = line.substr(eq + 1);
  }
  return r;
}

std::string get(const Result& r, const std::string& k) {
  const auto it = r.find(k);
  return it == r.end() ? "" : it->second;
}

}  // namespace

int devices(const Args& args) {
  const Options o(args, {{"devices", "all"}, {"batch", "16384"}, {"depth", "8"}, {"width", "256"}, {"repeats", "3"},
                         {"check-rows", "256"}, {"composite-rays", "16384"}, {"scene", ""}, {"pretrain-steps", "100"}, {"steps", "100"},
                         {"out", "devices"}, {"one", ""}, {"result", ""}});
  if (o.help()) {
    std::cout << o.usage("nova-bench devices") << "\n--devices: all, or ids/names separated by ','\n";
    return 0;
  }
  // Counts every device run takes (all >= 1), handed on to each child with the step counts.
  const std::vector<const char*> counts = {"batch", "depth", "width", "repeats", "check-rows", "composite-rays"};
  for (const char* k : counts)
    if (o.integer(k) < 1) throw Error(std::string("--") + k + " must be >= 1");
  if (o.integer("pretrain-steps") < 0 || o.integer("steps") < 1 || o.integer("pretrain-steps") + o.integer("steps") < 2)
    throw Error("--pretrain-steps must be >= 0, --steps >= 1, and the two at least 2 (the first step is not timed)");
  if (!o.str("one").empty()) return run_one(o);

  std::vector<DeviceInfo> chosen;
  const std::vector<DeviceInfo> all = list_devices();
  if (all.empty()) throw Error("no OpenCL platform is installed (install an ICD, e.g. pocl-opencl-icd)");
  if (o.str("devices") == "all") {
    chosen = all;
  } else {
    for (const std::string& sel : o.strings("devices")) chosen.push_back(select_device(sel));
  }
  const fs::path out = o.str("out");
  const ScratchDir work("devices");
  std::string scene = o.str("scene");
  if (scene.empty()) {
    scene = (work / "tiny").string();
    write_synthetic_scene(scene, "tiny", 7);
  } else {
    load_scene(scene);  // bad input fails here, once, rather than as a failure of every device
  }
  // This program, to run each device in a child of its own.
  const std::string self = fs::read_symlink("/proc/self/exe").string();
  std::cout << "nova-bench devices: " << chosen.size() << " device(s); MLP 63 -> " << o.integer("depth") << " x "
            << o.integer("width") << " -> 4 at " << o.integer("batch") << " rows, error at " << o.integer("check-rows")
            << " rows against float64; training: quick, " << o.integer("pretrain-steps") << " + " << o.integer("steps")
            << " steps of " << scene << "\n\n";
  std::vector<std::pair<DeviceInfo, Result>> rows;
  for (const DeviceInfo& d : chosen) {
    const fs::path res = work / ("device-" + d.id() + ".txt"), err = work / ("device-" + d.id() + ".err");
    std::ostringstream cmd;
    cmd << "'" << self << "' devices --one " << d.id() << " --result '" << res.string() << "' --scene '" << scene << "'";
    for (const char* k : counts) cmd << " --" << k << " " << o.integer(k);
    for (const char* k : {"pretrain-steps", "steps"}) cmd << " --" << k << " " << o.integer(k);
    cmd << " > /dev/null 2> '" << err.string() << "'";
    std::cerr << "device " << d.id() << " (" << d.name << ") ..." << std::endl;
    const int status = std::system(cmd.str().c_str());
    Result r = read_result(res);
    if (get(r, "stage") != "done") {
      std::string why = WIFSIGNALED(status) ? "crashed (signal " + std::to_string(WTERMSIG(status)) + ")"
                                            : "failed (exit " + std::to_string(WEXITSTATUS(status)) + ")";
      std::ifstream e(err);
      std::string last, line;
      while (std::getline(e, line))
        if (!line.empty()) last = line;
      r["status"] = why + " in " + (get(r, "stage").empty() ? "start-up" : get(r, "stage")) + (last.empty() ? "" : ": " + last);
    } else {
      r["status"] = "ok";
    }
    rows.emplace_back(d, r);
  }
  // PSNR difference from the first device that trained.
  std::string first_psnr;
  for (auto& [d, r] : rows)
    if (!get(r, "psnr").empty()) {
      if (first_psnr.empty()) first_psnr = get(r, "psnr");
      std::ostringstream s;
      s << std::fixed << std::setprecision(3) << std::stod(get(r, "psnr")) - std::stod(first_psnr);
      r["psnr_diff"] = s.str();
    }

  const std::vector<std::pair<std::string, std::string>> cols = {
      {"name", "device"}, {"driver", "driver"}, {"units", "CUs"}, {"memory_mb", "memory MB"},
      {"mlp_samples_s", "MLP samples/s"}, {"mlp_gflops", "MLP GFLOP/s"}, {"mlp_out_err", "MLP output err"},
      {"mlp_grad_err", "MLP gradient err"}, {"composite_samples_s", "composite samples/s"},
      {"train_s_per_step", "train s/step"}, {"device_mb", "step device MB"},
      {"view_s", "render s/view"},
      {"psnr", "camera-0 PSNR"}, {"psnr_diff", "PSNR - first"}, {"status", "status"}};
  auto shown = [](const std::string& k, const std::string& v) {
    if (v.empty() || k == "name" || k == "driver" || k == "status" || k == "units" || k == "memory_mb") return v;
    std::ostringstream s;
    const double x = std::stod(v);
    if (k.find("err") != std::string::npos) s << std::scientific << std::setprecision(1) << x;
    else s << std::fixed << std::setprecision(k == "mlp_samples_s" || k == "composite_samples_s" || k == "device_mb" ? 0 : k == "train_s_per_step" || k == "view_s" ? 3 : 2) << x;
    return s.str();
  };
  std::ostringstream md, csv;
  // Every value a string, as the CSV has it (empty where a stage did not run).
  nlohmann::ordered_json devices = nlohmann::ordered_json::array();
  md << "| id |";
  csv << "id";
  for (const auto& [k, h] : cols) md << " " << h << " |", csv << "," << k;
  md << "\n|---|";
  csv << "\n";
  for (size_t i = 0; i < cols.size(); ++i) md << "---|";
  md << "\n";
  for (size_t i = 0; i < rows.size(); ++i) {
    const auto& [d, r] = rows[i];
    md << "| " << d.id() << " |";
    csv << d.id();
    nlohmann::ordered_json row;
    row["id"] = d.id();
    for (const auto& [k, h] : cols) {
      const std::string v = get(r, k);
      md << " " << shown(k, v) << " |";
      std::string q = v;
      std::replace(q.begin(), q.end(), ',', ';');
      csv << "," << q;
      row[k] = v;
    }
    md << "\n";
    csv << "\n";
    devices.push_back(std::move(row));
  }
  const nlohmann::ordered_json json = {{"devices", std::move(devices)}};
  std::cout << md.str();
  fs::create_directories(out);
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream((out / (name + ".tmp")).string()) << text;
    fs::rename(out / (name + ".tmp"), out / name);
  };
  write("devices.md", md.str());
  write("devices.csv", csv.str());
  write("devices.json", json.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n");
  std::vector<BarGroup> speed, error;
  for (const auto& [d, r] : rows) {
    BarGroup s{d.id(), {}}, e{d.id(), {}};
    if (!get(r, "mlp_gflops").empty()) s.bars.push_back({"MLP GFLOP/s", std::stod(get(r, "mlp_gflops"))});
    if (!get(r, "composite_samples_s").empty())
      s.bars.push_back({"composite Msamples/s", std::stod(get(r, "composite_samples_s")) * 1e-6});
    if (!get(r, "train_s_per_step").empty()) s.bars.push_back({"training steps/s x 10", 10.0 / std::stod(get(r, "train_s_per_step"))});
    if (!get(r, "psnr").empty()) e.bars.push_back({"camera-0 PSNR dB", std::stod(get(r, "psnr"))});
    speed.push_back(s);
    error.push_back(e);
  }
  write_png((out / "devices.png").string(),
            stack_images({plot_bar_groups(speed, "speed per device", "", 2), plot_bar_groups(error, "accuracy per device", "dB", 2)}));
  std::cout << "\nwrote " << (out / "devices.md").string() << ", devices.csv, devices.json, devices.png\n";
  // A device that failed is a row of the table; the exit code says that one did.
  for (const auto& [d, r] : rows)
    if (get(r, "status") != "ok") return kExitInternal;
  return 0;
}

}  // namespace nova::bench
