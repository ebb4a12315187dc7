#pragma once
// Frames as an MP4 video. Implemented in nova_io (OpenCV's videoio, where it was built).
#include <string>
#include <vector>

#include "nova/model/scene.hpp"

namespace nova {

// An MP4 of `frames` (all the same size, 3-channel RGB or 1-channel grey) at `fps`, through
// cv::VideoWriter's FFmpeg backend with the 'mp4v' codec, else 'avc1'. Written to
// "<stem>.tmp<ext>" beside `path` (FFmpeg picks the container from the extension) and renamed
// over `path` at the end, so a failed write leaves no partial video. Throws nova::Error when
// no codec opens (naming the codecs tried; callers write the PNG frames first, so the message
// says those are still there), the folder does not exist, `path` has no extension, the
// frames are empty or differ in size, or fps is not positive.
void write_video(const std::vector<Image8>& frames, const std::string& path, double fps);
// Whether this build writes videos (OpenCV's videoio was found); without it write_video throws.
bool video_supported();

}  // namespace nova
