#pragma once
// Uniform doubles from a 64-bit Mersenne twister, the values
// std::uniform_real_distribution<double> gives with libstdc++ (one engine
// draw per number, rounded to double, times 2^-64, kept below 1), without
// the two long-double logarithms that its generate_canonical evaluates per
// call where the compiler does not fold them (unoptimised and sanitizer
// builds, where packing a million particles otherwise takes seconds).
#include <cmath>
#include <random>

namespace lbdem {

// Uniform in [0, 1).
inline double uniform01(std::mt19937_64& g) {
  const double x = static_cast<double>(g()) * 0x1.0p-64;
  return x < 1.0 ? x : std::nextafter(1.0, 0.0);
}

// Uniform in [a, b).
inline double uniform(std::mt19937_64& g, double a, double b) { return uniform01(g) * (b - a) + a; }

}  // namespace lbdem
