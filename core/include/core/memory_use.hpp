#pragma once
// Memory of a run, by component. The same list is produced two ways: by the
// estimate functions of each module (lbm_memory(), psm_memory(), ...), from
// the set-up alone before anything is allocated, and by the live objects
// (LbmSolver::memory_use(), PsmCoupling::memory_use(), ...) from the byte
// counts of the Buffers they hold. A test allocates a scene and compares the
// two component by component, to the byte.
#include <algorithm>
#include <cstddef>
#include <string>
#include <vector>

#include "core/exec.hpp"
#include "core/grid.hpp"

namespace lbdem {

// Cells of one output slab: fields leave the device through staging buffers
// of this many cells (rho + u: 4 doubles a cell, 4 MiB), reserved when the
// solver is made, so that writing output never allocates device memory.
inline constexpr Index kOutputSlabCells = Index{1} << 17;

struct MemoryItem {
  std::string name;       // "populations", "flags", "output staging", ...
  std::size_t bytes = 0;  // on the run's backend
};

struct MemoryUse {
  std::vector<MemoryItem> items;
  void add(const std::string& name, std::size_t bytes) {
    for (auto& it : items)
      if (it.name == name) {
        it.bytes += bytes;
        return;
      }
    items.push_back({name, bytes});
  }
  void add(const MemoryUse& o) {
    for (const auto& it : o.items) add(it.name, it.bytes);
  }
  std::size_t total() const {
    std::size_t s = 0;
    for (const auto& it : items) s += it.bytes;
    return s;
  }
  // Bytes of a component (0 when absent).
  std::size_t of(const std::string& name) const {
    for (const auto& it : items)
      if (it.name == name) return it.bytes;
    return 0;
  }
};

// `box` cut into boxes of at most max_cells cells, in storage order (z, then
// y, then x): whole z layers where a layer fits, else rows of one layer, else
// pieces of one row. Each is a box, so it is one hyperslab of a dataset and
// one launch; together they hold every cell of `box` once.
inline std::vector<CellBox> slabs_of(const CellBox& box, Index max_cells) {
  std::vector<CellBox> out;
  if (box.empty()) return out;
  if (max_cells < 1) max_cells = 1;
  const Index row = box.ext[0], layer = row * box.ext[1];
  if (layer <= max_cells) {
    const int k = static_cast<int>(std::min<Index>(max_cells / layer, box.ext[2]));
    for (int z = 0; z < box.ext[2]; z += k) {
      CellBox b = box;
      b.lo[2] = box.lo[2] + z;
      b.ext[2] = std::min(k, box.ext[2] - z);
      out.push_back(b);
    }
  } else if (row <= max_cells) {
    const int k = static_cast<int>(max_cells / row);
    for (int z = 0; z < box.ext[2]; ++z)
      for (int y = 0; y < box.ext[1]; y += k) {
        CellBox b = box;
        b.lo[2] = box.lo[2] + z;
        b.ext[2] = 1;
        b.lo[1] = box.lo[1] + y;
        b.ext[1] = std::min(k, box.ext[1] - y);
        out.push_back(b);
      }
  } else {
    const int k = static_cast<int>(max_cells);
    for (int z = 0; z < box.ext[2]; ++z)
      for (int y = 0; y < box.ext[1]; ++y)
        for (int x = 0; x < box.ext[0]; x += k) {
          CellBox b;
          b.lo[0] = box.lo[0] + x;
          b.lo[1] = box.lo[1] + y;
          b.lo[2] = box.lo[2] + z;
          b.ext[0] = std::min(k, box.ext[0] - x);
          b.ext[1] = b.ext[2] = 1;
          out.push_back(b);
        }
  }
  return out;
}

}  // namespace lbdem
