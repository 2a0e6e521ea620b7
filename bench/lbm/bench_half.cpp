// Host throughput of the 16-bit storage conversions (core/half.hpp): one
// core, arrays small enough for the caches (so the figure is the conversion's
// cost, not memory traffic), the thread's CPU time, median of repeats. For each format: the
// branch-free encode/decode the kernels use, the alternative decode the other
// backend uses, and the case-by-case reference conversions; Fp16s also through
// its storage type (F16C where the compiler targets it, else Binary16Format).
//
// Inputs: "populations" are values like the stored f - w of a D3Q19 flow near
// rest (mostly 10^-4 .. 0.3 in magnitude, both signs); "small" are magnitudes
// below 2^-14, where Fp16c and binary16 codes are subnormal.
//
//   lbdem_bench_half [--n N] [--repeats R]
// prints one line per conversion: ns per value and values per second.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <vector>

#include "core/half.hpp"

namespace {

// CPU time of this thread (ns): a machine shared with other work slows the
// wall clock, not this.
double thread_ns() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e9 * static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec);
}

template <class Body>
double median_ns_per_value(std::size_t n, int repeats, int passes, Body body) {
  std::vector<double> t;
  for (int r = 0; r < repeats; ++r) {
    const double t0 = thread_ns();
    for (int p = 0; p < passes; ++p) body();
    const double t1 = thread_ns();
    t.push_back((t1 - t0) / (static_cast<double>(n) * passes));
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

// Keeps results observable so the loops are not removed.
volatile std::uint32_t g_sink = 0;

template <class Enc>
void bench_encode(const char* name, const char* input, const std::vector<float>& x, int repeats, int passes, Enc enc) {
  std::vector<std::uint16_t> out(x.size());
  const double ns = median_ns_per_value(x.size(), repeats, passes, [&] {
    const float* in = x.data();
    std::uint16_t* o = out.data();
    const std::size_t n = x.size();
    for (std::size_t i = 0; i < n; ++i) o[i] = enc(in[i]);
    g_sink = g_sink + o[n / 2];
  });
  std::printf("%-34s %-12s %8.3f ns  %8.1f M/s\n", name, input, ns, 1e3 / ns);
}

template <class Dec>
void bench_decode(const char* name, const char* input, const std::vector<std::uint16_t>& h, int repeats, int passes,
                  Dec dec) {
  std::vector<float> out(h.size());
  const double ns = median_ns_per_value(h.size(), repeats, passes, [&] {
    const std::uint16_t* in = h.data();
    float* o = out.data();
    const std::size_t n = h.size();
    for (std::size_t i = 0; i < n; ++i) o[i] = dec(in[i]);
    std::uint32_t b;
    std::memcpy(&b, &o[n / 2], sizeof b);
    g_sink = g_sink + b;
  });
  std::printf("%-34s %-12s %8.3f ns  %8.1f M/s\n", name, input, ns, 1e3 / ns);
}

template <class F>
void bench_format(const char* fname, const std::vector<float>& pops, const std::vector<float>& small, int repeats,
                  int passes) {
  const std::string f(fname);
  for (int k = 0; k < 2; ++k) {
    const std::vector<float>& x = k == 0 ? pops : small;
    const char* in = k == 0 ? "populations" : "small";
    std::vector<std::uint16_t> h(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) h[i] = F::encode_reference(x[i]);
    bench_encode((f + " encode").c_str(), in, x, repeats, passes, [](float v) { return F::encode(v); });
    bench_encode((f + " encode_reference").c_str(), in, x, repeats, passes,
                 [](float v) { return F::encode_reference(v); });
    bench_decode((f + " decode (host: significand)").c_str(), in, h, repeats, passes,
                 [](std::uint16_t c) { return F::decode(c); });
    bench_decode((f + " decode_scaled (device's)").c_str(), in, h, repeats, passes,
                 [](std::uint16_t c) { return F::decode_scaled(c); });
    bench_decode((f + " decode_reference").c_str(), in, h, repeats, passes,
                 [](std::uint16_t c) { return F::decode_reference(c); });
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::size_t n = 1 << 14;  // 64 KiB of floats and 32 KiB of codes: in L2
  int repeats = 9;
  for (int i = 1; i < argc; i += 2) {
    const std::string k = argv[i];
    if ((k == "--n" || k == "--repeats") && i + 1 == argc) {
      std::fprintf(stderr, "lbdem_bench_half: option '%s' needs a value\n", k.c_str());
      return 2;
    }
    if (k == "--n") {
      n = std::strtoull(argv[i + 1], nullptr, 10);
    } else if (k == "--repeats") {
      repeats = std::atoi(argv[i + 1]);
    } else {
      std::fprintf(stderr, "lbdem_bench_half: unknown option '%s' (valid: --n N, --repeats R)\n", k.c_str());
      return 2;
    }
  }
  if (n == 0 || repeats <= 0) {
    std::fprintf(stderr, "lbdem_bench_half: --n and --repeats must be positive (got %zu, %d)\n", n, repeats);
    return 2;
  }
  const int passes = static_cast<int>(std::max<std::size_t>(1, (std::size_t{1} << 24) / n));

  std::mt19937 gen(19);
  std::vector<float> pops(n), small(n);
  std::uniform_real_distribution<float> mant(1.0f, 2.0f);
  std::uniform_int_distribution<int> ex(-14, -2);  // 2^-14 .. 2^-1 magnitudes, as f - w near rest
  std::uniform_real_distribution<float> tiny(0.0f, 0x1p-14f);
  for (std::size_t i = 0; i < n; ++i) {
    const float s = (i & 1) ? -1.0f : 1.0f;
    pops[i] = s * std::ldexp(mant(gen), ex(gen));
    small[i] = s * tiny(gen);
  }
  std::printf("lbdem_bench_half: %zu values, %d passes per repeat, median of %d; F16C for Fp16s: %s\n", n, passes,
              repeats,
#if defined(__F16C__)
              "yes"
#else
              "no (software Binary16Format)"
#endif
  );
  bench_format<lbdem::Fp16cFormat>("Fp16c", pops, small, repeats, passes);
  bench_format<lbdem::Binary16Format>("Binary16", pops, small, repeats, passes);
  for (int k = 0; k < 2; ++k) {
    const std::vector<float>& x = k == 0 ? pops : small;
    const char* in = k == 0 ? "populations" : "small";
    std::vector<std::uint16_t> h(x.size());
    for (std::size_t i = 0; i < x.size(); ++i) h[i] = lbdem::Fp16s::encode(x[i]);
    bench_encode("Fp16s encode (storage type)", in, x, repeats, passes, [](float v) { return lbdem::Fp16s::encode(v); });
    bench_decode("Fp16s decode (storage type)", in, h, repeats, passes,
                 [](std::uint16_t c) { return lbdem::Fp16s::decode(c); });
  }
  return 0;
}
