#pragma once
// Training checkpoints: named float arrays (parameters, Adam moments) plus free key/value
// text (step, phase, config fingerprint, RNG state). Plain C++ in nova_core.
//
// File layout, all integers little-endian:
//   "NOVACKPT"            8 bytes, magic
//   u32 version           1
//   u64 payload_bytes     size of the payload below, so truncation and corruption are told
//                         apart before the payload is parsed
//   payload:
//     u32 meta_count, then per entry: u32 key_len, key, u32 value_len, value (sorted by key)
//     u32 array_count, then per array: u32 name_len, name, u32 rank, rank x u64 dims,
//                                      u64 float_count (= product of dims), float_count x f32
//   u32 crc32             CRC-32 (zlib polynomial) of the payload bytes
// Floats are stored as their bit patterns, so -0.0, denormals and NaN payloads survive.
#include <cstddef>
#include <map>
#include <string>
#include <vector>

namespace nova {

struct CheckpointArray {
  std::string name;
  std::vector<size_t> shape;  // rank 0 means a scalar (one value)
  std::vector<float> values;  // row-major, product of shape values
};

struct Checkpoint {
  std::map<std::string, std::string> meta;
  std::vector<CheckpointArray> arrays;  // names unique; order is kept

  // Throw nova::Error naming the missing array or key (and what the checkpoint has).
  const CheckpointArray& array(const std::string& name) const;
  const std::string& get(const std::string& key) const;
};

// Writes `path` + ".tmp", syncs and closes it, then renames it over `path`, so a crash or an
// error never leaves a half-written checkpoint under `path`; on failure the .tmp is removed
// and nova::Error names the path and the problem. Arrays whose value count does not match
// their shape, or repeated array names, are rejected before anything is written.
void write_checkpoint(const std::string& path, const Checkpoint& ckpt);

// Throws nova::Error (exit code 2) naming `path` and the problem: missing or unreadable file,
// "not a nova checkpoint" (magic), unsupported version, truncated, corrupt (CRC mismatch),
// or an inconsistent payload (shape vs value count, duplicate names, trailing bytes).
Checkpoint read_checkpoint(const std::string& path);

}  // namespace nova
