#pragma once
// How sharply a scene's disparity steps at its objects' silhouettes. A depth network's
// disparity is blurred over them: inside a mask near its edge it reads part way to the
// background, which flattens the objects the frames' alignment follows
// (AlignmentOptions::depth_reach_px undoes that); an exact disparity steps at the silhouette,
// where the nearest depth close by would move the object's rim forward instead.
#include <optional>

#include "nova/model/scene.hpp"

namespace nova {

// For each frame and object whose mask has interior pixels (2 or more pixels from its edge)
// and background about it, the share of the disparity's step that falls at the silhouette:
//   (median of the mask's rim pixels - median of the background pixels touching the mask)
//   / (median of the interior - median of the background 3 to 4 pixels out),
// at the disparity's size, counted where the interior stands in front (a larger disparity).
// The median over frames and objects: about 1 for an exact disparity, less the wider it is
// blurred. No value when no frame and object give one (no disparity, objects too thin).
std::optional<double> silhouette_step_share(const Scene& scene);

// Below this share the start's alignment reads each mask pixel's nearest depth within a pixel
// (TrainConfig::align_depth_auto). On the family's scenes, the default synthetic scene and
// nvidia_balloon1 the shares fall at 0.04-0.47 (blurred maps) and 0.87-0.98 (exact ones).
inline constexpr double kBlurredStepShare = 0.7;

}  // namespace nova
