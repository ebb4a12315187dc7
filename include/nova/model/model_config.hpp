#pragma once
// What rendering a trained model needs besides its checkpoint's weights: the fields' shapes
// and encodings, the samples per ray, and how its occupancy grids tell empty cells. A run's
// TrainConfig is one (train_config.hpp), so its config.ini describes the model it trained;
// the renderer and the checkpoint's fingerprint read only this part of it.
#include <string>

#include "nova/model/fields.hpp"

namespace nova {

struct ModelConfig {
  FieldConfig field;
  int samples = 64;  // stratified samples per ray
  // Of those, how many crowd about where the rigid objects stand (object_samples.hpp): the rest
  // stay evenly spread. 0: all evenly spread.
  int object_samples = 0;
  // Empty-space skipping (occupancy.hpp): whether the model has occupancy grids, and the
  // opacity over one grid cell above which a cell counts as occupied.
  bool occupancy = true;
  float occupancy_alpha = 0.01f;
};

// The parameters that fix the networks' shapes: a checkpoint written under one
// fingerprint cannot be loaded under another.
std::string network_fingerprint(const ModelConfig& c);

}  // namespace nova
