#include "model.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace lbdem::scaling_model {

const char* to_string(Transport t) {
  switch (t) {
    case Transport::HostMpi: return "host_mpi";
    case Transport::DeviceMpi: return "device_mpi";
    case Transport::Nccl: return "nccl";
  }
  return "?";
}

Transport parse_transport(const std::string& s, const std::string& key) {
  if (s == "host_mpi") return Transport::HostMpi;
  if (s == "device_mpi") return Transport::DeviceMpi;
  if (s == "nccl") return Transport::Nccl;
  throw std::invalid_argument(key + ": '" + s + "' is not a transport (host_mpi, device_mpi, nccl)");
}

const char* to_string(Source s) {
  switch (s) {
    case Source::Measured: return "measured";
    case Source::DataSheet: return "data sheet";
    case Source::Fitted: return "fitted";
    case Source::Assumed: return "assumed";
  }
  return "?";
}

void Rates::add(bool fp64, double cells, double rate) {
  auto& v = fp64 ? this->fp64 : fp32;
  // Several measurements at one size: keep their mean.
  for (auto& p : v)
    if (p.first == cells) {
      p.second = 0.5 * (p.second + rate);
      return;
    }
  v.emplace_back(cells, rate);
  std::sort(v.begin(), v.end());
}

double Rates::rate(bool fp64, double cells) const {
  const auto& v = fp64 ? this->fp64 : fp32;
  if (v.empty()) throw std::invalid_argument(std::string("no measured ") + (fp64 ? "fp64" : "fp32") + " cell rate");
  if (cells <= v.front().first) return v.front().second;
  if (cells >= v.back().first) return v.back().second;
  for (std::size_t i = 1; i < v.size(); ++i)
    if (cells <= v[i].first) {
      const double t = std::log(cells / v[i - 1].first) / std::log(v[i].first / v[i - 1].first);
      return v[i - 1].second + t * (v[i].second - v[i - 1].second);
    }
  return v.back().second;
}

namespace {

// D3Q19 velocities other than rest: 6 faces, 12 edges.
int d3q19_slots(const std::array<int, 3>& r) {
  int n = 0;
  for (int cz = -1; cz <= 1; ++cz)
    for (int cy = -1; cy <= 1; ++cy)
      for (int cx = -1; cx <= 1; ++cx) {
        const std::array<int, 3> c{cx, cy, cz};
        const int nz = (cx != 0) + (cy != 0) + (cz != 0);
        if (nz == 0 || nz == 3) continue;
        bool ok = true;
        for (std::size_t a = 0; a < 3; ++a)
          if (r[a] != 0 && c[a] != r[a]) ok = false;
        n += ok;
      }
  return n;
}

// The peer across direction r, or -1 (an unsplit axis or a walled end).
int peer_of(const halo::Decomposition& dec, int rank, const std::array<int, 3>& r) {
  std::array<int, 3> c = dec.coords(rank);
  for (std::size_t a = 0; a < 3; ++a) {
    if (r[a] == 0) continue;
    if (dec.dims[a] < 2) return -1;
    c[a] += r[a];
    if (c[a] < 0 || c[a] >= dec.dims[a]) {
      if (!dec.periodic[a]) return -1;
      c[a] = (c[a] + dec.dims[a]) % dec.dims[a];
    }
  }
  return dec.rank_at(c);
}

Grid whole_of(const halo::Decomposition& dec) { return Grid::whole(dec.global, dec.periodic); }

}  // namespace

std::vector<LinkTraffic> fluid_links(const halo::Decomposition& dec, int rank, int storage_bytes, int gpus_per_node) {
  const Grid p = dec.ranks() > 1 ? dec.piece(whole_of(dec), rank) : whole_of(dec);
  std::vector<LinkTraffic> out;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const std::array<int, 3> r{dx, dy, dz};
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const int peer = peer_of(dec, rank, r);
        if (peer < 0) continue;
        const int slots = d3q19_slots(r);
        if (slots == 0) continue;
        long cells = 1;
        for (std::size_t a = 0; a < 3; ++a) cells *= r[a] != 0 ? 1 : p.local[a];
        LinkTraffic k;
        k.dir = r;
        k.peer = peer;
        k.bytes = cells * slots * storage_bytes;
        k.same_node = rank / gpus_per_node == peer / gpus_per_node;
        out.push_back(k);
      }
  return out;
}

int particle_neighbours(const halo::Decomposition& dec, int rank, int& same_node, int gpus_per_node) {
  int n = 0;
  same_node = 0;
  for (int dz = -1; dz <= 1; ++dz)
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        if (dx == 0 && dy == 0 && dz == 0) continue;
        const int peer = peer_of(dec, rank, {dx, dy, dz});
        if (peer < 0) continue;
        ++n;
        same_node += rank / gpus_per_node == peer / gpus_per_node;
      }
  return n;
}

