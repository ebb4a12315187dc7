// Ray generation and stratified sampling ops (sampling.cl). Both are forward only: their
// inputs are data (pixels, cameras, jitter), so nothing upstream needs a gradient.
#include "nova/sampling/rays.hpp"

#include "nova/graph/executor.hpp"
#include "ops/tensor/op_util.hpp"

namespace nova {
namespace {

[[noreturn]] void bad(const std::string& op, const std::string& what) {
  throw Error(op + ": " + what, kExitInternal);
}

class GenerateRaysOp final : public Op {
 public:
  GenerateRaysOp(size_t rays, size_t nerfs, RayOptions o) : rays_(rays), nerfs_(nerfs), o_(o) {}
  std::string type() const override { return "generate_rays"; }

  void forward(ExecContext& ctx) override {
    ctx.launch("sampling", "rays_generate")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.out(0)).arg(ctx.out(1)).arg(ctx.out(2))
        .arg(detail::u32(rays_, "rays")).arg(detail::u32(nerfs_, "nerfs"))
        .arg(static_cast<int>(o_.ndc)).arg(o_.ndc_near)
        .run2(rays_, nerfs_);
  }
  // Rays are data: no input requires a gradient (checked when the op is built).
  void backward(ExecContext&) override {}
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  size_t rays_, nerfs_;
  RayOptions o_;
};

class StratifiedSamplesOp final : public Op {
 public:
  StratifiedSamplesOp(size_t rays, size_t nerfs, std::vector<int> groups, SampleOptions o,
                      bool jitter, size_t warp_knots)
      : rays_(rays), nerfs_(nerfs), groups_(std::move(groups)), o_(std::move(o)), jitter_(jitter),
        warp_knots_(warp_knots) {}
  std::string type() const override { return "stratified_samples"; }

  // Inputs: origins, directions, viewdirs[, jitter][, warp]. Outputs: z, delta, then per
  // group positions and viewdirs.
  void forward(ExecContext& ctx) override {
    const unsigned R = detail::u32(rays_, "rays"), S = static_cast<unsigned>(o_.samples);
    const size_t rs = rays_ * o_.samples;
    cl_mem jitter = jitter_ ? ctx.in(3) : ctx.in(0);
    // Without a warp the kernels read no knot; any buffer stands in for the argument.
    cl_mem warp = warp_knots_ ? ctx.in(jitter_ ? 4 : 3) : ctx.in(0);
    const unsigned W = static_cast<unsigned>(warp_knots_);
    ctx.launch("sampling", "sample_spacing")
        .arg(ctx.in(1)).arg(jitter).arg(ctx.out(0)).arg(ctx.out(1)).arg(R).arg(S)
        .arg(detail::u32(nerfs_, "nerfs")).arg(o_.near).arg(o_.far).arg(static_cast<int>(jitter_))
        .arg(warp).arg(W)
        .run2(rs, nerfs_);
    unsigned first = 0;
    for (size_t g = 0; g < groups_.size(); ++g) {
      const unsigned count = static_cast<unsigned>(groups_[g]);
      ctx.launch("sampling", "sample_points")
          .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.in(2)).arg(jitter)
          .arg(ctx.out(2 + 2 * g)).arg(ctx.out(3 + 2 * g)).arg(R).arg(S).arg(first).arg(count)
          .arg(o_.near).arg(o_.far).arg(static_cast<int>(jitter_)).arg(warp).arg(W)
          .run2(rs, count);
      first += count;
    }
  }
  void backward(ExecContext&) override {}
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  size_t rays_, nerfs_;
  std::vector<int> groups_;
  SampleOptions o_;
  bool jitter_;
  size_t warp_knots_;
};

class InstancePointsOp final : public Op {
 public:
  InstancePointsOp(size_t m, size_t b, InstanceOptions o) : m_(m), b_(b), o_(o) {}
  std::string type() const override { return "instance_points"; }
  void forward(ExecContext& ctx) override {
    ctx.launch("sampling", "instance_points")
        .arg(ctx.in(0)).arg(ctx.in(1)).arg(ctx.out(0))
        .arg(detail::u32(m_, "positions")).arg(detail::u32(b_, "instances"))
        .arg(static_cast<int>(o_.ndc)).arg(o_.ax).arg(o_.ay).arg(o_.ndc_near)
        .run2(m_, b_);
  }
  void backward(ExecContext&) override {}
  std::vector<TensorId> saved_for_backward() const override { return {}; }

 private:
  size_t m_, b_;
  InstanceOptions o_;
};

}  // namespace

std::vector<float> camera_rows(const std::vector<Camera>& cameras) {
  std::vector<float> v;
  for (const Camera& c : cameras) {
    for (double x : {c.fx, c.fy, c.cx, c.cy}) v.push_back(static_cast<float>(x));
    for (double x : c.c2w) v.push_back(static_cast<float>(x));
  }
  return v;
}

