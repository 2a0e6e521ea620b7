#pragma once
// The solid fraction of one cell for one particle, by method and dimension, as
// a small trivially-copyable functor shared by the slot map (cell_slots.cu) and
// the fused PSM kernel (psm_fused.hpp). `Access` reads table entries (constant
// memory, a global-memory copy, or the host copy).
//
// prepare(R) is the per-particle part (the linear method's volume-conserving
// radius: four Newton steps), done once per particle by callers that visit many
// cells of one particle; operator() takes its result.
#include <cmath>
#include <type_traits>

#include "core/hd.hpp"
#include "imb/fraction_table.hpp"
#include "imb/solid_fraction.hpp"

namespace lbdem::imb {

// Real: the arithmetic of the table and linear methods (double for the slot
// map; the fused kernel passes the lattice's precision). Callers pass offsets
// in double; they are rounded to Real once.
template <int Dim, FractionMethod M, class Access, class Real = double>
struct FractionOf {
  TableGeometry g;
  Access tab;
  bool linear_normalised = true;

  LBDEM_HD double prepare(double R) const {
    if constexpr (M == FractionMethod::Linear) {
      if (!linear_normalised) return R;
      return Dim == 3 ? linear_effective_radius_3d(R) : linear_effective_radius_2d(R);
    } else {
      return R;
    }
  }
  // eps of the cell whose centre sits at (rx, ry, rz) from the particle centre;
  // aux = prepare(R). Dim 2 ignores rz.
  LBDEM_HD Real operator()(double rx, double ry, double rz, double R, double aux) const {
    if constexpr (M == FractionMethod::Exact) {
      (void)aux;
      if constexpr (Dim == 3) return Real(exact_fraction_3d(rx, ry, rz, R));
      else return Real(exact_fraction_2d(rx, ry, R));
    } else if constexpr (M == FractionMethod::Table) {
      (void)aux;
      if constexpr (Dim == 3) return table_fraction_3d<Access, Real>(g, tab, Real(rx), Real(ry), Real(rz), Real(R));
      else return table_fraction_2d<Access, Real>(g, tab, Real(rx), Real(ry), Real(R));
    } else if constexpr (std::is_same_v<Real, double>) {
      const double d = Dim == 3 ? sqrt(rx * rx + ry * ry + rz * rz) : sqrt(rx * rx + ry * ry);
      return linear_fraction(d, aux);
    } else {
      const Real x = Real(rx), y = Real(ry), z = Real(rz);
      const Real d = Dim == 3 ? sqrt(x * x + y * y + z * z) : sqrt(x * x + y * y);
      const Real e = Real(aux) - d + Real(0.5);
      return e < Real(0) ? Real(0) : (e > Real(1) ? Real(1) : e);
    }
  }
  // The same with offsets, radius and aux already in Real (the fused kernel's
  // per-cell arithmetic in the lattice's precision).
  LBDEM_HD Real eval(Real rx, Real ry, Real rz, Real R, Real aux) const {
    if constexpr (M == FractionMethod::Table && Dim == 3) {
      // One division and nested lerps, in float or double (fewer divisions and
      // multiplications; the slot map keeps table_fraction_3d in double).
      return table_fraction_3d_one_div<Access, Real>(g, tab, rx, ry, rz, R);
    } else if constexpr (std::is_same_v<Real, double> || M == FractionMethod::Exact) {
      return (*this)(double(rx), double(ry), double(rz), double(R), double(aux));
    } else if constexpr (M == FractionMethod::Table) {
      return table_fraction_2d<Access, Real>(g, tab, rx, ry, R);
    } else {
      const Real d = Dim == 3 ? sqrt(rx * rx + ry * ry + rz * rz) : sqrt(rx * rx + ry * ry);
      const Real e = aux - d + Real(0.5);
      return e < Real(0) ? Real(0) : (e > Real(1) ? Real(1) : e);
    }
  }
  LBDEM_HD Real operator()(double rx, double ry, double rz, double R) const {
    return (*this)(rx, ry, rz, R, prepare(R));
  }
};

}  // namespace lbdem::imb
