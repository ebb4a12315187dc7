#pragma once
// CRC-32 (IEEE 802.3, the zlib/PNG/ZIP polynomial), in the core so that checkpoints can be
// checked without zlib or OpenCV.
#include <cstddef>
#include <cstdint>

namespace nova {

// crc32("123456789") == 0xcbf43926. Pass a previous result as `crc` to continue a sum over
// several pieces.
uint32_t crc32(const void* data, size_t size, uint32_t crc = 0);

}  // namespace nova
