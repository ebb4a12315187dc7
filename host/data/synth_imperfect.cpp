// Imperfect training inputs of the synthetic family (see synth.hpp): masks grown or shrunk
// and jagged as a segmentation network's, disparity right up to an affine map and blurred as
// a monocular depth network's, per-frame exposure gains. Identities when none apply, so the
// fixed presets' files do not change.
#include <algorithm>
#include <cmath>

#include "nova/data/synth.hpp"

namespace nova {
namespace {

// A reproducible coin per (seed, frame, object, pixel): an integer hash, no generator state.
uint32_t hash32(uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
  uint32_t h = a * 0x9E3779B1u ^ (b + 0x7F4A7C15u);
  for (uint32_t v : {c, d}) {
    h ^= v + 0x9E3779B9u + (h << 6) + (h >> 2);
    h *= 0x85EBCA6Bu;
    h ^= h >> 13;
  }
  h *= 0xC2B2AE35u;
  return h ^ (h >> 16);
}

// Dilation (grow > 0) or erosion (grow < 0) with a disc of radius |grow|.
Image8 grow_mask(const Image8& m, int grow) {
  const int r = std::abs(grow);
  const uint8_t want = grow > 0 ? 255 : 0;  // a pixel flips when the disc holds this value
  Image8 out = m;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      if (m.at(x, y) == want) continue;
      bool flip = false;
      for (int dy = -r; dy <= r && !flip; ++dy)
        for (int dx = -r; dx <= r && !flip; ++dx) {
          if (dx * dx + dy * dy > r * r) continue;
          const int xx = x + dx, yy = y + dy;
          // Outside the image counts as unchanged, so erosion does not eat the border.
          if (xx < 0 || yy < 0 || xx >= m.width || yy >= m.height) continue;
          flip = m.at(xx, yy) == want;
        }
      if (flip) out.at(x, y) = want;
    }
  return out;
}

// Border pixels (a 4-neighbour differs) flip with probability 1/2: a ragged silhouette.
Image8 jag_mask(const Image8& m, uint32_t seed, int frame, int object) {
  Image8 out = m;
  for (int y = 0; y < m.height; ++y)
    for (int x = 0; x < m.width; ++x) {
      bool border = false;
      const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
      for (const auto& d : nb) {
        const int xx = x + d[0], yy = y + d[1];
        if (xx >= 0 && yy >= 0 && xx < m.width && yy < m.height && m.at(xx, yy) != m.at(x, y))
          border = true;
      }
      if (border && (hash32(seed, uint32_t(frame), uint32_t(object), uint32_t(y * m.width + x)) & 1u))
        out.at(x, y) = m.at(x, y) ? 0 : 255;
    }
  return out;
}

std::vector<double> gaussian_kernel(double sigma) {
  const int r = std::max(1, int(std::ceil(3 * sigma)));
  std::vector<double> k(size_t(2 * r + 1));
  double sum = 0;
  for (int i = -r; i <= r; ++i) sum += k[size_t(i + r)] = std::exp(-0.5 * i * i / (sigma * sigma));
  for (double& v : k) v /= sum;
  return k;
}

}  // namespace

std::vector<Image8> synth_training_masks(const std::vector<Image8>& exact,
                                         const SynthImperfections& imp, int frame) {
  if (imp.mask_grow == 0 && !imp.mask_jagged) return exact;
  std::vector<Image8> out = exact;
  for (size_t k = 1; k < out.size(); ++k) {
    if (imp.mask_grow) out[k] = grow_mask(out[k], imp.mask_grow);
    if (imp.mask_jagged) out[k] = jag_mask(out[k], imp.noise_seed, frame, int(k));
  }
  // The background is what no object mask claims, among pixels that hit anything.
  Image8& bg = out[0];
  for (size_t p = 0; p < bg.data.size(); ++p) {
    bool hit = false, object = false;
    for (size_t k = 0; k < exact.size(); ++k) hit = hit || exact[k].data[p];
    for (size_t k = 1; k < out.size(); ++k) object = object || out[k].data[p];
    bg.data[p] = hit && !object ? 255 : 0;
  }
  return out;
}

ImageF synth_training_disparity(const ImageF& exact, const SynthImperfections& imp) {
  if (!imp.disparity) return exact;
  // Separable Gaussian with clamped borders, then the affine map.
  const std::vector<double> k = gaussian_kernel(imp.disp_sigma);
  const int r = int(k.size() / 2), w = exact.width, h = exact.height;
  std::vector<double> tmp(exact.data.size());
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      for (int i = -r; i <= r; ++i)
        s += k[size_t(i + r)] * exact.data[size_t(y) * w + std::clamp(x + i, 0, w - 1)];
      tmp[size_t(y) * w + x] = s;
    }
  ImageF out = exact;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      for (int i = -r; i <= r; ++i) s += k[size_t(i + r)] * tmp[size_t(std::clamp(y + i, 0, h - 1)) * w + x];
      out.data[size_t(y) * w + x] = static_cast<float>(imp.disp_scale * s + imp.disp_shift);
    }
  return out;
}

Image8 synth_training_image(const Image8& exact, const SynthImperfections& imp, int frame) {
  if (imp.gains.empty()) return exact;
  const double g = imp.gains[size_t(frame) % imp.gains.size()];
  Image8 out = exact;
  for (uint8_t& v : out.data) v = static_cast<uint8_t>(std::lround(std::min(255.0, v * g)));
  return out;
}

}  // namespace nova
