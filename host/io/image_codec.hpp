#pragma once
// The codec behind image_io.cpp: OpenCV's imgcodecs where the build has it, stb_image /
// stb_image_write where it does not (a machine with OpenCV's core and imgproc only: imgcodecs
// pulls in GDAL, FFmpeg and some 200 more libraries). Both give OpenCV's conventions: channels
// in BGR(A) order, 8 or 16 bits per channel, grey as one channel.
// NOVA_IMAGE_CODEC=opencv|stb chooses when both are built (default opencv).
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace nova::detail {

enum class ImageCodec { OpenCV, Stb };
bool image_codec_built(ImageCodec c);
// NOVA_IMAGE_CODEC, else OpenCV where built; Error for a codec this build lacks.
ImageCodec image_codec();
const char* image_codec_name(ImageCodec c);

// IMREAD_UNCHANGED's result (grey + alpha becomes BGRA); an empty Mat when the bytes are no
// image the codec reads.
cv::Mat decode_image(const std::vector<unsigned char>& bytes, ImageCodec c);
// PNG at compression level 6; false on failure.
bool encode_png(const cv::Mat& bgr_or_grey, std::vector<unsigned char>& out, ImageCodec c);

}  // namespace nova::detail