Rays generate_rays(Tensor pixels, Tensor cameras, const RayOptions& options) {
  const std::string op = "generate_rays";
  if (pixels.shape().rank() != 2 || pixels.shape()[1] != 2)
    bad(op, "pixels must be [R, 2], got " + pixels.shape().str());
  if (cameras.shape().rank() != 2 || cameras.shape()[1] != static_cast<size_t>(kCameraFloats))
    bad(op, "cameras must be [N, 16] (camera_rows), got " + cameras.shape().str());
  for (const Tensor& t : {pixels, cameras})
    if (t.info().requires_grad) bad(op, "'" + t.info().name + "' cannot take a gradient");
  const size_t R = pixels.shape()[0], N = cameras.shape()[0];
  Graph& g = *pixels.graph;
  Rays r;
  r.origins = g.activation("rays.origins", Shape{N, R, 3});
  r.directions = g.activation("rays.directions", Shape{N, R, 3});
  r.viewdirs = g.activation("rays.viewdirs", Shape{N, R, 3});
  g.add(std::make_unique<GenerateRaysOp>(R, N, options), {pixels, cameras},
        {r.origins, r.directions, r.viewdirs});
  return r;
}

Samples stratified_samples(const Rays& rays, Tensor jitter, const SampleOptions& options, Tensor warp) {
  const std::string op = "stratified_samples";
  const Shape& rs = rays.origins.shape();
  if (rs.rank() != 3 || rs[2] != 3 || !(rays.directions.shape() == rs) ||
      !(rays.viewdirs.shape() == rs))
    bad(op, "rays must be three [N, R, 3] tensors");
  const size_t N = rs[0], R = rs[1];
  if (options.samples < 1) bad(op, "needs at least one sample per ray");
  const size_t S = static_cast<size_t>(options.samples);
  std::vector<int> groups = options.groups.empty() ? std::vector<int>{static_cast<int>(N)} : options.groups;
  size_t total = 0;
  for (int c : groups) {
    if (c < 1) bad(op, "a NeRF group must hold at least one NeRF");
    total += static_cast<size_t>(c);
  }
  if (total != N) bad(op, "groups hold " + std::to_string(total) + " NeRFs, the rays " + std::to_string(N));
  if (jitter.valid() && !(jitter.shape() == Shape{R, S}))
    bad(op, "jitter must be [R, S] = " + Shape{R, S}.str() + ", got " + jitter.shape().str());
  if (jitter.valid() && jitter.info().requires_grad) bad(op, "jitter cannot take a gradient");
  if (warp.valid() && (warp.shape().rank() != 2 || warp.shape()[1] != 2 || warp.shape()[0] < 2))
    bad(op, "warp must be [W, 2] knots with W >= 2, got " + warp.shape().str());
  if (warp.valid() && warp.info().requires_grad) bad(op, "warp cannot take a gradient");

  Graph& g = *rays.origins.graph;
  Samples s;
  s.z = g.activation("samples.z", Shape{R, S});
  s.delta = g.activation("samples.delta", Shape{N, R, S});
  std::vector<Tensor> outputs = {s.z, s.delta};
  for (size_t k = 0; k < groups.size(); ++k) {
    const Shape shape = groups[k] == 1 ? Shape{R * S, 3} : Shape{static_cast<size_t>(groups[k]), R * S, 3};
    s.positions.push_back(g.activation("samples.positions", shape));
    s.viewdirs.push_back(g.activation("samples.viewdirs", shape));
    outputs.push_back(s.positions.back());
    outputs.push_back(s.viewdirs.back());
  }
  std::vector<Tensor> inputs = {rays.origins, rays.directions, rays.viewdirs};
  if (jitter.valid()) inputs.push_back(jitter);
  if (warp.valid()) inputs.push_back(warp);
  g.add(std::make_unique<StratifiedSamplesOp>(R, N, groups, options, jitter.valid(),
                                              warp.valid() ? warp.shape()[0] : 0),
        inputs, outputs);
  return s;
}

Tensor instance_points(Tensor positions, Tensor transforms, const InstanceOptions& options) {
  const std::string op = "instance_points";
  if (positions.shape().rank() != 2 || positions.shape()[1] != 3)
    bad(op, "positions must be [M, 3], got " + positions.shape().str());
  if (transforms.shape().rank() != 2 || transforms.shape()[1] != 12)
    bad(op, "transforms must be [B, 12], got " + transforms.shape().str());
  for (const Tensor& t : {positions, transforms})
    if (t.info().requires_grad) bad(op, "'" + t.info().name + "' cannot take a gradient");
  if (options.ndc && (options.ax == 0.0f || options.ay == 0.0f || options.ndc_near <= 0.0f))
    bad(op, "NDC constants must be non-zero and the near plane positive");
  const size_t M = positions.shape()[0], B = transforms.shape()[0];
  Graph& g = *positions.graph;
  Tensor out = g.activation("instance.positions", B == 1 ? Shape{M, 3} : Shape{B, M, 3});
  g.add(std::make_unique<InstancePointsOp>(M, B, options), {positions, transforms}, {out});
  return out;
}

}  // namespace nova
