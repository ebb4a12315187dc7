// The kernel tuning database: every family's defines as the ops have always built them (a
// changed define is a different program, and on PoCL a changed GEMM tile a different sum), the
// device table as CLBlast receives it, and a cache entry taking over from the default.
#include <clblast.h>

#include <boost/test/unit_test.hpp>
#include <cstdlib>
#include <filesystem>
#include <unistd.h>

#include "harness.hpp"
#include "nova/ops/linalg/gemm.hpp"
#include "nova/render/render_composite.hpp"
#include "nova/tuning/tuning.hpp"

using namespace nova;
namespace fs = std::filesystem;

BOOST_AUTO_TEST_SUITE(tuning)

BOOST_AUTO_TEST_CASE(families_yield_their_defines) {
  BOOST_TEST(BlockedGemmParams{}.to_defines() == "-DGEMM_RM=6 -DGEMM_VN=2");
  const BlockedGemmParams b = blocked_gemm_params(GemmConfig::parse("blocked KC=256 RM=4 TA=1 VN=3"));
  BOOST_TEST(b.to_defines() == "-DGEMM_RM=4 -DGEMM_VN=3");
  BOOST_TEST(b.kc == 256u);
  BOOST_TEST(b.ta == 1u);
  BOOST_CHECK_THROW(blocked_gemm_params(GemmConfig{"blocked", {{"XX", 1}}}), Error);

  BOOST_TEST(RenderParams{}.to_defines() == "-DNERFS=1 -DRGB_SIGMOID=1 -DBLEND_SIGMOID=1 -DHARD_BLEND=0");
  BOOST_TEST(render_program_options(1) == RenderParams{}.to_defines());
  RenderOptions ref;  // the reference code's conventions
  ref.blend_eps = 1e-8f;
  ref.alpha_full_sum = true;
  ref.hard_blend = true;
  BOOST_TEST(render_program_options(3, ref) ==
             "-DNERFS=3 -DRGB_SIGMOID=1 -DBLEND_SIGMOID=1 -DHARD_BLEND=1 -DBLEND_EPS=1e-08f "
             "-DALPHA_FULL_SUM=1");
  RenderOptions pre;
  pre.no_blend = true;
  pre.nerf_depth = true;
  pre.rgb_sigmoid = false;
  BOOST_TEST(render_program_options(1, pre) ==
             "-DNERFS=1 -DRGB_SIGMOID=0 -DBLEND_SIGMOID=1 -DHARD_BLEND=0 -DNO_BLEND=1 -DNERF_DEPTH=1");

  BOOST_TEST(HashGridParams{}.to_defines() == "-DHG_DIMS=3 -DHG_FEATURES=2");
  const HashGridParams video{4, 8, true};
  BOOST_TEST(video.to_defines() == "-DHG_DIMS=4 -DHG_FEATURES=8 -DHG_EXTEND=1");

  BOOST_TEST(ActivationParams{static_cast<int>(Activation::ReLU)}.to_defines() == "-DACT=1");
  BOOST_TEST(ActivationParams{static_cast<int>(Activation::Softplus)}.gemm_epilogue_defines() ==
             " -DGEMM_BIAS_ACT=3");

  BOOST_TEST(pack_params().to_defines() == "-DPACK_BLOCK=128");
}

