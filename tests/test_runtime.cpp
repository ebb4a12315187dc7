// Device discovery and choice, program building and its error reporting.
#include <boost/test/unit_test.hpp>
#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "harness.hpp"
#include "nova/runtime/runtime.hpp"

using namespace nova;

namespace {

// Runs the nova CLI with `args`, returns its exit code and captured stderr.
std::pair<int, std::string> run_cli(const std::string& args, const std::string& env = "") {
  const std::string err = std::filesystem::temp_directory_path() / "nova_test_runtime.err";
  const std::string cmd = env + " " + NOVA_BINARY_DIR "/nova " + args + " >/dev/null 2>" + err;
  const int status = std::system(cmd.c_str());
  std::string text;
  if (FILE* f = std::fopen(err.c_str(), "r")) {
    char buf[4096];
    size_t n;
    while ((n = std::fread(buf, 1, sizeof buf, f)) > 0) text.append(buf, n);
    std::fclose(f);
  }
  std::filesystem::remove(err);
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, text};
}

}  // namespace

BOOST_AUTO_TEST_SUITE(runtime)

BOOST_AUTO_TEST_CASE(lists_devices_and_selects_by_index_and_name) {
  const auto all = list_devices();
  BOOST_REQUIRE(!all.empty());
  for (const auto& d : all) {
    BOOST_TEST(!d.name.empty());
    BOOST_TEST(d.compute_units > 0u);
    BOOST_TEST(d.global_mem_bytes > 0u);
    BOOST_TEST(select_device(d.id()).device == d.device);
    BOOST_TEST(select_device(d.name.substr(0, 6)).name.find(d.name.substr(0, 6)) == 0u);
  }
  // By type: the first device of that type, in list order; a type the machine lacks is an
  // error naming it.
  for (const char* type : {"cpu", "GPU"}) {
    const cl_device_type want = std::string(type) == "cpu" ? CL_DEVICE_TYPE_CPU : CL_DEVICE_TYPE_GPU;
    const auto first = std::find_if(all.begin(), all.end(), [&](const DeviceInfo& d) { return (d.type & want) != 0; });
    if (first == all.end()) {
      try {
        select_device(type);
        BOOST_FAIL("select_device(" << type << ") chose a device on a machine without one");
      } catch (const Error& e) {
        BOOST_TEST(std::string(e.what()).find("no " + std::string(type == std::string("cpu") ? "cpu" : "gpu")) != std::string::npos, e.what());
      }
    } else {
      const DeviceInfo d = select_device(type);
      BOOST_TEST((d.platform == first->platform && d.device == first->device), type);
    }
  }
}

BOOST_AUTO_TEST_CASE(bad_selector_is_a_usage_error_naming_what_was_found) {
  try {
    select_device("no-such-device-anywhere");
    BOOST_FAIL("select_device accepted a selector that matches nothing");
  } catch (const Error& e) {
    const std::string what = e.what();
    BOOST_TEST(e.exit_code() == kExitUsage);
    BOOST_TEST(what.find("no-such-device-anywhere") != std::string::npos);
    BOOST_TEST(what.find("found:") != std::string::npos);
    BOOST_TEST(what.find(list_devices().front().name) != std::string::npos);
  }
  try {
    select_device("9:9");
    BOOST_FAIL("select_device accepted index 9:9");
  } catch (const Error& e) {
    BOOST_TEST(e.exit_code() == kExitUsage);
  }
}

BOOST_AUTO_TEST_CASE(cli_reports_bad_selector_with_exit_code_2) {
  if (!std::filesystem::exists(NOVA_BINARY_DIR "/nova")) return;  // built without tools
  const auto [code, err] = run_cli("devices --device no-such-device");
  BOOST_TEST(code == 2);
  BOOST_TEST(err.find("no-such-device") != std::string::npos);
  BOOST_TEST(std::count(err.begin(), err.end(), '\n') == 1, "one line: " << err);
  const auto [code_env, err_env] = run_cli("devices", "NOVA_DEVICE=nothing-here");
  BOOST_TEST(code_env == 2);
  BOOST_TEST(err_env.find("NOVA_DEVICE") != std::string::npos);
  const auto [code_ok, err_ok] = run_cli("devices");
  BOOST_TEST(code_ok == 0, err_ok);
}

BOOST_AUTO_TEST_CASE(cli_rejects_bad_options_with_exit_code_2) {
  if (!std::filesystem::exists(NOVA_BINARY_DIR "/nova")) return;
  for (const char* args : {"train-mlp --steps 0", "train-mlp --bogus 1", "train-mlp --lr abc",
                           "no-such-command"}) {
    const auto [code, err] = run_cli(args);
    BOOST_TEST(code == 2, args << ": " << err);
    BOOST_TEST(!err.empty(), args);
  }
  BOOST_TEST(run_cli("train-mlp --help").first == 0);
}

