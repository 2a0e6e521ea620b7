#pragma once
// Cells per population slab (population q of cell i at f[q*stride + i]).
#include "core/hd.hpp"

namespace lbdem::lbm {

// The storage cells rounded up to a whole number of 64-cell blocks, and that
// number made odd. A slab is then 64 b sizeof(T) bytes with b odd, so the Q
// slabs start at different offsets modulo 4 KiB (16 different ones in fp32,
// 8 in fp64) and the step's 2Q streams spread over the cache sets. With an even
// b, and on grids such as 64^3, 128^3 or 256^3 where the slab is a multiple of
// 4 KiB, every stream falls into the same sets of the host caches: they evict
// each other's lines, and loads wait on unrelated stores to addresses equal
// modulo 4 KiB. Alignment stays 64 cells (coalesced device access).
inline Index population_stride(Index cells) {
  Index blocks = (cells + 63) / 64;
  if (blocks % 2 == 0) ++blocks;
  return blocks * 64;
}

}  // namespace lbdem::lbm