// The default device's entry: PoCL's CPU device gets the measured Xgemm set and the indirect
// GEMM path, any other device CLBlast's own database; a CPU sums the hash grid's gradient in
// order, a GPU with 64-bit atomics with them. Either way CLBlast holds what the entry
// says once configure_gemm ran.
BOOST_AUTO_TEST_CASE(default_device_entry_reaches_clblast) {
  Runtime& rt = test::runtime();
  const DeviceTuning& t = device_tuning(rt.info());
  if (!std::getenv("NOVA_HASH_BACKWARD")) {
    const bool gpu_atomics = rt.info().int64_atomics && !rt.is_cpu();
    BOOST_TEST((hash_backward_choice(rt.info()) ==
                (gpu_atomics ? HashBackward::Atomic : HashBackward::Ordered)));
  }
  BOOST_TEST(t.blocked_gemm_group.items == 64u);
  BOOST_TEST(t.blocked_gemm_group.items0 == 16u);
  const bool pocl_cpu = t.name == "pocl-cpu";
  BOOST_TEST_MESSAGE("device tuning entry: " << t.name);
  if (!pocl_cpu) {
    BOOST_TEST(t.name == "clblast-defaults");
    BOOST_TEST(!t.xgemm.has_value());
    BOOST_TEST(!t.xgemm_min_indirect_size.has_value());
    return;
  }
  BOOST_TEST_REQUIRE(t.xgemm.has_value());
  BOOST_TEST(t.xgemm->to_defines() ==
             "-DGEMMK=0 -DKREG=1 -DSTRM=0 -DSTRN=0 -DSA=1 -DSB=1 -DMWG=64 -DNWG=64 -DKWG=16 "
             "-DMDIMC=8 -DNDIMC=8 -DMDIMA=8 -DNDIMB=8 -DKWI=2 -DVWM=8 -DVWN=8");
  BOOST_TEST((t.xgemm_min_indirect_size == std::optional<size_t>(0)));
  configure_gemm(rt);
  std::unordered_map<std::string, size_t> held;
  BOOST_TEST_REQUIRE((clblast::RetrieveParameters(rt.device(), "Xgemm", clblast::Precision::kSingle,
                                                  held) == clblast::StatusCode::kSuccess));
  for (const auto& [name, value] : t.xgemm->params()) BOOST_TEST(held[name] == value, name);
  std::unordered_map<std::string, size_t> routine;
  BOOST_TEST_REQUIRE((clblast::RetrieveParameters(rt.device(), "GemmRoutine",
                                                  clblast::Precision::kSingle, routine) ==
                      clblast::StatusCode::kSuccess));
  BOOST_TEST(routine["XGEMM_MIN_INDIRECT_SIZE"] == 0u);
}

// A cache entry for this device and shape class replaces the default configuration, and with
// it the blocked kernel's defines; other devices' entries and other shapes keep the default.
BOOST_AUTO_TEST_CASE(cache_entry_overrides_the_default) {
  Runtime& rt = test::runtime();
  const fs::path dir = fs::temp_directory_path() / ("nova-tuning-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / "cache.tsv").string();
  const GemmProvider before = gemm_provider(rt);
  set_gemm_provider(rt, GemmProvider::Tuned);
  const GemmArgs g{false, false, 4096, 24, 40};
  BOOST_TEST(reload_gemm_cache(rt, (dir / "none.tsv").string()) == 0u);
  const GemmConfig plain = gemm_choice(rt, g);
  BOOST_TEST(plain.provider != "blocked", plain.str());

  GemmCacheEntry e = gemm_cache_key(rt.info());
  e.shape = *gemm_shape_class(g);
  e.config = GemmConfig::parse("blocked RM=5 VN=1");
  GemmCacheEntry other = e;
  other.device = "another device";
  other.shape.n = 32;
  write_gemm_cache(path, {e, other});
  BOOST_TEST(reload_gemm_cache(rt, path) == 1u);
  const GemmConfig tuned = gemm_choice(rt, g);
  BOOST_TEST(tuned.str() == "blocked RM=5 VN=1");
  BOOST_TEST(blocked_gemm_params(tuned).to_defines() == "-DGEMM_RM=5 -DGEMM_VN=1");
  BOOST_TEST(gemm_choice(rt, GemmArgs{false, false, 4096, 32, 40}).str() == plain.str());

  set_gemm_provider(rt, before);
  try {
    reload_gemm_cache(rt);  // back to the user's cache for the rest of the process
  } catch (const Error&) {
  }
  fs::remove_all(dir);
}

BOOST_AUTO_TEST_SUITE_END()
