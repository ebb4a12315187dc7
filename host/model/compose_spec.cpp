// Composition spec placement (see include/nova/model/compose_spec.hpp): an instance's rotation and
// its map p -> p'. The text format is nova_io's (host/io/compose_spec_text.cpp).
#include "nova/model/compose_spec.hpp"

#include <cmath>

#include "nova/runtime/error.hpp"
#include "nova/sampling/rigid_motion.hpp"

namespace nova {

std::array<double, 9> euler_xyz_deg_to_matrix(const std::array<double, 3>& deg) {
  const double k = std::acos(-1.0) / 180.0;
  return euler_xyz_to_matrix({deg[0] * k, deg[1] * k, deg[2] * k});
}

std::array<double, 12> instance_transform(const ComposeInstance& inst) {
  if (!inst.pivot)
    throw Error("instance of object " + std::to_string(inst.object) +
                    " has no pivot: the renderer decides it (ViewRenderer::pivot_for)",
                kExitInternal);
  return instance_transform(inst, *inst.pivot);
}

std::array<double, 12> instance_transform(const ComposeInstance& inst, const std::array<double, 3>& pivot) {
  const auto r = euler_xyz_deg_to_matrix(inst.rotate_deg);
  std::array<double, 12> m{};
  for (int i = 0; i < 3; ++i) {
    double rp = 0;
    for (int j = 0; j < 3; ++j) {
      m[i * 4 + j] = r[i * 3 + j];
      rp += r[i * 3 + j] * pivot[j];
    }
    m[i * 4 + 3] = pivot[i] + inst.translate[i] - rp;
  }
  return m;
}

}  // namespace nova
