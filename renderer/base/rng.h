// Counter-based random numbers: every sample is a pure function of (seed, stream index, pass,
// dimension), so the CPU and GPU backends draw identical samples and images can be compared
// bit for bit between runs. The mixer is PCG's output hash applied in a chain (Jarzynski & Olano,
// "Hash Functions for GPU Rendering", JCGT 2020).
#pragma once

#include <cstdint>

#include "renderer/base/hd.h"
#include "renderer/base/vec.h"

namespace caustica {

CAUSTICA_HDI uint32_t pcg_hash(uint32_t v) {
  uint32_t state = v * 747796405u + 2891336453u;
  uint32_t word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}

// The key of sample stream `stream` of pass `pass` under `seed`, which every draw of it hashes.
CAUSTICA_HDI uint32_t stream_key(uint32_t seed, uint32_t stream, uint32_t pass) {
  return pcg_hash(seed ^ pcg_hash(stream ^ pcg_hash(pass + 0x9e3779b9u)));
}

// Uniform in [0, 1) from 32 random bits: the top 24 give every float in that range an equal chance.
CAUSTICA_HDI float unit_float(uint32_t bits) { return float(bits >> 8) * (1.0f / 16777216.0f); }

// Draws successive dimensions of one sample stream.
class Sampler {
 public:
  CAUSTICA_HD Sampler(uint32_t seed, uint32_t stream, uint32_t pass)
      : key_(stream_key(seed, stream, pass)) {}

  CAUSTICA_HDI uint32_t next_u32() { return pcg_hash(key_ ^ pcg_hash(dimension_++)); }
  CAUSTICA_HDI float next_float() { return unit_float(next_u32()); }
  // Moves past `n` dimensions without drawing them, as if they had been drawn.
  CAUSTICA_HDI void skip(uint32_t n) { dimension_ += n; }

 private:
  uint32_t key_;
  uint32_t dimension_ = 0;
};

}  // namespace caustica
