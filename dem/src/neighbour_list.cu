// NeighbourList: cell grid, cell sort, Verlet-list build with history
// hand-over, capacity fit.
#include "neighbour_list.hpp"

#include <algorithm>
#include <cmath>

#include "core/algorithms.hpp"
#include "core/error.hpp"
#include "format.hpp"
#include "list_kernels.hpp"
#include "particle_store.hpp"

namespace lbdem::dem {

namespace {

// The arguments of BuildList, made into the kernel of each flag combination.
struct BuildArgs {
  State s;
  CellGrid g;
  const int *cstart, *cend, *perm, *nbr_prev, *ncount_prev;
  const Vec3d* hist_prev;
  const std::int64_t* gid_prev;
  int have_prev, prev_full, ghost_off;
  template <bool Friction, bool Ghosts>
  BuildList<Friction, Ghosts> make() const {
    return {s, g, cstart, cend, perm, nbr_prev, ncount_prev, hist_prev, gid_prev, have_prev, prev_full, ghost_off};
  }
};

struct CountAt {
  const int* c;
  LBDEM_HD int operator()(Index i) const { return c[i]; }
};

}  // namespace

void NeighbourList::set_geometry(const Box& box, const std::vector<double>& r, double skin_param) {
  double rmax = 0, rmin = 1e300;
  for (double ri : r) {
    if (!(ri > 0)) throw ConfigError(fmtx(("particles: radius {} must be > 0"), ri));
    rmax = std::max(rmax, ri);
    rmin = std::min(rmin, ri);
  }
  const Index np = static_cast<Index>(r.size());
  if (np == 0) rmax = rmin = 1;
  skin = skin_param > 0 ? skin_param : 0.2 * rmin;
  const double rc = 2 * rmax + skin;
  cutoff = rc;
  for (int k = 0; k < 3; ++k) {
    if (box.periodic[k] && box.len[k] < 2 * rc)
      throw ConfigError(fmtx(("domain: periodic length {} along axis {} is below twice the largest cutoff "
                              "2*(2 r_max + skin) = {}: enlarge the box or lower the skin"),
                             box.len[k], k, 2 * rc));
    grid.nc[k] = std::max(1, static_cast<int>(std::min(1e9, std::floor(box.len[k] / rc))));
  }
  // Bound the cell count (a huge non-periodic box with few particles).
  const long long max_cells = std::max<long long>(1 << 20, 2 * static_cast<long long>(np));
  while (1LL * grid.nc[0] * grid.nc[1] * grid.nc[2] > max_cells) {
    int k = static_cast<int>(std::max_element(grid.nc, grid.nc + 3) - grid.nc);
    grid.nc[k] = std::max(1, grid.nc[k] / 2);
  }
  for (int k = 0; k < 3; ++k) {
    grid.lo[k] = box.lo[k];
    grid.inv_cl[k] = grid.nc[k] / box.len[k];
    grid.periodic[k] = box.periodic[k];
  }
}

void NeighbourList::allocate(const Exec& ex, Index np, bool with_history, bool with_pairs, int capacity,
                             bool ghost_cells) {
  const Backend be = ex.backend();
  n = np;
  history = with_history;
  pair_path = with_pairs;
  cap = capacity;
  long long total = 1LL * grid.nc[0] * grid.nc[1] * grid.nc[2];
  if (ghost_cells) {
    ghost_off = static_cast<int>(total);
    total *= 2;
  }
  key = Buffer<std::uint32_t>(be, n);
  key_sorted = Buffer<std::uint32_t>(be, n);
  idx = Buffer<int>(be, n);
  perm = Buffer<int>(be, n);
  cell_start = Buffer<int>(be, total);
  cell_end = Buffer<int>(be, total);
  cell_start.fill_zero(ex);
  cell_end.fill_zero(ex);
  ncount = Buffer<int>(be, n);
  if (history) ncount_prev = Buffer<int>(be, n);
  ccount = Buffer<int>(be, n + 1);
  ccount.fill_zero(ex);
  coffs = Buffer<int>(be, n + 1);
  flags = Buffer<int>(be, 2);
  flags.fill_zero(ex);
}

void NeighbourList::resize(Backend be, Index np) {
  n = np;
  auto fit = [be](auto& b, Index m) {
    if (b.size() < m) b.reserve_discard(be, m + m / 4 + 16);
  };
  fit(key, n); fit(key_sorted, n); fit(idx, n); fit(perm, n); fit(ncount, n);
  if (history) fit(ncount_prev, n);
  fit(ccount, n + 1); fit(coffs, n + 1);
}

void NeighbourList::load_previous(Backend be, const std::vector<int>& count, const std::vector<int>& nb,
                                  const std::vector<Vec3d>& hs, int cap_prev) {
  if (!history) return;
  const Index slots = n * std::max(cap_prev, 1);
  nbr_prev.reserve_discard(be, slots);
  hist_prev.reserve_discard(be, slots);
  if (n > 0) {
    ncount_prev.copy_from_host(count.data(), n);
    if (!nb.empty()) {
      nbr_prev.copy_from_host(nb.data(), static_cast<Index>(nb.size()));
      hist_prev.copy_from_host(hs.data(), static_cast<Index>(hs.size()));
    }
  }
  have_prev = true;
  prev_loaded = true;
}

void NeighbourList::allocate_lists(Backend be) {
  const Index slots = n * cap;
  nbr.reserve_discard(be, slots);
  if (history) hist.reserve_discard(be, slots);
  if (pair_path) pairs.reserve_discard(be, slots / 2 + 1);
}

void NeighbourList::bind(State& s) const {
  s.nbr = nbr.data(); s.ncount = ncount.data(); s.cap = cap;
  s.hist = hist.data();
  s.half_skin2 = 0.25 * skin * skin;
  s.skin = skin;
  s.flags = flags.data();
}

void NeighbourList::rebuild(const Exec& ex, ParticleStore& store, const State& physics, Scratch& scratch) {
  rows = store.owned();
  // 1. Cell of every particle, then sort by cell (ghosts into the second set
  // of cells when there are ghosts).
  launch(ex, n, CellKey{store.pos.data(), grid, key.data(), idx.data(), rows, static_cast<std::uint32_t>(ghost_off)});
  const bool host = !ex.on_device();
  if (host) {
    // Host: a stable counting sort by cell (O(N + cells)), which yields the
    // cell ranges as a by-product; far cheaper than a comparison sort.
    const std::uint32_t* k_in = key.data();
    std::uint32_t* ks = key_sorted.data();
    int *start = cell_start.data(), *end = cell_end.data(), *pm = perm.data();
    const Index ncells = cell_start.size();
    std::fill(end, end + ncells, 0);
    for (Index i = 0; i < n; ++i) ++end[k_in[i]];
    int run = 0;
    for (Index c = 0; c < ncells; ++c) {
      const int cnt = end[c];
      start[c] = run;
      end[c] = run;  // fill cursor; ends at start + count
      run += cnt;
    }
    for (Index i = 0; i < n; ++i) {
      const int at = end[k_in[i]]++;
      pm[at] = static_cast<int>(i);
      ks[at] = k_in[i];
    }
  } else {
    // Device: empty the cells of the previous build (its sorted keys are
    // still there: O(N), not O(cells)), then a CUB radix sort over only the
    // bits a cell index can use.
    // With ghosts the record count changes from build to build: clear all.
    if (ghost_off > 0) {
      cell_start.fill_zero(ex);
      cell_end.fill_zero(ex);
    } else if (have_cells) {
      launch(ex, n, ClearCells{key_sorted.data(), cell_start.data(), cell_end.data()});
    }
    have_cells = true;
    int bits = 1;
    while (bits < 32 && (Index{1} << bits) < cell_start.size()) ++bits;
    sort_pairs(ex, key.data(), key_sorted.data(), idx.data(), perm.data(), n, scratch, 0, bits);
  }
  // 2. Reorder all particle arrays into cell order (locality for the force
  // loop); the store's gid_prev() then holds the old order's ids (history
  // lookup by partner id).
  store.reorder(ex, perm.data());
  // 3. Cell ranges.
  if (!host) launch(ex, n, CellRange{key_sorted.data(), cell_start.data(), cell_end.data(), n});
  // 4. Verlet list (keeping the previous one for the history hand-over).
  if (history && !prev_loaded) {
    nbr.swap(nbr_prev);
    ncount.swap(ncount_prev);
    hist.swap(hist_prev);
  }
  prev_loaded = false;
  for (int attempt = 0;; ++attempt) {
    allocate_lists(ex.backend());
    State s = physics;
    store.bind(s);
    bind(s);
    const BuildArgs a{s, grid, cell_start.data(), cell_end.data(), perm.data(), nbr_prev.data(), ncount_prev.data(),
                      hist_prev.data(), store.gid_prev(), have_prev ? 1 : 0, pair_path ? 0 : 1, ghost_off};
    if (history) {
      if (ghost_off > 0) launch(ex, rows, a.make<true, true>());
      else launch(ex, rows, a.make<true, false>());
    } else {
      if (ghost_off > 0) launch(ex, rows, a.make<false, true>());
      else launch(ex, rows, a.make<false, false>());
    }
    // The one blocking read of a build: a list that overflowed must be
    // rebuilt larger before any force uses it. The flags stay zero otherwise.
    // (The copy is on the legacy queue: ex's build is waited for first.)
    int f[2];
    ex.synchronize();
    flags.copy_to_host(f, 2);
    if (!f[0]) break;
    if (attempt > 4) throw ResourceError("DEM: neighbour list kept overflowing");
    cap = ((static_cast<int>(f[1] * 1.25) + 7) / 8) * 8;
    flags.fill_zero(ex);
  }
  if (gid_order) {
    State s = physics;
    store.bind(s);
    bind(s);
    if (history) launch(ex, rows, SortRows<true>{s});
    else launch(ex, rows, SortRows<false>{s});
  }
  have_prev = history;
  have_list = true;
}

bool NeighbourList::fit_capacity(const Exec& ex, Scratch& scratch) {
  if (rows == 0) return false;
  const int mx = transform_reduce(ex, rows, 0, MaxOp{}, CountAt{ncount.data()}, scratch);
  const int fit = ((mx * 3 / 2 + 8 + 7) / 8) * 8;
  if (fit >= cap) return false;
  cap = fit;
  // Drop the previous list: the next build starts afresh.
  have_prev = false;
  have_list = false;
  nbr = Buffer<int>();
  hist = Buffer<Vec3d>();
  pairs = Buffer<PairIJ>();
  nbr_prev = Buffer<int>();
  hist_prev = Buffer<Vec3d>();
  return true;
}

}  // namespace lbdem::dem
