#pragma once
// Depth targets at an object's rim. A monocular disparity map is smooth across an object's
// silhouette (a depth network blurs edges; so do the family's imperfect maps), so inside a
// mask near its edge it reads part way to the background behind: on a box 25 pixels across
// under a 2.7-pixel blur, the pixels within 1.5 of the edge read half way. The free-space loss
// then counts the true surface there as weight in front of the surface, and the rims erode.
#include "nova/model/scene.hpp"

namespace nova {

// The frame's disparity with each object's rim raised to the nearest the object reads within
// `radius` pixels (a square window) among its own mask's pixels (>= 128): every pixel of
// object k's mask takes the largest disparity of mask k within the window, others keep
// theirs. Raising a target only ever moves the surface the free-space loss holds objects
// behind towards the camera, so a true surface is never penalised for it. A pixel two masks
// claim takes the larger value. Radius 0 or no disparity: the disparity as it is.
ImageF object_rim_disparity(const Frame& frame, int radius);

// The window's radius in pixels for a fraction of the image width (at least 1 when the
// fraction is positive, 0 when it is 0).
int object_rim_radius(double width_fraction, int image_width);

}  // namespace nova
