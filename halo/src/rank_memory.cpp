// Memory use over the ranks of a run (halo/rank_memory.hpp).
#include "halo/rank_memory.hpp"

#include <algorithm>
#include <cstddef>
#include <span>

namespace lbdem::halo {

std::vector<std::string> memory_component_names(const MemoryUse& m, const Comm& comm) {
  std::string mine;
  for (const auto& it : m.items) mine += it.name + "\n";
  const auto all = comm.allgather(std::as_bytes(std::span<const char>(mine.data(), mine.size())));
  std::vector<std::string> names;
  for (const auto& b : all) {
    std::string text(reinterpret_cast<const char*>(b.data()), b.size());
    std::size_t at = 0;
    while (at < text.size()) {
      const std::size_t e = text.find('\n', at);
      const std::string nm = text.substr(at, e - at);
      if (std::find(names.begin(), names.end(), nm) == names.end()) names.push_back(nm);
      at = e + 1;
    }
  }
  return names;
}

}  // namespace lbdem::halo
