// lbdem_scaling_model: the many-GPU performance model (model.hpp), calibrated
// on measured scaling points, compared with every one of them, and used to
// predict strong and weak scaling to 4096 GPUs.
//
//   lbdem_scaling_model [--shared FILE.jsonl]... [FILE.jsonl]... [--rates FILE.jsonl]... [--lbm-h100 F] [--lbm-h200 F]
//                       [--psm-h100 F] [--psm-h200 F] [--clustering X] [--out-json F] [--out-md F]
// FILE.jsonl: lines of lbdem_bench_scaling, one rank per GPU; --shared: its
// multi-rank points ran all ranks on one GPU; --rates: one-rank lines at
// several sizes that only set the cell rate R(n). Defaults read bench/results.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "model.hpp"

using namespace lbdem;
using namespace lbdem::scaling_model;

namespace {

// ---- a small JSON reader (objects, arrays, strings, numbers, literals) ----
struct Json {
  enum Kind { Null, Bool, Num, Str, Arr, Obj } kind = Null;
  double num = 0;
  bool b = false;
  std::string str;
  std::vector<Json> arr;
  std::map<std::string, Json> obj;
  const Json* find(const std::string& k) const {
    auto it = obj.find(k);
    return it == obj.end() ? nullptr : &it->second;
  }
  const Json& at(const std::string& k, const std::string& where) const {
    const Json* j = find(k);
    if (!j) throw std::runtime_error(where + ": no key \"" + k + "\"");
    return *j;
  }
};

struct Parser {
  const std::string& s;
  std::size_t i = 0;
  std::string where;
  [[noreturn]] void fail(const std::string& why) {
    throw std::runtime_error(where + ": JSON " + why + " at character " + std::to_string(i));
  }
  void ws() { while (i < s.size() && std::isspace(static_cast<unsigned char>(s[i]))) ++i; }
  Json value() {
    ws();
    if (i >= s.size()) fail("ends early");
    Json j;
    const char c = s[i];
    if (c == '{') {
      j.kind = Json::Obj;
      ++i;
      ws();
      if (s[i] == '}') { ++i; return j; }
      for (;;) {
        ws();
        const std::string k = string();
        ws();
        if (s[i] != ':') fail("expects ':'");
        ++i;
        j.obj[k] = value();
        ws();
        if (s[i] == ',') { ++i; continue; }
        if (s[i] == '}') { ++i; return j; }
        fail("expects ',' or '}'");
      }
    }
    if (c == '[') {
      j.kind = Json::Arr;
      ++i;
      ws();
      if (s[i] == ']') { ++i; return j; }
      for (;;) {
        j.arr.push_back(value());
        ws();
        if (s[i] == ',') { ++i; continue; }
        if (s[i] == ']') { ++i; return j; }
        fail("expects ',' or ']'");
      }
    }
    if (c == '"') { j.kind = Json::Str; j.str = string(); return j; }
    if (s.compare(i, 4, "true") == 0) { i += 4; j.kind = Json::Bool; j.b = true; return j; }
    if (s.compare(i, 5, "false") == 0) { i += 5; j.kind = Json::Bool; return j; }
    if (s.compare(i, 4, "null") == 0) { i += 4; return j; }
    char* end = nullptr;
    j.num = std::strtod(s.c_str() + i, &end);
    if (end == s.c_str() + i) fail("has an unexpected character");
    i = static_cast<std::size_t>(end - s.c_str());
    j.kind = Json::Num;
    return j;
  }
  std::string string() {
    if (s[i] != '"') fail("expects a string");
    std::string out;
    for (++i; i < s.size() && s[i] != '"'; ++i) {
      if (s[i] == '\\' && i + 1 < s.size()) ++i;
      out += s[i];
    }
    ++i;
    return out;
  }
};

Json parse_json(const std::string& text, const std::string& where) {
  Parser p{text, 0, where};
  return p.value();
}

std::string read_file(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot read " + path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

std::vector<Measured> read_points(const std::string& path, bool shared) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error("cannot read " + path);
  std::vector<Measured> out;
  std::string line;
  int n = 0;
  while (std::getline(f, line)) {
    ++n;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const std::string where = path + ":" + std::to_string(n);
    const Json j = parse_json(line, where);
    Measured m;
    m.device = j.at("device", where).str;
    m.transport = j.at("transport", where).str;
    m.mode = j.at("mode", where).str;
    m.ranks = static_cast<int>(j.at("ranks", where).num);
    m.ranks_per_gpu = shared ? m.ranks : 1;
    for (std::size_t a = 0; a < 3; ++a) {
      m.dims[a] = static_cast<int>(j.at("dims", where).arr.at(a).num);
      m.grid[a] = static_cast<long>(j.at("grid", where).arr.at(a).num);
    }
    const std::string prec = j.at("precision", where).str;
    if (prec != "fp32" && prec != "fp64") throw std::runtime_error(where + ": precision '" + prec + "' (fp32, fp64)");
    m.fp64 = prec == "fp64";
    m.t_step = j.at("t_step_s", where).num;
    m.t_compute = j.at("t_compute_s", where).num;
    m.t_serial = j.at("t_serial_s", where).num;
    m.exposed = j.at("exposed_comm_s", where).num;
    m.comm = j.at("comm_s", where).num;
    m.halo_bytes = static_cast<long>(j.at("halo_bytes_per_rank", where).num);
    m.messages = static_cast<int>(j.at("messages_per_rank", where).num);
    m.copy_GBs = j.at("copy_bandwidth_GBs", where).num;
    if (const Json* st = j.find("streaming"); st && st->str != "aa")
      continue;  // the model's rates are those of the A-A step
    if (j.at("backend", where).str != "cuda") continue;
    out.push_back(m);
  }
  return out;
}

// D3Q19 A-A rates on the GPU and its copy bandwidth (lbdem_bench_lbm JSON).
void read_lbm(Model& md, const std::string& path) {
  const Json j = parse_json(read_file(path), path);
  md.machine.copy_Bps = {j.at("copy_bandwidth_GBs", path).at("cuda", path).num * 1e9, Source::Measured,
                         "device copy bandwidth (" + path.substr(path.rfind('/') + 1) + ")"};
  for (const Json& r : j.at("runs", path).arr) {
    if (r.at("backend", path).str != "cuda" || r.at("lattice", path).str != "D3Q19" ||
        r.at("streaming", path).str != "aa")
      continue;
    double cells = 1;
    for (const Json& c : r.at("cells", path).arr) cells *= c.num;
    md.rates.add(r.at("precision", path).str == "fp64", cells, r.at("mlups", path).num * 1e6);
  }
}

// PSM cost per cell beyond the fluid step and the DEM time of the fused,
// table-lookup suspension (lbdem_bench_psm suspension JSON).
void read_psm(Model& md, const std::string& path) {
  const Json j = parse_json(read_file(path), path);
  const std::string file = path.substr(path.rfind('/') + 1);
  for (const Json& r : j.at("runs", path).arr) {
    if (r.at("pipeline", path).str != "fused" || r.at("fraction", path).str != "table") continue;
    const double n = r.at("n", path).num;
    const double cells = n * n * n;
    const double per = (r.at("psm_step_seconds", path).num - r.at("fluid_step_seconds", path).num) / cells;
    const bool fp64 = r.at("precision", path).str == "fp64";
    const std::string note = "(PSM step - fluid step) / cells, fused, table, 256^3, phi 0.128, d/l 10 (" + file + ")";
    (fp64 ? md.suspension.psm_s_per_cell_fp64 : md.suspension.psm_s_per_cell_fp32) = {per, Source::Measured, note};
    if (!fp64)
      md.suspension.dem_floor_s = {r.at("dem_seconds_per_step", path).num + r.at("map_seconds", path).num,
                                   Source::Measured, "DEM (6 substeps) + map at 4101 particles, launch-bound (" + file + ")"};
  }
}

struct Args {
  std::vector<std::pair<std::string, bool>> points;  // file, shared
  std::vector<std::string> rate_files;               // one-rank lines: cell rates only
  std::string lbm_h100, lbm_h200, psm_h100, psm_h200, out_json, out_md;
  double clustering = 1.25;
};

[[noreturn]] void usage(const std::string& why) {
  std::fprintf(stderr,
               "lbdem_scaling_model: %s\n"
               "usage: lbdem_scaling_model [--shared FILE.jsonl]... [FILE.jsonl]... [--rates FILE.jsonl]...\n"
               "       [--lbm-h100 F] [--lbm-h200 F]\n"
               "       [--psm-h100 F] [--psm-h200 F] [--clustering X (>= 1)] [--out-json F] [--out-md F]\n",
               why.c_str());
  std::exit(2);
}

Args parse(int argc, char** argv) {
  Args a;
  const std::string res = std::string(LBDEM_SOURCE_DIR) + "/bench/results/";
  a.lbm_h100 = res + "lbm_h100.json";
  a.lbm_h200 = res + "lbm_h200.json";
  a.psm_h100 = res + "psm_suspension_h100.json";
  a.psm_h200 = res + "psm_suspension_h200.json";
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    auto val = [&]() -> std::string {
      if (i + 1 >= argc) usage(k + " needs a value");
      return argv[++i];
    };
    if (k == "--shared") a.points.emplace_back(val(), true);
    else if (k == "--rates") a.rate_files.push_back(val());
    else if (k == "--lbm-h100") a.lbm_h100 = val();
    else if (k == "--lbm-h200") a.lbm_h200 = val();
    else if (k == "--psm-h100") a.psm_h100 = val();
    else if (k == "--psm-h200") a.psm_h200 = val();
    else if (k == "--out-json") a.out_json = val();
    else if (k == "--out-md") a.out_md = val();
    else if (k == "--clustering") {
      const std::string v = val();
      char* end = nullptr;
      a.clustering = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || !(a.clustering >= 1))
        usage("--clustering " + v + ": must be a number >= 1 (densest sub-domain load / mean)");
    } else if (!k.empty() && k[0] == '-') usage("unknown option " + k);
    else a.points.emplace_back(k, false);
  }
  return a;
}

