#pragma once
// Memory use (core/memory_use.hpp) over the ranks of a run.
#include <string>
#include <vector>

#include "core/memory_use.hpp"
#include "halo/comm.hpp"

namespace lbdem::halo {

// The components of every rank's memory use (a rank without particles may
// hold fewer buffers): the union, in the order of the ranks. Collective.
std::vector<std::string> memory_component_names(const MemoryUse& m, const Comm& comm);

}  // namespace lbdem::halo
