// GEMM tuning: the per-device cache (round trip, merge, corrupt files), the parameter search
// (its float64 reference check must reject a wrong candidate), and the tuned configurations
// (blocked kernels with split reductions and packed A^T, the cache's dispatch) against float64
// products. Bound per element, as test_gemm: 2 k u sum |a b| + 2 u |beta c|, u = 2^-24.
#include <boost/test/unit_test.hpp>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <unistd.h>

#include "harness.hpp"
#include "nova/ops/linalg/gemm.hpp"

using namespace nova;
namespace fs = std::filesystem;

namespace {

std::string temp_path(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("nova-gemm-tune-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return (dir / name).string();
}

GemmCacheEntry entry(const std::string& device, const std::string& shape, const std::string& cfg,
                     double def, double tuned) {
  GemmCacheEntry e;
  e.device = device;
  e.vendor = "Vendor";
  e.driver = "1.0";
  e.clblast = clblast_version();
  std::istringstream in(shape);
  std::string dims;
  in >> e.shape.kind >> dims;
  char x;
  std::istringstream d(dims);
  d >> e.shape.m >> x >> e.shape.n >> x >> e.shape.k;
  e.config = GemmConfig::parse(cfg);
  e.default_gflops = def;
  e.tuned_gflops = tuned;
  return e;
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

// Runs op(A) op(B) (+ beta C) through `cfg` and returns worst error / bound over all of C.
double run_and_check(const GemmConfig& cfg, bool ta, bool tb, size_t m, size_t n, size_t k,
                     size_t batch, float alpha, float beta) {
  Runtime& rt = test::runtime();
  const size_t sa = m * k, sb = k * n, sc = m * n;
  const auto a = test::random_floats(sa * batch, -1, 1, 21);
  const auto b = test::random_floats(sb * batch, -1, 1, 22);
  const auto c0 = test::random_floats(sc * batch, -1, 1, 23);
  Buffer da = rt.upload_floats(a), db = rt.upload_floats(b), dc = rt.upload_floats(c0);
  GemmArgs g{ta, tb, m, n, k, alpha, da.get(), ta ? m : k, sa, db.get(), tb ? k : n, sb,
             beta, dc.get(), n, sc, batch};
  Buffer temp;
  if (size_t bytes = gemm_temp_bytes_with(rt, cfg, g)) temp = rt.alloc(bytes);
  gemm_with(rt, cfg, g, temp.get());
  const auto out = rt.download_floats(dc.get(), sc * batch);
  double worst = 0;
  for (size_t p = 0; p < batch; ++p) {
    auto slice = [&](const std::vector<float>& v, size_t s) {
      return std::vector<float>(v.begin() + p * s, v.begin() + (p + 1) * s);
    };
    GemmArgs one = g;
    one.batch = 1;
    worst = std::max(worst, gemm_error_ratio(one, slice(a, sa), slice(b, sb), slice(c0, sc),
                                             slice(out, sc)));
  }
  return worst;
}

}  // namespace

BOOST_AUTO_TEST_SUITE(gemm_tune)

BOOST_AUTO_TEST_CASE(config_strings_round_trip) {
  for (const char* text : {"clblast", "clblast KC=2048", "kernels", "blocked KC=256 RM=6 TA=1 VN=2",
                           "clblast KWG=16 MWG=64 NWG=64"})
    BOOST_TEST(GemmConfig::parse(text).str() == text);
  for (const char* bad : {"", "cublas", "blocked RM=x", "blocked RM=-1", "blocked RM=99",
                          "blocked FOO=1", "kernels RM=4", "blocked RM"})
    BOOST_CHECK_THROW(GemmConfig::parse(bad), Error);
}

BOOST_AUTO_TEST_CASE(cache_round_trip_and_merge) {
  const std::string path = temp_path("sub/dir/cache.tsv");  // the folder is created
  fs::remove_all(fs::path(path).parent_path());
  std::vector<GemmCacheEntry> in = {
      entry("dev\twith tab \\ and backslash", "nn 16384x256x256", "blocked RM=6 VN=2", 14.5, 49.75),
      entry("other", "tn 256x256x16384", "blocked KC=256 RM=4 VN=2", 16, 26),
      entry("other", "nt 8192x319x256",
            "clblast GEMMK=0 KREG=1 KWG=16 KWI=2 MDIMA=8 MDIMC=8 MWG=64 NDIMB=8 NDIMC=8 NWG=64 "
            "SA=1 SB=1 STRM=0 STRN=0 VWM=8 VWN=8",
            1, 2)};
  write_gemm_cache(path, in);
  const auto out = read_gemm_cache(path);
  BOOST_TEST_REQUIRE(out.size() == in.size());
  for (size_t i = 0; i < in.size(); ++i) {
    BOOST_TEST(out[i].device == in[i].device);
    BOOST_TEST(out[i].vendor == in[i].vendor);
    BOOST_TEST(out[i].driver == in[i].driver);
    BOOST_TEST(out[i].clblast == in[i].clblast);
    BOOST_TEST(out[i].shape.str() == in[i].shape.str());
    BOOST_TEST(out[i].config.str() == in[i].config.str());
    BOOST_TEST(out[i].default_gflops == in[i].default_gflops, boost::test_tools::tolerance(1e-3));
    BOOST_TEST(out[i].tuned_gflops == in[i].tuned_gflops, boost::test_tools::tolerance(1e-3));
  }
  // A merge replaces the same device and shape and keeps the rest; no temporary is left.
  merge_gemm_cache(path, {entry("other", "tn 256x256x16384", "blocked KC=1024 RM=6 VN=2", 16, 30)});
  const auto merged = read_gemm_cache(path);
  BOOST_TEST(merged.size() == 3u);
  size_t found = 0;
  for (const auto& e : merged)
    if (e.device == "other" && e.shape.kind == "tn") {
      ++found;
      BOOST_TEST(e.config.str() == "blocked KC=1024 RM=6 VN=2");
    }
  BOOST_TEST(found == 1u);
  for (const auto& f : fs::directory_iterator(fs::path(path).parent_path()))
    BOOST_TEST(f.path().filename() == "cache.tsv", "left behind: " << f.path());
  BOOST_TEST(read_gemm_cache(temp_path("does-not-exist.tsv")).empty());
}

BOOST_AUTO_TEST_CASE(corrupt_cache_is_a_clear_error_or_warning) {
  const std::string header = "# comment\nnova-gemm-tuning\t1\n";
  const std::string good = "d\tv\t1\t" + clblast_version() + "\tnn 16384x64x64\tblocked RM=6 VN=2\t1\t2\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"\x7f" "ELF garbage\n", "not a nova GEMM tuning cache"},
      {header + good + "d\tv\t1\n", "line 4: expected 8 tab-separated fields"},
      {header + "d\tv\t1\tx\tqq 1x2x3\tblocked\t1\t2\n", "line 3: shape"},
      {header + "d\tv\t1\tx\tnn 1x2x3\tblocked RM=abc\t1\t2\n", "line 3:"},
      {header + "d\tv\t1\tx\tnn 1x2x3\tblocked\tfast\t2\n", "line 3: 'fast' is not a GFLOP/s"},
      {header + "d\\q\tv\t1\tx\tnn 1x2x3\tblocked\t1\t2\n", "line 3: bad escape"},
  };
  const std::string path = temp_path("corrupt.tsv");
  for (const auto& [text, expect] : cases) {
    write_text(path, text);
    try {
      read_gemm_cache(path);
      BOOST_ERROR("no error for a corrupt cache (" << expect << ")");
    } catch (const Error& e) {
      const std::string msg = e.what();
      BOOST_TEST(msg.find(path) != std::string::npos, msg);
      BOOST_TEST(msg.find(expect) != std::string::npos, msg);
    }
    // Start-up: one warning naming the file, no winners, no exception.
    std::ostringstream warn;
    BOOST_TEST(read_gemm_cache_or_warn(path, warn).empty());
    BOOST_TEST(warn.str().find(path) != std::string::npos, warn.str());
    BOOST_TEST(warn.str().find("warning") != std::string::npos, warn.str());
  }
  // A folder where the file should be: a warning too.
  const std::string dir = temp_path("a-folder.tsv");
  fs::create_directories(dir);
  std::ostringstream warn;
  BOOST_TEST(read_gemm_cache_or_warn(dir, warn).empty());
  BOOST_TEST(warn.str().find(dir) != std::string::npos, warn.str());
  // `nova tune` over a corrupt cache replaces it.
  write_text(path, "garbage\n");
  merge_gemm_cache(path, {entry("d", "nn 16384x64x64", "blocked RM=6 VN=2", 1, 2)});
  BOOST_TEST(read_gemm_cache(path).size() == 1u);
}

BOOST_AUTO_TEST_CASE(shape_classes) {
  auto cls = [](bool ta, bool tb, size_t m, size_t n, size_t k) {
    const auto c = gemm_shape_class(GemmArgs{ta, tb, m, n, k});
    return c ? c->str() : std::string("none");
  };
  BOOST_TEST(cls(false, false, 65536, 256, 63) == "nn 65536x256x63");
  BOOST_TEST(cls(false, false, 50000, 256, 256) == "nn 32768x256x256");
  BOOST_TEST(cls(false, true, 9000, 319, 256) == "nt 8192x319x256");
  BOOST_TEST(cls(true, false, 256, 4, 20000) == "tn 256x4x16384");
  BOOST_TEST(cls(false, false, 1000, 256, 256) == "none");  // short: never tuned
  BOOST_TEST(cls(true, true, 4096, 256, 256) == "none");
}

// The search's reference check must be able to fail: a candidate that scales the product by
// 1 + 1e-4 (a subtle error, far above the float32 bound for k = 32) and one that leaves the
// last row untouched are rejected, and the correct candidate wins.
BOOST_AUTO_TEST_CASE(search_rejects_wrong_candidates) {
  Runtime& rt = test::runtime();
  const GemmShapeClass shape{"nn", kGemmTunedMinRows, 24, 32};
  const GemmConfig good{"blocked", {{"RM", 4}, {"VN", 1}}};
  std::vector<GemmCandidate> cands;
  cands.push_back({good, {}});
  cands.push_back({GemmConfig{"blocked", {{"RM", 4}, {"VN", 1}}},
                   [&](Runtime& r, const GemmArgs& g, cl_mem temp) {
                     GemmArgs w = g;
                     w.alpha *= 1.0001f;
                     gemm_with(r, good, w, temp);
                   }});
  cands.push_back({GemmConfig{"blocked", {{"RM", 4}, {"VN", 1}}},
                   [&](Runtime& r, const GemmArgs& g, cl_mem temp) {
                     GemmArgs w = g;
                     w.m -= 1;  // the last row is never written
                     gemm_with(r, good, w, temp);
                   }});
  GemmSearchOptions o;
  o.repeats = 1;
  o.check_rows = 101;
  const auto res = search_gemm(rt, shape, cands, o);
  BOOST_TEST_REQUIRE(res.trials.size() == 3u);
  BOOST_TEST(res.trials[0].ok, res.trials[0].note);
  BOOST_TEST(res.trials[0].error_ratio <= 1.0);
  for (size_t i : {1u, 2u}) {
    BOOST_TEST(!res.trials[i].ok);
    BOOST_TEST(res.trials[i].note.find("rejected") != std::string::npos, res.trials[i].note);
    BOOST_TEST(res.trials[i].error_ratio > 1.0);
  }
  BOOST_TEST(res.winner == 0);
  BOOST_TEST(res.config.str() == good.str());
}

// A configuration the provider cannot run is a failed trial, not an exception.
BOOST_AUTO_TEST_CASE(search_survives_failing_candidates) {
  Runtime& rt = test::runtime();
  const GemmShapeClass shape{"tn", 16, 8, kGemmTunedMinRows};
  std::vector<GemmCandidate> cands = {
      {GemmConfig{"blocked", {{"RM", 2}, {"VN", 1}, {"KC", 512}}}, {}},
      {GemmConfig{"blocked", {{"RM", 2}}}, [](Runtime&, const GemmArgs&, cl_mem) {
         throw Error("this candidate cannot run");
       }}};
  GemmSearchOptions o;
  o.repeats = 1;
  o.check_rows = 600;  // > KC: the check runs the split reduction too
  const auto res = search_gemm(rt, shape, cands, o);
  BOOST_TEST(res.trials[0].ok, res.trials[0].note);
  BOOST_TEST(!res.trials[1].ok);
  BOOST_TEST(res.trials[1].note.find("cannot run") != std::string::npos, res.trials[1].note);
  BOOST_TEST(res.winner == 0);
}

// Every blocked variant the search proposes, at ragged sizes (no multiple of RM or 8 VN),
// with beta != 0, batches, transposes, split reductions with a ragged last chunk, and A^T
// packed first.
BOOST_AUTO_TEST_CASE(blocked_configs_match_float64) {
  Runtime& rt = test::runtime();
  std::set<std::string> seen;
  for (const char* kind : {"nn", "nt", "tn"}) {
    for (const auto& c : gemm_candidates(rt, GemmShapeClass{kind, 4096, 64, 64}, false)) {
      if (c.config.provider != "blocked") continue;
      GemmConfig cfg = c.config;
      if (cfg.params.count("KC")) cfg.params["KC"] = 40;  // several chunks at k = 131
      const bool ta = std::string(kind) == "tn", tb = std::string(kind) == "nt";
      BOOST_TEST_CONTEXT(kind << " " << cfg.str()) {
        BOOST_TEST(run_and_check(cfg, ta, tb, 37, 53, 131, 1, 1.0f, 0.0f) <= 1.0);
        BOOST_TEST(run_and_check(cfg, ta, tb, 29, 19, 131, 2, 0.5f, 0.75f) <= 1.0);
        BOOST_TEST(run_and_check(cfg, ta, tb, 3, 5, 1, 1, 1.0f, 1.0f) <= 1.0);
      }
      seen.insert(cfg.str());
    }
  }
  BOOST_TEST(seen.size() >= 5u);
}

// Split-K through CLBlast (KC=n): every transposition CLBlast takes, a ragged last chunk
// (k = 131 in chunks of 40: three full chunks in one strided-batched call, then the
// remainder), exact chunks (k = 120), one chunk (no split), batches, alpha and beta; the
// search proposes it for the weight gradient.
BOOST_AUTO_TEST_CASE(clblast_split_k_matches_float64) {
  for (const size_t kc : {size_t{40}, size_t{200}})
    for (const auto& [ta, tb] : {std::pair{true, false}, {false, false}, {false, true}, {true, true}}) {
      const GemmConfig cfg{"clblast", {{"KC", kc}}};
      BOOST_TEST_CONTEXT(cfg.str() << " ta=" << ta << " tb=" << tb) {
        BOOST_TEST(run_and_check(cfg, ta, tb, 37, 53, 131, 1, 1.0f, 0.0f) <= 1.0);
        BOOST_TEST(run_and_check(cfg, ta, tb, 29, 19, 120, 2, 0.5f, 0.75f) <= 1.0);
        BOOST_TEST(run_and_check(cfg, ta, tb, 3, 5, 1, 1, 1.0f, 1.0f) <= 1.0);
      }
    }
  Runtime& rt = test::runtime();
  GemmArgs tn{true, false, 64, 48, 4096};
  BOOST_TEST(gemm_temp_bytes_with(rt, GemmConfig{"clblast", {{"KC", 1024}}}, tn) ==
             4 * 64 * 48 * sizeof(float));  // the partial sums of 4 chunks
  bool proposed = false;
  for (const auto& c : gemm_candidates(rt, GemmShapeClass{"tn", 256, 256, 65536}, true))
    proposed |= c.config.provider == "clblast" && c.config.params.count("KC");
  BOOST_TEST(proposed);
}

// A workspace holding NaN (memory a previous op left) does not leak into a split product.
BOOST_AUTO_TEST_CASE(clblast_split_k_ignores_stale_workspace) {
  Runtime& rt = test::runtime();
  const size_t m = 16, n = 24, k = 300;
  const auto a = test::random_floats(k * m, -1, 1, 41), b = test::random_floats(k * n, -1, 1, 42);
  const std::vector<float> c0(m * n, 0.0f);
  Buffer da = rt.upload_floats(a), db = rt.upload_floats(b), dc = rt.upload_floats(c0);
  GemmArgs g{true, false, m, n, k, 1.0f, da.get(), m, k * m, db.get(), n, k * n, 0.0f,
             dc.get(), n, m * n, 1};
  const GemmConfig cfg{"clblast", {{"KC", 64}}};
  const size_t bytes = gemm_temp_bytes_with(rt, cfg, g);
  Buffer temp = rt.upload_floats(std::vector<float>(bytes / sizeof(float), std::numeric_limits<float>::quiet_NaN()));
  gemm_with(rt, cfg, g, temp.get());
  BOOST_TEST(gemm_error_ratio(g, a, b, c0, rt.download_floats(dc.get(), m * n)) <= 1.0);
}

// The tuned mode runs the cache's winner for a shape class (and shapes within a factor of 4
// of its long dimension), and the table's CLBlast elsewhere; results match float64 either way.
BOOST_AUTO_TEST_CASE(tuned_dispatch_uses_the_cache) {
  Runtime& rt = test::runtime();
  const std::string path = temp_path("dispatch.tsv");
  GemmCacheEntry e = gemm_cache_key(rt.info());
  e.shape = GemmShapeClass{"nt", 2048, 24, 40};
  e.config = GemmConfig::parse("blocked RM=5 VN=1");
  write_gemm_cache(path, {e, entry("another device", "nt 2048x24x40", "kernels", 1, 2)});
  BOOST_TEST(reload_gemm_cache(rt, path) == 1u);
  const GemmProvider before = gemm_provider(rt);
  set_gemm_provider(rt, GemmProvider::Tuned);
  GemmArgs g{false, true, 3001, 24, 40};
  const auto cfg = tuned_gemm_config(rt, g);
  BOOST_TEST_REQUIRE(cfg.has_value());
  BOOST_TEST(cfg->str() == "blocked RM=5 VN=1");
  BOOST_TEST(!tuned_gemm_config(rt, GemmArgs{false, true, 3001, 24, 41}).has_value());
  BOOST_TEST(!tuned_gemm_config(rt, GemmArgs{false, false, 3001, 24, 40}).has_value());
  BOOST_TEST(!tuned_gemm_config(rt, GemmArgs{false, true, 64000, 24, 40}).has_value());  // 32x
  {  // through gemm(): the dispatch, the temp size and the result
    const size_t m = 3001, n = 24, k = 40;
    const auto a = test::random_floats(m * k, -1, 1, 31), b = test::random_floats(n * k, -1, 1, 32);
    const auto c0 = test::random_floats(m * n, -1, 1, 33);
    Buffer da = rt.upload_floats(a), db = rt.upload_floats(b), dc = rt.upload_floats(c0);
    GemmArgs h{false, true, m, n, k, 1.0f, da.get(), k, m * k, db.get(), k, n * k, 0.5f,
               dc.get(), n, m * n, 1};
    BOOST_TEST(gemm_temp_bytes(rt, h) == n * k * sizeof(float));  // the blocked kernel's B^T
    Buffer small = rt.alloc(4);  // a workspace too small is not used
    gemm(rt, h, small.get());
    BOOST_TEST(gemm_error_ratio(h, a, b, c0, rt.download_floats(dc.get(), m * n)) <= 1.0);
  }
  // A corrupt cache on reload: an error naming the file, the winners kept.
  write_text(path, "junk\n");
  BOOST_CHECK_THROW(reload_gemm_cache(rt, path), Error);
  BOOST_TEST(tuned_gemm_config(rt, g).has_value());
  BOOST_TEST(reload_gemm_cache(rt, temp_path("none.tsv")) == 0u);
  BOOST_TEST(!tuned_gemm_config(rt, g).has_value());
  set_gemm_provider(rt, before);
  try {
    reload_gemm_cache(rt);  // back to the user's cache for the rest of the process
  } catch (const Error&) {
  }
  fs::remove_all(fs::path(path).parent_path());
}

BOOST_AUTO_TEST_SUITE_END()
