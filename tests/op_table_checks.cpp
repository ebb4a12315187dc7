// The op table's checks of their own (op_harness.hpp): entries whose float64 reference runs a
// whole problem, checked with Boost.Test here so that the table itself needs no Boost. The
// shapes, builders and tolerances' reasons are with each entry (op_table_render.cpp,
// op_table_ray_losses.cpp, op_table_ranks.cpp).
#include "op_harness.hpp"
#include "rays_reference.hpp"
#include "render_check.hpp"

namespace nova::test {

namespace {

void check_render(const OpShape& s) {
  const auto [in, targets_seed] = render_table_case(s);
  if (s.variant == 9) {  // the device forward's own central differences, one output at a time
    for (int output = 0; output < 5; ++output) {
      const BuildFn build = [&](Graph& g) {
        const RenderGraph r = render_table_graph(g, in);
        const Tensor outs[] = {r.out.rgb, r.out.nerf_rgb, r.out.mask, r.out.depth, r.out.acc};
        return OpUnderTest{{r.raw, r.delta, r.z}, outs[output]};
      };
      const double worst = check_gradients(build, {to_float(in.raw), to_float(in.delta), to_float(in.z)});
      BOOST_TEST_MESSAGE("render output " << output << ": worst FD error " << worst);
    }
    return;
  }
  const RenderTargets t = random_targets(in, targets_seed);
  const DeviceRender d = run_device_render(in, t);
  expect_forward_close(d, in, 2e-6, 1e-5, "render " + s.label);
  expect_gradient_close(d, in, t, 1e-4, 1e-3, "render " + s.label);
  // Channels past the fifth take a zero gradient.
  for (size_t e = 0; e < d.grad_raw.size(); e += in.channels)
    for (int k = 5; k < in.channels; ++k) BOOST_TEST(d.grad_raw[e + k] == 0.0f);
}

void check_points(const OpShape& s) { check_instance_points(runtime(), s.dims[0], instance_points_seed(s)); }

void check_free_space(const OpShape& s) {
  const FreeSpaceCase f = free_space_case(s);
  const FreeSpaceRun run = run_free_space(f, runtime());
  const double ref = free_space_reference(f, f.raw);
  BOOST_TEST(ref > 1e-3, s.label << ": no weight in front of the targets");
  expect_close({run.loss}, {ref}, 0, 1e-4, "free_space_loss " + s.label);
  const std::vector<double> fd = free_space_sigma_fd(f, s.variant == 0 ? 1e-3f : 1e-4f);
  expect_close(run.d_raw, fd, 1e-5 * max_abs(fd), 1e-3, "d free_space_loss / d raw, " + s.label);
}

void check_free_space_over_ranks(const OpShape& s) {
  const FreeSpaceCase f = free_space_case(s);
  const FreeSpaceRun run = run_free_space(f, runtime(), true, &twin_ranks());
  expect_close({run.loss}, {free_space_reference(f, f.raw)}, 0, 1e-4, "free_space_loss over ranks");
  const std::vector<double> fd = free_space_sigma_fd(f, 1e-3f);
  expect_close(run.d_raw, fd, 1e-5 * max_abs(fd), 1e-3, "d free_space_loss over ranks / d raw");
  std::vector<double> d_depth(f.R);
  for (size_t r = 0; r < f.R; ++r) d_depth[r] = 2.0 * f.depth[r] / double(f.R);
  expect_close(run.d_depth, d_depth, 0, 1e-6, "d free_space_loss over ranks / d depth (the mse's alone)");
}

}  // namespace

const std::map<std::string, OwnCheck>& own_checks() {
  static const std::map<std::string, OwnCheck> checks = {
      {"render_composite", check_render},
      {"instance_points", check_points},
      {"free_space_loss", check_free_space},
      {"free_space_loss_over_ranks", check_free_space_over_ranks},
  };
  return checks;
}

}  // namespace nova::test
