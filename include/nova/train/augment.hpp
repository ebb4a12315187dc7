#pragma once
// Novel-view augmentation (NOVA, section "novel view supervision"): an object's camera is
// rotated about its own x or y axis; since a pure rotation has no parallax, the object's
// image and mask in the rotated camera are exactly the original ones warped by the
// homography K R K^-1 (up to resampling). The target composite is the warped objects over
// the original image, with the warped objects' pixels removed from the background mask; a
// turned object's old place, where no warped object stands, has no target (unseen background),
// nor has a warped object where it meets another object (which one is in front is unknown:
// each renders from a camera of its own).
//
// Pixel coordinates follow camera.hpp: pixel (i, j) is the point (i, j), no half-pixel
// offset; bilinear sampling reads pixels floor(x), floor(x) + 1. Plain C++, no OpenCV.
#include <array>
#include <optional>
#include <random>
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

enum class RotationAxis { x, y };

struct CameraRotation {
  RotationAxis axis = RotationAxis::y;
  double degrees = 0;
};

// Uniform axis (x or y) and angle in [-max_degrees, max_degrees], from `rng` (our own
// uniform mapping, so the sequence is the same on every standard library).
CameraRotation random_rotation(std::mt19937& rng, double max_degrees = 20.0);

// The camera turned about its own axis: c2w rotation R_c2w * R_axis, same centre.
Camera rotate_camera(const Camera& camera, const CameraRotation& rotation);

// Row-major 3x3 H mapping a pixel of the rotated camera (homogeneous (i, j, 1)) to the pixel
// of the original camera that sees the same ray: H = K R K^-1 with K in camera.hpp's axes.
std::array<double, 9> rotation_homography(const Camera& camera, const CameraRotation& rotation);

// Backward warp: out(i, j) = bilinear src at H (i, j, 1). Pixels whose source falls outside
// [0, W-1] x [0, H-1] (or behind the camera) get `fill` and valid = 0; `valid` (optional)
// receives a 0/255 mask of the pixels that were sampled.
Image8 warp_image(const Image8& src, const std::array<double, 9>& h, uint8_t fill = 0,
                  Image8* valid = nullptr);

struct AugmentedFrame {
  Image8 rgb;                  // composite target
  std::vector<Image8> masks;   // 1 + K: background with warped objects removed, warped objects
  std::vector<Camera> cameras; // per NeRF: 0 unchanged, k rotated (or unchanged)
  std::vector<Image8> valid;   // per NeRF: where the warp had source pixels; 0: where the
                               // target is known (not a turned object's uncovered old place,
                               // nor a warped object over another object)
  std::vector<Image8> images;  // per NeRF: the frame as its camera sees it (0: the frame, k:
                               // the frame warped with object k's homography, or the frame)
};

// Rotates the camera of each object k with rotations[k - 1] (std::nullopt: unchanged).
// Object k's warped image is the frame warped with its homography, cut out by its warped
// mask (fractional at the edges: alpha-composited in object order over the frame).
AugmentedFrame augment_frame(const Frame& frame,
                             const std::vector<std::optional<CameraRotation>>& rotations);

}  // namespace nova