std::string fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

std::string param_json(const std::string& name, const Param& p) {
  return "    {\"name\": \"" + name + "\", \"value\": " + fmt("%.6g", p.value) + ", \"source\": \"" +
         to_string(p.source) + "\", \"note\": \"" + p.note + "\"}";
}

struct Row {
  std::string scene, scaling, precision, transport;
  int gpus = 1;
  std::array<long, 3> grid{};
  long particles = 0;
  Prediction p;
  double efficiency = 1;
  bool fits_h100 = true;
};

const char* loss_reason(const Row& r, double t_ideal) {
  // The largest term of (t_step - t_ideal): bandwidth part of exposed
  // communication (surface-to-volume), its latency part, particles
  // (imbalance and particle messages), or compute at small sub-domains.
  const double bw = r.p.t_exposed - r.p.t_latency;
  const double lat = r.p.t_latency + (r.p.t_particles - r.p.t_imbalance);
  const double imb = r.p.t_imbalance;
  const double comp = r.p.t_compute - r.p.t_imbalance - t_ideal;
  if (imb >= bw && imb >= lat && imb >= comp) return "particle imbalance";
  if (lat >= bw && lat >= comp) return "latency";
  if (bw >= comp) return "surface-to-volume";
  return "small sub-domains (split step)";
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const Args a = parse(argc, argv);
    Model h100, h200;
    read_lbm(h100, a.lbm_h100);
    read_lbm(h200, a.lbm_h200);
    read_psm(h100, a.psm_h100);
    read_psm(h200, a.psm_h200);
    h100.machine.mem_bytes = {80e9, Source::DataSheet, "H100 80 GB"};
    h200.machine.mem_bytes = {141e9, Source::DataSheet, "H200 141 GB"};
    for (Model* m : {&h100, &h200}) m->suspension.clustering.value = a.clustering;

    std::vector<Measured> pts100, pts200;
    for (const auto& [file, shared] : a.points)
      for (const Measured& m : read_points(file, shared)) {
        if (m.device.find("H100") != std::string::npos) pts100.push_back(m);
        else if (m.device.find("H200") != std::string::npos) pts200.push_back(m);
        else std::fprintf(stderr, "lbdem_scaling_model: %s: device '%s' is neither H100 nor H200; skipped\n",
                          file.c_str(), m.device.c_str());
      }
    // One-rank lines at many sizes: the cell rate R(n) of each device.
    for (const std::string& file : a.rate_files)
      for (const Measured& m : read_points(file, false)) {
        if (m.ranks != 1) throw std::runtime_error(file + ": --rates takes one-rank lines only");
        const double cells = static_cast<double>(m.grid[0]) * m.grid[1] * m.grid[2];
        if (m.device.find("H100") != std::string::npos) h100.rates.add(m.fp64, cells, cells / m.t_step);
        else if (m.device.find("H200") != std::string::npos) h200.rates.add(m.fp64, cells, cells / m.t_step);
      }
    std::vector<std::string> log100 = calibrate(h100, pts100), log200 = calibrate(h200, pts200);
    // Constants of the exchange (host side, overlap) carry over to the H200
    // where it has no multi-rank points of its own.
    bool h200_multi = false;
    for (const Measured& m : pts200) h200_multi = h200_multi || m.ranks > 1;
    if (!h200_multi) {
      h200.machine.host_mpi_Bps = h100.machine.host_mpi_Bps;
      h200.machine.fixed_host_s = h100.machine.fixed_host_s;
      h200.machine.overlap_eff = h100.machine.overlap_eff;
      for (Param* p : {&h200.machine.host_mpi_Bps, &h200.machine.fixed_host_s, &h200.machine.overlap_eff})
        p->note += " (fitted on the H100 points)";
    }

    // ---- model against every measured point ----
    std::ostringstream cmpj, cmpm;
    int worst_ok = 1;
    bool first = true;
    auto compare = [&](const Model& md, const std::vector<Measured>& pts) {
      for (const Measured& m : pts) {
        const Prediction p = md.predict(case_of(m));
        const double err = p.t_step / m.t_step - 1;
        if (std::fabs(err) > 0.10) worst_ok = 0;
        cmpj << (first ? "" : ",\n") << "    {\"device\": \"" << m.device << "\", \"ranks\": " << m.ranks
             << ", \"ranks_per_gpu\": " << m.ranks_per_gpu << ", \"mode\": \"" << m.mode << "\", \"grid\": [" << m.grid[0]
             << ", " << m.grid[1] << ", " << m.grid[2] << "], \"precision\": \"" << (m.fp64 ? "fp64" : "fp32")
             << "\", \"transport\": \"" << m.transport << "\", \"measured\": {\"t_step_s\": " << fmt("%.4e", m.t_step)
             << ", \"t_compute_s\": " << fmt("%.4e", m.t_compute) << ", \"comm_s\": " << fmt("%.4e", m.comm)
             << ", \"exposed_s\": " << fmt("%.4e", m.exposed) << ", \"halo_bytes\": " << m.halo_bytes
             << "}, \"model\": {\"t_step_s\": " << fmt("%.4e", p.t_step) << ", \"t_compute_s\": "
             << fmt("%.4e", p.t_compute) << ", \"comm_s\": " << fmt("%.4e", p.t_comm) << ", \"exposed_s\": "
             << fmt("%.4e", p.t_exposed) << ", \"halo_bytes\": " << p.halo_bytes << "}, \"rel_error\": "
             << fmt("%.4f", err) << "}";
        first = false;
        cmpm << "| " << m.device << " | " << m.ranks << (m.ranks_per_gpu > 1 ? " (1 GPU)" : "") << " | " << m.mode
             << " " << m.grid[0] << "x" << m.grid[1] << "x" << m.grid[2] << " | " << (m.fp64 ? "fp64" : "fp32")
             << " | " << m.transport << " | " << fmt("%.3f", m.t_step * 1e3) << " | " << fmt("%.3f", p.t_step * 1e3)
             << " | " << fmt("%+.1f %%", err * 100) << " | " << fmt("%.3f", m.t_compute * 1e3) << " / "
             << fmt("%.3f", p.t_compute * 1e3) << " | " << fmt("%.3f", m.comm * 1e3) << " / "
             << fmt("%.3f", p.t_comm * 1e3) << " | " << fmt("%.3f", m.exposed * 1e3) << " / "
             << fmt("%.3f", p.t_exposed * 1e3) << " | " << m.halo_bytes << " / " << p.halo_bytes << " |\n";
        std::printf("%-22s ranks %d%s %-6s %ldx%ldx%ld %s %-9s measured %.3f ms model %.3f ms (%+.1f %%)\n",
                    m.device.c_str(), m.ranks, m.ranks_per_gpu > 1 ? " (1 GPU)" : "", m.mode.c_str(), m.grid[0],
                    m.grid[1], m.grid[2], m.fp64 ? "fp64" : "fp32", m.transport.c_str(), m.t_step * 1e3,
                    p.t_step * 1e3, err * 100);
      }
    };
    compare(h100, pts100);
    compare(h200, pts200);

    // ---- predictions (H200 nodes of 8, NVLink inside, 4 x 200 Gb/s IB between) ----
    std::vector<Row> rows;
    const std::vector<int> many{1, 8, 64, 512, 4096}, host{1, 2, 4, 8};
    const Transport tps[] = {Transport::HostMpi, Transport::DeviceMpi, Transport::Nccl};
    struct Scene {
      std::string name;
      bool fp64;
      std::array<long, 3> strong;  // {0,0,0}: no strong scaling
      long particles;
      std::array<long, 3> per_gpu;  // {0,0,0}: no weak scaling
      long particles_per_gpu;
      std::vector<int> counts;
      bool stack_z;  // weak: per-GPU boxes stacked along z (as lbdem_bench_scaling --per-rank does)
      double clustering = 0;  // > 0: this scene's clustering factor (else --clustering)
    };
    const std::vector<Scene> scenes{
        {"suspension 512x2016x512, 129024 particles", false, {512, 2016, 512}, 129024, {256, 256, 256}, 4101, many, false},
        {"fluid 4096^3", false, {4096, 4096, 4096}, 0, {512, 512, 512}, 0, many, false},
        {"fluid 4096^3", true, {4096, 4096, 4096}, 0, {512, 512, 512}, 0, many, false},
        // The sweeps of one host (issues 14 and 20), for holding the model against them.
        {"one host: fluid 512^3", false, {512, 512, 512}, 0, {512, 512, 512}, 0, host, true},
        {"one host: fluid 512^3", true, {512, 512, 512}, 0, {512, 512, 512}, 0, host, true},
        {"one host: fluid 1024^3", false, {1024, 1024, 1024}, 0, {0, 0, 0}, 0, host, true},
        // The benchmark's suspension is a random homogeneous packing run for
        // 100 steps: no clusters form, only the Poisson fluctuation remains.
        {"one host: suspension 256^3 per GPU", false, {0, 0, 0}, 0, {256, 256, 256}, 4101, host, true, 1.0},
    };
    for (const Scene& sc : scenes)
      for (const Transport tp : tps)
        for (const bool weak : {false, true}) {
          if ((weak ? sc.per_gpu[0] : sc.strong[0]) == 0) continue;
          double t1 = 0;
          for (const int n : sc.counts) {
            Case c;
            c.fp64 = sc.fp64;
            c.transport = tp;
            c.ranks = n;
            c.clustering = sc.clustering;
            if (!weak) {
              c.grid = sc.strong;
              c.particles = sc.particles;
            } else if (sc.stack_z) {
              c.grid = {sc.per_gpu[0], sc.per_gpu[1], sc.per_gpu[2] * n};
              c.dims = {1, 1, n};
              c.particles = sc.particles_per_gpu * n;
            } else {
              // Per-GPU box times the ranks per axis the decomposition picks
              // for a cube of n such boxes.
              const long big = sc.per_gpu[0] * n;
              const halo::Decomposition d = halo::decompose(Grid::whole({big, big, big}), n);
              for (std::size_t ax = 0; ax < 3; ++ax) c.grid[ax] = sc.per_gpu[ax] * d.dims[ax];
              c.dims = d.dims;
              c.particles = sc.particles_per_gpu * n;
            }
            Row r;
            r.scene = sc.name;
            r.scaling = weak ? "weak" : "strong";
            r.precision = sc.fp64 ? "fp64" : "fp32";
            r.transport = to_string(tp);
            r.gpus = n;
            r.grid = c.grid;
            r.particles = c.particles;
            r.p = h200.predict(c);
            r.fits_h100 = r.p.mem_per_gpu <= 80e9;
            if (n == 1) t1 = r.p.t_step;
            r.efficiency = weak ? t1 / r.p.t_step : t1 / (n * r.p.t_step);
            rows.push_back(r);
          }
        }

    // ---- JSON ----
    std::ostringstream js;
    js << "{\n  \"benchmark\": \"scaling_model\",\n  \"command\": \"lbdem_scaling_model";
    for (int i = 1; i < argc; ++i) js << " " << argv[i];
    js << "\",\n  \"machine_predicted\": \"H200 141 GB, 8 per node, NVLink 4 inside, 4 x 200 Gb/s InfiniBand between nodes\",\n";
    js << "  \"calibration_log\": [";
    for (std::size_t i = 0; i < log100.size(); ++i) js << (i ? ", " : "") << "\"H100: " << log100[i] << "\"";
    for (std::size_t i = 0; i < log200.size(); ++i) js << ", \"H200: " << log200[i] << "\"";
    js << "],\n  \"all_points_within_10_percent\": " << (worst_ok ? "true" : "false") << ",\n";
    auto params = [&](const Model& md) {
      const Machine& m = md.machine;
      const Suspension& s = md.suspension;
      std::ostringstream o;
      o << "[\n" << param_json("nvlink_Bps", m.nvlink_Bps) << ",\n" << param_json("ib_node_Bps", m.ib_node_Bps) << ",\n"
        << param_json("pcie_Bps", m.pcie_Bps) << ",\n" << param_json("copy_Bps", m.copy_Bps) << ",\n"
        << param_json("host_mpi_Bps", m.host_mpi_Bps) << ",\n" << param_json("lat_mpi_s", m.lat_mpi_s) << ",\n"
        << param_json("lat_ib_s", m.lat_ib_s) << ",\n" << param_json("lat_nccl_s", m.lat_nccl_s) << ",\n"
        << param_json("launch_s", m.launch_s) << ",\n" << param_json("fixed_host_s", m.fixed_host_s) << ",\n"
        << param_json("fixed_device_s", m.fixed_device_s) << ",\n" << param_json("overlap_eff", m.overlap_eff) << ",\n"
        << param_json("shared_gpu_penalty", m.shared_gpu_penalty) << ",\n" << param_json("mem_bytes", m.mem_bytes)
        << ",\n" << param_json("psm_s_per_cell_fp32", s.psm_s_per_cell_fp32) << ",\n"
        << param_json("psm_s_per_cell_fp64", s.psm_s_per_cell_fp64) << ",\n" << param_json("dem_floor_s", s.dem_floor_s)
        << ",\n" << param_json("dem_particle_steps_per_s", s.dem_particle_steps_per_s) << ",\n"
        << param_json("clustering", s.clustering) << ",\n" << param_json("particle_speed", s.particle_speed) << ",\n"
        << param_json("refresh_bytes", s.refresh_bytes) << ",\n" << param_json("force_bytes", s.force_bytes) << ",\n"
        << param_json("migrate_bytes", s.migrate_bytes) << ",\n" << param_json("rebuild_every", s.rebuild_every) << ",\n";
      o << "    {\"name\": \"rates_fp32\", \"value\": [";
      for (std::size_t i = 0; i < md.rates.fp32.size(); ++i)
        o << (i ? ", " : "") << "[" << fmt("%.0f", md.rates.fp32[i].first) << ", " << fmt("%.4g", md.rates.fp32[i].second) << "]";
      o << "], \"source\": \"measured\", \"note\": \"(cells, cells/s), D3Q19 A-A\"},\n";
      o << "    {\"name\": \"rates_fp64\", \"value\": [";
      for (std::size_t i = 0; i < md.rates.fp64.size(); ++i)
        o << (i ? ", " : "") << "[" << fmt("%.0f", md.rates.fp64[i].first) << ", " << fmt("%.4g", md.rates.fp64[i].second) << "]";
      o << "], \"source\": \"measured\", \"note\": \"(cells, cells/s), D3Q19 A-A\"}\n  ]";
      return o.str();
    };
    js << "  \"parameters_h100\": " << params(h100) << ",\n  \"parameters_h200\": " << params(h200) << ",\n";
    js << "  \"points\": [\n" << cmpj.str() << "\n  ],\n  \"predictions\": [\n";
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const Row& r = rows[i];
      js << "    {\"scene\": \"" << r.scene << "\", \"scaling\": \"" << r.scaling << "\", \"precision\": \"" << r.precision
         << "\", \"transport\": \"" << r.transport << "\", \"gpus\": " << r.gpus << ", \"grid\": [" << r.grid[0] << ", "
         << r.grid[1] << ", " << r.grid[2] << "], \"dims\": [" << r.p.dims[0] << ", " << r.p.dims[1] << ", "
         << r.p.dims[2] << "], \"particles\": " << r.particles << ", \"t_step_s\": " << fmt("%.4e", r.p.t_step)
         << ", \"t_compute_s\": " << fmt("%.4e", r.p.t_compute) << ", \"comm_s\": " << fmt("%.4e", r.p.t_comm)
         << ", \"exposed_s\": " << fmt("%.4e", r.p.t_exposed) << ", \"latency_s\": " << fmt("%.4e", r.p.t_latency)
         << ", \"particles_s\": " << fmt("%.4e", r.p.t_particles) << ", \"imbalance_s\": "
         << fmt("%.4e", r.p.t_imbalance) << ", \"halo_bytes\": " << r.p.halo_bytes << ", \"messages\": " << r.p.messages
         << ", \"mlups\": " << fmt("%.1f", r.p.mlups) << ", \"efficiency\": " << fmt("%.4f", r.efficiency)
         << ", \"mem_per_gpu_GB\": " << fmt("%.2f", r.p.mem_per_gpu / 1e9) << ", \"fits_h200\": "
         << (r.p.fits ? "true" : "false") << ", \"fits_h100\": " << (r.fits_h100 ? "true" : "false") << "}"
         << (i + 1 < rows.size() ? ",\n" : "\n");
    }
    js << "  ]\n}\n";

    // ---- Markdown ----
    std::ostringstream md;
    md << "# Many-GPU performance model\n\n"
       << "`lbdem_scaling_model` (`bench/scaling/model.hpp`; method and parameters: `bench/scaling/NOTES.md`). "
       << "Model against every measured point, then predictions for H200 nodes of 8 (NVLink 4 inside, "
       << "4 x 200 Gb/s InfiniBand between nodes). Command: `" << js.str().substr(js.str().find("lbdem_scaling_model"),
                                                                         js.str().find("\",\n  \"machine") - js.str().find("lbdem_scaling_model"))
       << "`. Plot: `scaling_model.png` (`scripts/plot_scaling.py`).\n\n## Calibration\n\n";
    for (const auto& l : log100) md << "- H100: " << l << "\n";
    for (const auto& l : log200) md << "- H200: " << l << "\n";
    md << "\n## Model against measurement (times in ms; measured / model)\n\n"
       << "| device | ranks | case | precision | transport | step measured | step model | error | compute | comm | "
          "exposed | halo bytes |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n"
       << cmpm.str() << "\nEvery point within 10 %: " << (worst_ok ? "yes" : "NO") << ".\n";
    std::string last;
    for (const Row& r : rows) {
      const std::string head = r.scene + ", " + r.precision + ", " + r.scaling + " scaling";
      if (head != last) {
        md << "\n## " << head << "\n\n"
           << (r.scaling == "weak" ? (r.particles ? "256^3 cells and 4101 particles per GPU" : "512^3 cells per GPU") : "")
           << (r.scaling == "weak" ? (r.scene.rfind("one host", 0) == 0 ? ", stacked along z. " : ". ") : "")
           << "Times in ms per step; efficiency against one GPU (model); memory per GPU (H200 141 GB; * = does not "
              "fit, + = does not fit an 80 GB H100).\n\n"
           << "| transport | GPUs | dims | step | compute | exposed comm (latency) | particles (imbalance) | MLUPS | "
              "efficiency | GB/GPU | below 80 % because |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
        last = head;
      }
      double t_ideal = 0;
      for (const Row& q : rows)
        if (q.scene == r.scene && q.precision == r.precision && q.scaling == r.scaling && q.transport == r.transport &&
            q.gpus == 1)
          t_ideal = r.scaling == "weak" ? q.p.t_step : q.p.t_step / r.gpus;
      md << "| " << r.transport << " | " << r.gpus << " | " << r.p.dims[0] << "x" << r.p.dims[1] << "x" << r.p.dims[2]
         << " | " << fmt("%.3f", r.p.t_step * 1e3) << " | " << fmt("%.3f", r.p.t_compute * 1e3) << " | "
         << fmt("%.3f", r.p.t_exposed * 1e3) << " (" << fmt("%.3f", r.p.t_latency * 1e3) << ") | "
         << fmt("%.3f", r.p.t_particles * 1e3) << " (" << fmt("%.3f", r.p.t_imbalance * 1e3) << ") | "
         << fmt("%.0f", r.p.mlups) << " | " << fmt("%.1f %%", r.efficiency * 100) << " | "
         << fmt("%.1f", r.p.mem_per_gpu / 1e9) << (r.p.fits ? "" : "*") << (r.fits_h100 ? "" : "+") << " | "
         << (r.efficiency < 0.8 ? loss_reason(r, t_ideal) : "") << " |\n";
    }

    // Where each series first falls below 80 % and which term costs most.
    md << "\n## Where and why efficiency falls below 80 %\n\n"
       << "The loss of a step against the ideal (one GPU's time / GPUs, or one GPU's time for weak scaling) is split "
          "into: the bandwidth part of the exposed halo exchange (surface-to-volume: halo bytes grow as the "
          "sub-domain surface, compute as its volume), per-message latency and fixed exchange costs (including the "
          "particle ghost refresh before every DEM substep and the force return, which are not overlapped), the "
          "particle load imbalance (PSM and DEM work of the densest sub-domain; clustering factor "
       << fmt("%.2f", a.clustering)
       << " times the Poisson fluctuation 1 + 3/sqrt(particles per rank)), and compute that does not shrink with "
          "the sub-domain (split-step launches, the DEM's launch-bound floor). The largest one is named.\n\n";
    std::string last_series;
    for (const Row& r : rows) {
      const std::string series = r.scene + ", " + r.precision + ", " + r.scaling + ", " + r.transport;
      if (series == last_series || r.efficiency >= 0.8) continue;
      last_series = series;
      double t_ideal = 0;
      for (const Row& q : rows)
        if (q.scene == r.scene && q.precision == r.precision && q.scaling == r.scaling && q.transport == r.transport &&
            q.gpus == 1)
          t_ideal = r.scaling == "weak" ? q.p.t_step : q.p.t_step / r.gpus;
      md << "- " << series << ": " << fmt("%.0f", r.efficiency * 100) << " % at " << r.gpus << " GPUs ("
         << loss_reason(r, t_ideal) << "; step " << fmt("%.3f", r.p.t_step * 1e3) << " ms of which exposed halo "
         << fmt("%.3f", r.p.t_exposed * 1e3) << ", particles " << fmt("%.3f", r.p.t_particles * 1e3) << ").\n";
    }
    if (!a.out_json.empty()) std::ofstream(a.out_json) << js.str();
    if (!a.out_md.empty()) std::ofstream(a.out_md) << md.str();
    if (a.out_json.empty() && a.out_md.empty()) std::fputs(md.str().c_str(), stdout);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lbdem_scaling_model: %s\n", e.what());
    return 2;
  }
}
