#pragma once
// Multiresolution hash encoding (Instant-NGP): L levels of grids from min_resolution to
// max_resolution (geometric), each with a table of 2^log2_size entries of `features` floats;
// a point's encoding is the concatenation over levels of its D-linearly interpolated
// features (L * features values). Coarse levels whose vertices fit the table are dense,
// finer ones hashed. Converges in far fewer steps than the positional encoding at a fraction
// of the MLP work, which is what makes training on two CPU cores useful.
#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "nova/graph/graph.hpp"
#include "nova/tuning/tuning.hpp"

namespace nova {

struct HashGridConfig {
  int levels = 16;
  int features = 2;          // per level
  int log2_size = 16;        // table entries per level: 2^log2_size
  int min_resolution = 16;   // coarsest grid: cells per dimension
  int max_resolution = 512;  // finest grid
  float bound = 1.0f;        // encodes [-bound, bound]^D; points outside are clamped to it
  // Half-sizes of x, y and z where > 0, in place of `bound`: an NDC scene whose camera moves
  // sideways needs a box wider in x than in z, and a cube would coarsen z with it.
  std::array<float, 3> axis_bound{};
  // Hashed levels encode a point outside the box in cells of their own beyond it instead of
  // clamping it to the box's face (which streaks whatever lies there); dense levels, whose
  // table holds exactly the box's vertices, still clamp. Points inside encode as without.
  bool extend = false;
  // With D = 4 the 4th coordinate is time, on [-1, 1] whatever `bound`, with at most this
  // many cells per level (0: as space). A monocular video sees each time from one camera:
  // time cells shared by neighbouring frames tie the object NeRFs to several viewpoints.
  int time_max_resolution = 0;

  int outputs() const { return levels * features; }
  float half_size(int axis) const { return axis_bound[static_cast<size_t>(axis)] > 0.0f ? axis_bound[static_cast<size_t>(axis)] : bound; }
  // The smallest cube that holds the box (what an occupancy grid of the field covers).
  float max_half_size() const { return std::max({half_size(0), half_size(1), half_size(2)}); }
};

// Checks the configuration (throws nova::Error naming the field and the limit).
void validate(const HashGridConfig& c);

// Cells per dimension of each level: floor(min * g^l), g = (max / min)^(1 / (L - 1)).
std::vector<float> hash_grid_resolutions(const HashGridConfig& c);

// Cells along time of each level: min(res_l, time_max_resolution), or res_l when it is 0.
std::vector<float> hash_grid_time_resolutions(const HashGridConfig& c);

// Shape of the tables of `networks` encodings: [L, T, F], or [networks, L, T, F] when > 1.
Shape hash_grid_table_shape(const HashGridConfig& c, size_t networks = 1);

// The table parameter `name` of `networks` encodings: [L, T, F] or [networks, L, T, F],
// initialised uniform in +-1e-4 as Instant-NGP does.
Tensor hash_grid_table(Graph& g, const std::string& name, const HashGridConfig& c,
                       int networks = 1);

// positions [M, D] with table [L, T, F], or [B, M, D] with table [B, L, T, F]; D <= 4.
// Output [M, L * F] or [B, M, L * F]. Differentiable in the table, and in the positions when
// they take a gradient (samples moved by a learned object motion, motion.hpp).
Tensor hash_encoding(Tensor positions, Tensor table, const HashGridConfig& c);

// How the table gradient is summed per device (HashBackward, hash_backward_choice): the
// tuning database's, tuning.hpp.

}  // namespace nova