BOOST_AUTO_TEST_CASE(cli_without_platform_says_what_to_install) {
  if (!std::filesystem::exists(NOVA_BINARY_DIR "/nova")) return;
  // An empty vendor directory leaves the ICD loader with no platform at all.
  const auto empty = std::filesystem::temp_directory_path() / "nova_no_icd";
  std::filesystem::create_directories(empty);
  const auto [code, err] = run_cli("devices", "OCL_ICD_VENDORS=" + empty.string());
  std::filesystem::remove_all(empty);
  BOOST_TEST(code == 2);
  BOOST_TEST(err.find("no OpenCL platform") != std::string::npos, err);
  BOOST_TEST(err.find("pocl-opencl-icd") != std::string::npos, err);
}

BOOST_AUTO_TEST_CASE(programs_are_cached_per_context) {
  Runtime& rt = test::runtime();
  cl_kernel a = rt.kernel("tensor", "copy_cols");
  cl_kernel b = rt.kernel("tensor", "copy_cols");
  BOOST_TEST(a == b);
  BOOST_TEST(rt.work_group_size(a) >= 1u);
  BOOST_TEST(rt.work_group_size(a) <= rt.info().max_work_group_size);
}

// A launch of a few long work-items caps its groups (Launch::run's max_group) so that a CPU
// device's threads share them: the group is as asked, and every item still runs once.
BOOST_AUTO_TEST_CASE(a_capped_work_group_runs_every_item) {
  Runtime& rt = test::runtime();
  rt.record_launches(true);  // left on, as the op table's suite leaves it: records cost nothing else
  const unsigned total = 37, cols = 3;
  const std::vector<float> fill = {1.5f, -2.0f, 4.0f};
  for (size_t cap : {size_t{0}, size_t{1}, size_t{4}}) {
    Buffer dense = rt.upload_floats(std::vector<float>(total + 5, 0.0f));
    Buffer f = rt.upload_floats(fill);
    rt.launch("packing", "fill_rows").arg(dense).arg(f).arg(total).arg(cols).run(total, cap);
    const std::vector<float> out = rt.download_floats(dense.get(), total + 5);
    for (unsigned t = 0; t < total + 5; ++t) BOOST_TEST(out[t] == (t < total ? fill[t % cols] : 0.0f));
    bool seen = false;
    for (const LaunchRecord& r : rt.launches())
      if (r.family == "packing" && r.name == "fill_rows" && r.size[0] == total) {
        const size_t own = rt.work_group_size(rt.kernel("packing", "fill_rows"));
        seen = seen || r.local[0] == (cap ? std::min(cap, own) : own);
      }
    BOOST_TEST(seen, "no launch of fill_rows with work-group " << cap);
  }
}

// Asynchronous uploads land in order, even when each one overwrites the last, and their
// staging blocks are freed by the runtime's own later calls (no event callbacks): never more
// than kMaxStagedUploads wait, and none after a blocking transfer or finish.
BOOST_AUTO_TEST_CASE(async_uploads_land_in_order_and_their_staging_is_freed) {
  Runtime rt(test::runtime().info(), false);
  const size_t n = 64, uploads = 3 * Runtime::kMaxStagedUploads;
  Buffer b = rt.upload_floats(std::vector<float>(n, -1.0f));
  size_t most = 0;
  for (size_t u = 0; u < uploads; ++u) {
    std::vector<float> v(n);
    for (size_t i = 0; i < n; ++i) v[i] = static_cast<float>(u * n + i);
    // Every second upload writes the whole buffer, the others its first half only.
    rt.upload_async(b.get(), v.data(), (u % 2 ? n : n / 2) * sizeof(float));
    most = std::max(most, rt.staged_uploads());
  }
  BOOST_TEST(most <= Runtime::kMaxStagedUploads);
  const std::vector<float> out = rt.download_floats(b.get(), n);
  BOOST_TEST(rt.staged_uploads() == 0u);
  // The last upload (u = uploads - 1, odd) wrote the whole buffer.
  for (size_t i = 0; i < n; ++i) BOOST_TEST(out[i] == static_cast<float>((uploads - 1) * n + i));
  std::vector<float> half(n / 2, 7.0f);
  rt.upload_async(b.get(), half.data(), half.size() * sizeof(float), (n / 2) * sizeof(float));
  BOOST_TEST(rt.staged_uploads() <= 1u);
  rt.finish();
  BOOST_TEST(rt.staged_uploads() == 0u);
  const std::vector<float> after = rt.download_floats(b.get(), n);
  BOOST_TEST(after[0] == out[0]);
  BOOST_TEST(after[n - 1] == 7.0f);
}

BOOST_AUTO_TEST_CASE(build_failure_shows_the_compiler_log) {
  Runtime& rt = test::runtime();
  try {
    rt.kernel("bias_act", "bias_act_forward", "-DACT=)");  // breaks `#if ACT == 1`
    BOOST_FAIL("a broken build was accepted");
  } catch (const Error& e) {
    const std::string what = e.what();
    BOOST_TEST(what.find("kernels/bias_act.cl failed to build") != std::string::npos, what);
    BOOST_TEST(what.size() > 120u, "the message carries the build log: " << what);
  }
  BOOST_CHECK_THROW(rt.kernel("no_such_family", "k"), Error);
  BOOST_CHECK_THROW(rt.kernel("tensor", "no_such_kernel"), Error);
}

BOOST_AUTO_TEST_SUITE_END()
