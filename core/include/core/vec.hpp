#pragma once
// Small fixed-size vector for host and device code.
#include <cmath>
#include "core/hd.hpp"

namespace lbdem {

template <class T>
struct Vec3 {
  T x{}, y{}, z{};
  LBDEM_HD constexpr T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  LBDEM_HD constexpr const T& operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  LBDEM_HD constexpr Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  LBDEM_HD constexpr Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  LBDEM_HD constexpr Vec3& operator*=(T s) { x *= s; y *= s; z *= s; return *this; }
};
template <class T> LBDEM_HD constexpr Vec3<T> operator+(Vec3<T> a, const Vec3<T>& b) { return a += b; }
template <class T> LBDEM_HD constexpr Vec3<T> operator-(Vec3<T> a, const Vec3<T>& b) { return a -= b; }
template <class T> LBDEM_HD constexpr Vec3<T> operator-(const Vec3<T>& a) { return {-a.x, -a.y, -a.z}; }
template <class T> LBDEM_HD constexpr Vec3<T> operator*(Vec3<T> a, T s) { return a *= s; }
template <class T> LBDEM_HD constexpr Vec3<T> operator*(T s, Vec3<T> a) { return a *= s; }
template <class T> LBDEM_HD constexpr T dot(const Vec3<T>& a, const Vec3<T>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T> LBDEM_HD constexpr Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T> LBDEM_HD inline T norm(const Vec3<T>& a) { return std::sqrt(dot(a, a)); }

using Vec3d = Vec3<double>;
using Vec3f = Vec3<float>;

}  // namespace lbdem