double Model::memory_bytes(const Grid& piece, bool fp64, bool coupled) const {
  const double t = fp64 ? 8 : 4;
  const double storage = static_cast<double>(piece.storage_cells());
  // A-A: one population array (19 slots) and a flag byte per stored cell;
  // the PSM adds the solid fraction (one value) and a particle slot pair
  // (two 4-byte ids) per cell; halo buffers are a few faces.
  double b = storage * (19 * t + 1);
  if (coupled) b += storage * (t + 8);
  return b;
}

Prediction Model::predict(const Case& c) const {
  const Machine& m = machine;
  Grid whole = Grid::whole(c.grid, c.periodic);
  const halo::Decomposition dec = halo::decompose(whole, c.ranks, c.dims, "dims");
  const int tb = c.fp64 ? 8 : 4;
  const int N = dec.ranks();
  const int s = std::max(1, c.ranks_per_gpu);
  const int gpn = s > 1 ? N : m.gpus_per_node;  // ranks sharing one GPU share one node
  const double ib_gpu = m.ib_node_Bps.value / m.gpus_per_node;
  const bool coupled = c.particles > 0;
  const double density = coupled ? static_cast<double>(c.particles) / static_cast<double>(whole.global_cells()) : 0;
  const double eta = m.overlap_eff.value;

  Prediction best;
  best.dims = dec.dims;
  best.t_step = -1;
  for (int rank = 0; rank < N; ++rank) {
    const Grid p = N > 1 ? dec.piece(whole, rank) : whole;
    Prediction q;
    q.dims = dec.dims;
    const double cells = static_cast<double>(p.cells());
    const double R = rates.rate(c.fp64, cells);
    double t_c = cells / R;
    double t_inner = t_c;
    const auto links = fluid_links(dec, rank, tb, gpn);
    long b_nv = 0, b_ib = 0, bytes = 0;
    int n_nv = 0, n_ib = 0;
    for (const LinkTraffic& k : links) {
      bytes += k.bytes;
      if (k.same_node) { b_nv += k.bytes; ++n_nv; }
      else { b_ib += k.bytes; ++n_ib; }
    }
    q.halo_bytes = bytes;
    q.messages = static_cast<int>(links.size());
    if (N > 1) {
      t_inner = static_cast<double>(p.inner(1).size()) / R;
      const double pack = 4.0 * static_cast<double>(bytes) / m.copy_Bps.value;
      if (s > 1) {
        t_c = s * t_c * (1 + m.shared_gpu_penalty.value);
        t_inner = s * t_inner;
      } else {
        const auto launches = static_cast<double>(p.outer(1).size() + 2 * links.size());
        t_c += launches * m.launch_s.value;
      }
      t_c += pack;
    }
    double comm = 0, overlappable = 0, lat = 0;
    if (N > 1 && !links.empty()) {
      const double B_nv_dev = s > 1 ? m.copy_Bps.value / 2 : m.nvlink_Bps.value;
      switch (c.transport) {
        case Transport::HostMpi: {
          const double stage = s * static_cast<double>(bytes) * 2 / m.pcie_Bps.value;
          const double intra = n_nv * m.lat_mpi_s.value + static_cast<double>(b_nv) / m.host_mpi_Bps.value;
          const double inter = n_ib * m.lat_ib_s.value + static_cast<double>(b_ib) / ib_gpu;
          const double mpi = std::max(intra, inter);
          comm = m.fixed_host_s.value + stage + mpi;
          overlappable = s > 1 ? comm : mpi;
          lat = m.fixed_host_s.value + n_nv * m.lat_mpi_s.value + n_ib * m.lat_ib_s.value;
          break;
        }
        case Transport::DeviceMpi: {
          const double intra = n_nv * m.lat_mpi_s.value + static_cast<double>(b_nv) / B_nv_dev;
          const double inter = n_ib * m.lat_ib_s.value + static_cast<double>(b_ib) / ib_gpu;
          overlappable = std::max(intra, inter);
          comm = m.fixed_device_s.value + overlappable;
          lat = m.fixed_device_s.value + n_nv * m.lat_mpi_s.value + n_ib * m.lat_ib_s.value;
          break;
        }
        case Transport::Nccl: {
          const double wire = std::max(static_cast<double>(b_nv) / B_nv_dev, static_cast<double>(b_ib) / ib_gpu);
          overlappable = static_cast<double>(links.size()) * m.lat_nccl_s.value + wire;
          comm = m.fixed_device_s.value + overlappable;
          lat = m.fixed_device_s.value + static_cast<double>(links.size()) * m.lat_nccl_s.value;
          break;
        }
      }
    }
    const double exposed = std::max(0.0, comm - std::min(overlappable, eta * t_inner));
    q.t_comm = comm;
    q.t_exposed = exposed;
    q.t_latency = comm > 0 ? exposed * std::min(1.0, lat / comm) : 0;

    // Coupled suspension: PSM and DEM on the rank's particle load, particle
    // messages (host-driven rounds: counts, then bytes), none overlapped.
    double t_part = 0, t_imb = 0, t_psm_dem = 0;
    if (coupled) {
      const Suspension& su = suspension;
      const double np_mean = density * cells;
      double load = 1;
      const double cluster = c.clustering > 0 ? c.clustering : su.clustering.value;
      if (N > 1) load = std::min<double>(N, cluster * (1 + 3 / std::sqrt(std::max(np_mean, 1.0))));
      const double per_cell = c.fp64 ? su.psm_s_per_cell_fp64.value : su.psm_s_per_cell_fp32.value;
      auto dem = [&](double np) {
        return std::max(su.dem_floor_s.value, su.substeps.value * np / su.dem_particle_steps_per_s.value);
      };
      const double psm = per_cell * cells * load + dem(np_mean * load);
      const double psm_balanced = per_cell * cells + dem(np_mean);
      t_psm_dem = psm;
      t_imb = psm - psm_balanced;
      if (N > 1) {
        double face_cells = 0;
        for (std::size_t a = 0; a < 3; ++a)
          if (dec.dims[a] > 1) face_cells += 2.0 * cells / static_cast<double>(p.local[a]);
        const double ghosts = density * face_cells * su.diameter.value;
        const double migrants = density * face_cells * su.particle_speed.value;
        int nn_same = 0;
        const int nn = particle_neighbours(dec, rank, nn_same, gpn);
        const bool off_node = nn_same < nn;
        const double lat1 = off_node ? m.lat_ib_s.value : m.lat_mpi_s.value;
        const double bw = off_node ? ib_gpu
                                   : (c.transport == Transport::HostMpi ? m.host_mpi_Bps.value : m.nvlink_Bps.value);
        const double stage = c.transport == Transport::HostMpi ? 2 / m.pcie_Bps.value : 0;  // s per byte
        // DemDomain exchange: a ghost refresh through the transport before
        // every DEM force evaluation (one message per neighbour); the
        // hydrodynamic forces of ghosts back to their owners once per step;
        // migration and ghost rebuild at list builds (host-staged, sizes
        // then bytes).
        const double fixed = c.transport == Transport::HostMpi ? m.fixed_host_s.value : m.fixed_device_s.value;
        const double refresh = su.substeps.value * (fixed + lat1 + ghosts * su.refresh_bytes.value * (1 / bw + stage));
        const double forces = m.fixed_device_s.value + 2 * lat1 + ghosts * su.force_bytes.value * (1 / bw + 2 / m.pcie_Bps.value);
        const double migrate = (m.fixed_host_s.value + 2 * lat1 +
                                migrants * su.rebuild_every.value * su.migrate_bytes.value * (1 / bw + 2 / m.pcie_Bps.value)) /
                               su.rebuild_every.value;
        t_part = refresh + forces + migrate;
      }
    }
    q.t_compute = t_c + t_psm_dem;
    q.t_particles = t_part + t_imb;
    q.t_imbalance = t_imb;
    q.t_step = q.t_compute + exposed + t_part;
    q.mem_per_gpu = memory_bytes(p, c.fp64, coupled) * s;
    q.fits = q.mem_per_gpu <= m.mem_bytes.value;
    if (q.t_step > best.t_step) best = q;
  }
  best.mlups = static_cast<double>(whole.global_cells()) / best.t_step / 1e6;
  return best;
}

