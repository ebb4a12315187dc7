#include "nova/model/fields.hpp"

#include <algorithm>

#include "nova/runtime/error.hpp"
#include "nova/model/mlp.hpp"
#include "nova/ops/linalg/dense.hpp"
#include "nova/ops/tensor/tensor_ops.hpp"
#include "nova/ops/encoding/positional_encoding.hpp"

namespace nova {
namespace {

MlpConfig trunk_config(const FieldConfig& c, int outputs, int networks) {
  if (c.pos_freqs < 0 || c.dir_freqs < 0)
    throw Error("field: encoding frequencies must be >= 0", kExitUsage);
  MlpConfig m;
  m.depth = c.depth;
  m.width = c.width;
  m.skip = c.skip;
  m.outputs = outputs;
  m.output_activation = Activation::Identity;
  m.networks = networks;
  return m;
}

// The encoded input of a trunk: positional encoding, or the hash grid `table_name`.
Tensor encode(Tensor x, const FieldConfig& c, const HashGridConfig& hash, const std::string& table_name,
              int networks) {
  if (c.encoding == Encoding::Frequency) return positional_encoding(x, c.pos_freqs);
  return hash_encoding(x, hash_grid_table(*x.graph, table_name, hash, networks), hash);
}

// A rigid object's deformation (FieldConfig::deform_width): canonical positions moved by a
// small network of [PE(position), PE(time)], its offset bounded by deform_bound. The output
// layer starts at zero, so training starts from the rigid shape.
Tensor deform_positions(Tensor positions, Tensor times, const FieldConfig& c, int networks) {
  Graph& g = *positions.graph;
  Tensor in = concat({positional_encoding(positions, kDeformFrequencies), positional_encoding(times, kDeformFrequencies)});
  Tensor hidden = dense_layer(in, c.deform_width, Activation::ReLU, "objects.deform.hidden", networks);
  const bool batched = networks > 1;
  const size_t W = static_cast<size_t>(c.deform_width), B = static_cast<size_t>(networks);
  Tensor w = g.parameter("objects.deform.out.w", batched ? Shape{B, W, 3} : Shape{W, 3}, Init::zeros());
  Tensor b = g.parameter("objects.deform.out.b", batched ? Shape{B, 3} : Shape{3}, Init::zeros());
  return bounded_offset(positions, dense(hidden, w, b, Activation::Identity), c.deform_bound);
}

}  // namespace

HashGridConfig object_hash_config(const FieldConfig& c) {
  HashGridConfig h = c.hash;
  if (c.object_max_resolution > 0) h.max_resolution = c.object_max_resolution;
  if (c.motion == ObjectMotion::Rigid && c.canonical_max_resolution > 0) h.max_resolution = c.canonical_max_resolution;
  if (c.motion == ObjectMotion::Rigid && c.object_box) {
    h.bound = 1.0f;
    h.axis_bound = {};
  }
  return h;
}

const char* encoding_name(Encoding e) {
  return e == Encoding::HashGrid ? "hashgrid" : "frequency";
}

Tensor build_static_field(Tensor positions, Tensor viewdirs, const FieldConfig& c) {
  if (positions.shape().rank() != 2 || positions.shape()[1] != 3)
    throw Error("static field: positions must be [M, 3], got " + positions.shape().str(),
                kExitInternal);
  // The trunk's output layer is the reference's feature_linear; sigma and blend are linear
  // heads on the feature (the same function class as heads on the last hidden layer).
  Tensor feature = build_mlp(encode(positions, c, c.hash, "static.hash", 1), trunk_config(c, c.width, 1),
                             "static.trunk").output;
  Tensor sigma_blend = dense_layer(feature, 2, Activation::Identity, "static.sigma_blend");
  Tensor colour_in = c.view_dirs ? concat({feature, positional_encoding(viewdirs, c.dir_freqs)})
                                 : feature;
  Tensor hidden = dense_layer(colour_in, std::max(1, c.width / 2), Activation::ReLU, "static.view");
  Tensor rgb = dense_layer(hidden, 3, Activation::Identity, "static.rgb");
  return concat({rgb, sigma_blend});
}

Tensor build_object_fields(Tensor positions, Tensor times, const FieldConfig& c, Tensor level_window) {
  const Shape& ps = positions.shape();
  const bool batched = ps.rank() == 3;
  if (!(ps.rank() == 2 || batched) || ps.cols() != 3)
    throw Error("object fields: positions must be [B, M, 3] or [M, 3], got " + ps.str(),
                kExitInternal);
  Shape ts = ps;
  ts.dims.back() = 1;
  if (!(times.shape() == ts))
    throw Error("object fields: times must be " + ts.str() + ", got " + times.shape().str(),
                kExitInternal);
  const int networks = batched ? static_cast<int>(ps[0]) : 1;
  const bool rigid = c.motion == ObjectMotion::Rigid;
  if (rigid && c.deform_width > 0) positions = deform_positions(positions, times, c, networks);
  if (rigid && c.object_box) {
    const Shape bs = batched ? Shape{static_cast<size_t>(networks), 6} : Shape{6};
    positions = box_coordinates(positions, positions.graph->parameter(kObjectBoxName, bs, Init::zeros()));
  }
  Tensor xyzt = rigid ? positions : concat({positions, times});
  Tensor encoded = encode(xyzt, c, object_hash_config(c), "objects.hash", networks);
  if (level_window.valid()) {
    if (c.encoding != Encoding::HashGrid) throw Error("object fields: a level window needs a hash grid", kExitInternal);
    encoded = scale_columns(encoded, level_window);
  }
  if (!rigid || c.canonical_colour_time_freqs < 0)
    return build_mlp(encoded, trunk_config(c, 5, networks), "objects.trunk").output;
  Tensor feature = build_mlp(encoded, trunk_config(c, c.width, networks), "objects.trunk").output;
  Tensor sigma_blend = dense_layer(feature, 2, Activation::Identity, "objects.sigma_blend", networks);
  Tensor colour_in = concat({feature, positional_encoding(times, c.canonical_colour_time_freqs)});
  Tensor hidden = dense_layer(colour_in, std::max(1, c.width / 2), Activation::ReLU, "objects.colour", networks);
  Tensor rgb = dense_layer(hidden, 3, Activation::Identity, "objects.rgb", networks);
  return concat({rgb, sigma_blend});
}

}  // namespace nova
