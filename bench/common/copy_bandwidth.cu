// Built through lbdem_kernel_sources: compiled by nvcc with the CUDA backend,
// as host C++ without it.
#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>

#include "bench_support.hpp"
#include "core/buffer.hpp"
#include "core/error.hpp"

#ifndef LBDEM_GIT_COMMIT
#define LBDEM_GIT_COMMIT "unknown"
#endif

namespace lbdem::bench {

namespace {

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

double copy_bandwidth(Backend b, std::size_t bytes) {
  Buffer<char> src(b, static_cast<Index>(bytes)), dst(b, static_cast<Index>(bytes));
  backend_memset(b, src.data(), 1, bytes);
  backend_memset(b, dst.data(), 2, bytes);
  std::vector<double> t;
  if (b == Backend::Cuda) {
#if defined(LBDEM_HAVE_CUDA)
    cudaEvent_t e0, e1;
    LBDEM_CUDA_CHECK(cudaEventCreate(&e0));
    LBDEM_CUDA_CHECK(cudaEventCreate(&e1));
    LBDEM_CUDA_CHECK(cudaDeviceSynchronize());
    for (int r = 0; r < 23; ++r) {  // 3 warm-up copies, median of 20
      LBDEM_CUDA_CHECK(cudaEventRecord(e0));
      LBDEM_CUDA_CHECK(cudaMemcpyAsync(dst.data(), src.data(), bytes, cudaMemcpyDeviceToDevice));
      LBDEM_CUDA_CHECK(cudaEventRecord(e1));
      LBDEM_CUDA_CHECK(cudaEventSynchronize(e1));
      float ms = 0;
      LBDEM_CUDA_CHECK(cudaEventElapsedTime(&ms, e0, e1));
      if (r >= 3) t.push_back(1e-3 * ms);
    }
    LBDEM_CUDA_CHECK(cudaEventDestroy(e0));
    LBDEM_CUDA_CHECK(cudaEventDestroy(e1));
#else
    throw ResourceError("copy_bandwidth: this build has no CUDA backend");
#endif
  } else {
    const Index n = static_cast<Index>(bytes);
    char* d = dst.data();
    const char* s = src.data();
    for (int r = 0; r < 10; ++r) {  // 2 warm-up copies, median of 8
      const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel
      {
        const Index nt = omp_get_num_threads(), id = omp_get_thread_num();
        const Index lo = n * id / nt, hi = n * (id + 1) / nt;
        std::memcpy(d + lo, s + lo, static_cast<std::size_t>(hi - lo));
      }
      if (r >= 2) t.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    }
  }
  return 2.0 * static_cast<double>(bytes) / median(t);
}

std::string device_name(Backend b) {
#if defined(LBDEM_HAVE_CUDA)
  if (b == Backend::Cuda) {
    cudaDeviceProp prop{};
    LBDEM_CUDA_CHECK(cudaGetDeviceProperties(&prop, 0));
    return prop.name;
  }
#endif
  (void)b;
  std::ifstream cpu("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpu, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "host";
}

std::string utc_date() {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[16];
  std::strftime(buf, sizeof buf, "%Y-%m-%d", &tm);
  return buf;
}

std::string git_commit() {
  const char* env = std::getenv("LBDEM_COMMIT");
  if (env && *env) return env;
  return LBDEM_GIT_COMMIT[0] ? LBDEM_GIT_COMMIT : "unknown";
}

std::string json_escape(const std::string& s) {
  std::string o;
  for (const char c : s) {
    if (c == '"' || c == '\\') {
      o += '\\';
      o += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\u%04x", c);
      o += buf;
    } else {
      o += c;
    }
  }
  return o;
}

std::string json_header(const std::string& benchmark, const std::string& device,
                        const std::vector<std::pair<std::string, double>>& copy_bw) {
  std::ostringstream o;
  o.precision(6);
  o << "  \"benchmark\": \"" << json_escape(benchmark) << "\",\n  \"device\": \"" << json_escape(device)
    << "\",\n  \"date\": \"" << utc_date() << "\",\n  \"commit\": \"" << json_escape(git_commit())
    << "\",\n  \"copy_bandwidth_GBs\": {";
  for (std::size_t i = 0; i < copy_bw.size(); ++i)
    o << (i ? ", " : "") << "\"" << json_escape(copy_bw[i].first) << "\": " << copy_bw[i].second / 1e9;
  o << "}";
  return o.str();
}

}  // namespace lbdem::bench