Case case_of(const Measured& m) {
  Case c;
  c.grid = m.grid;
  c.fp64 = m.fp64;
  c.ranks = m.ranks;
  c.ranks_per_gpu = m.ranks_per_gpu;
  c.dims = m.ranks > 1 ? m.dims : std::array<int, 3>{0, 0, 0};
  c.transport = m.transport == "none" ? Transport::HostMpi : parse_transport(m.transport, "transport");
  return c;
}

std::vector<std::string> calibrate(Model& md, const std::vector<Measured>& pts) {
  std::vector<std::string> log;
  Machine& m = md.machine;
  std::vector<const Measured*> multi;
  for (const Measured& p : pts) {
    if (p.ranks == 1) {
      const double cells = static_cast<double>(p.grid[0]) * p.grid[1] * p.grid[2];
      md.rates.add(p.fp64, cells, cells / p.t_step);
    } else {
      multi.push_back(&p);
    }
  }
  if (multi.empty()) return log;

  // Compute of ranks sharing a GPU: the whole GPU's cells at the measured
  // rate, times (1 + penalty); dedicated GPUs: extra launches of the split.
  double pen_sum = 0, launch_sum = 0;
  int pen_n = 0, launch_n = 0;
  for (const Measured* p : multi) {
    const Grid whole = Grid::whole(p->grid);
    const halo::Decomposition dec = halo::decompose(whole, p->ranks, p->dims, "dims");
    const Grid piece = dec.piece(whole, 0);
    const double cells = static_cast<double>(piece.cells());
    const double base = cells / md.rates.rate(p->fp64, cells);
    if (p->ranks_per_gpu > 1) {
      pen_sum += p->t_compute / (p->ranks_per_gpu * base) - 1;
      ++pen_n;
    } else {
      const auto links = fluid_links(dec, 0, p->fp64 ? 8 : 4, m.gpus_per_node);
      long bytes = 0;
      for (const auto& k : links) bytes += k.bytes;
      const double launches = static_cast<double>(piece.outer(1).size() + 2 * links.size());
      launch_sum += (p->t_compute - base - 4.0 * static_cast<double>(bytes) / m.copy_Bps.value) / launches;
      ++launch_n;
    }
  }
  if (pen_n > 0) {
    m.shared_gpu_penalty = {pen_sum / pen_n, Source::Fitted, "extra compute when ranks share one GPU (context switches)"};
    log.push_back("shared_gpu_penalty = " + std::to_string(m.shared_gpu_penalty.value) + " (mean of " +
                  std::to_string(pen_n) + " points)");
  }
  if (launch_n > 0) {
    m.launch_s = {std::max(0.0, launch_sum / launch_n), Source::Fitted, "one extra kernel launch of the split step"};
    log.push_back("launch_s = " + std::to_string(m.launch_s.value));
  }

  // Host-staged exchange (all points in one node): comm - staging - message
  // latencies = fixed + bytes / B.
  std::vector<std::pair<double, double>> xy;
  for (const Measured* p : multi) {
    if (p->transport != "host_mpi" || p->comm <= 0) continue;
    const double s = std::max(1, p->ranks_per_gpu);
    const double stage = s * static_cast<double>(p->halo_bytes) * 2 / m.pcie_Bps.value;
    xy.emplace_back(static_cast<double>(p->halo_bytes), p->comm - stage - p->messages * m.lat_mpi_s.value);
  }
  if (!xy.empty()) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (auto [x, y] : xy) { sx += x; sy += y; sxx += x * x; sxy += x * y; }
    const double n = static_cast<double>(xy.size());
    const double den = n * sxx - sx * sx;
    double slope = den > 0 ? (n * sxy - sx * sy) / den : 0;
    double icept;
    if (slope > 0) {
      icept = (sy - slope * sx) / n;
      if (icept < 0) {  // through the origin
        icept = 0;
        slope = sxy / sxx;
      }
      m.host_mpi_Bps = {1 / slope, Source::Fitted, "MPI between pinned host buffers of one node"};
    } else {
      icept = (sy - sx / m.host_mpi_Bps.value) / n;
    }
    m.fixed_host_s = {std::max(0.0, icept), Source::Fitted, "host-staged exchange: stream waits, staging, MPI progress"};
    log.push_back("host_mpi_Bps = " + std::to_string(m.host_mpi_Bps.value) + ", fixed_host_s = " +
                  std::to_string(m.fixed_host_s.value) + " (" + std::to_string(xy.size()) + " points)");
  }

  // Overlap efficiency: least squares on the relative step-time error.
  double best_eta = m.overlap_eff.value, best_err = std::numeric_limits<double>::max();
  for (int i = 0; i <= 100; ++i) {
    m.overlap_eff.value = i / 100.0;
    double err = 0;
    for (const Measured* p : multi) {
      const double e = md.predict(case_of(*p)).t_step / p->t_step - 1;
      err += e * e;
    }
    if (err < best_err) { best_err = err; best_eta = i / 100.0; }
  }
  m.overlap_eff = {best_eta, Source::Fitted, "fraction of the inner box's compute that hides communication"};
  log.push_back("overlap_eff = " + std::to_string(best_eta) + " (rms step error " +
                std::to_string(std::sqrt(best_err / static_cast<double>(multi.size()))) + ")");
  return log;
}

}  // namespace lbdem::scaling_model
