#pragma once

// A forward-mode dual number: a value and its gradient along N seeded directions, with the
// arithmetic, comparisons and Eigen traits that let a computation templated on its scalar run on
// it unchanged (simultaneous_impact.cpp: the derivatives of the simultaneous impulse-space
// integration). Private to the core library (not installed).
//
// Comparisons compare the values only: every branch is taken on the values, so the gradient is that
// of the piece the values lie on (one-sided at a branch point). Non-smooth functions (abs, max,
// min) carry the gradient of the branch their value takes. The values are not bit-identical to a
// double computation's: Eigen vectorises double reductions (dot products, norms) and sums them in
// another order than the unrolled scalar loop it uses here, an ulp apart; a caller that needs the
// double computation's branches compares the results (impact_derivatives.cpp does, to 1e-9).

#include <Eigen/Core>
#include <cmath>

namespace collision_response::core {

template <int N>
struct Dual {
  // Unaligned: the numbers sit in Eigen matrices and std::vectors of any alignment.
  using Gradient = Eigen::Matrix<double, N, 1, Eigen::DontAlign>;
  double v = 0.0;
  Gradient d = Gradient::Zero();

  Dual() = default;
  Dual(double value) : v(value) {}  // NOLINT: constants mix freely
  Dual(double value, const Gradient& gradient) : v(value), d(gradient) {}

  Dual& operator+=(const Dual& b) {
    v += b.v;
    d += b.d;
    return *this;
  }
  Dual& operator-=(const Dual& b) {
    v -= b.v;
    d -= b.d;
    return *this;
  }
  Dual& operator*=(const Dual& b) {
    d = b.v * d + v * b.d;
    v *= b.v;
    return *this;
  }
  Dual& operator/=(const Dual& b) {
    v /= b.v;  // a division, as the double computation does (not times 1 / b)
    d = (d - v * b.d) / b.v;
    return *this;
  }
};

template <int N>
Dual<N> operator+(Dual<N> a, const Dual<N>& b) {
  return a += b;
}
template <int N>
Dual<N> operator-(Dual<N> a, const Dual<N>& b) {
  return a -= b;
}
template <int N>
Dual<N> operator*(Dual<N> a, const Dual<N>& b) {
  return a *= b;
}
template <int N>
Dual<N> operator/(Dual<N> a, const Dual<N>& b) {
  return a /= b;
}
template <int N>
Dual<N> operator-(const Dual<N>& a) {
  return {-a.v, -a.d};
}
template <int N>
Dual<N> operator+(const Dual<N>& a) {
  return a;
}
template <int N>
Dual<N> operator+(Dual<N> a, double b) {
  a.v += b;
  return a;
}
template <int N>
Dual<N> operator+(double a, Dual<N> b) {
  b.v += a;
  return b;
}
template <int N>
Dual<N> operator-(Dual<N> a, double b) {
  a.v -= b;
  return a;
}
template <int N>
Dual<N> operator-(double a, const Dual<N>& b) {
  return {a - b.v, -b.d};
}
template <int N>
Dual<N> operator*(Dual<N> a, double b) {
  a.v *= b;
  a.d *= b;
  return a;
}
template <int N>
Dual<N> operator*(double a, Dual<N> b) {
  b.v *= a;
  b.d *= a;
  return b;
}
template <int N>
Dual<N> operator/(Dual<N> a, double b) {
  a.v /= b;
  a.d /= b;
  return a;
}
template <int N>
Dual<N> operator/(double a, const Dual<N>& b) {
  const double value = a / b.v;
  return {value, (-value / b.v) * b.d};
}

#define CR_DUAL_COMPARISON(op)                           \
  template <int N>                                       \
  bool operator op(const Dual<N>& a, const Dual<N>& b) { \
    return a.v op b.v;                                   \
  }                                                      \
  template <int N>                                       \
  bool operator op(const Dual<N>& a, double b) {         \
    return a.v op b;                                     \
  }                                                      \
  template <int N>                                       \
  bool operator op(double a, const Dual<N>& b) {         \
    return a op b.v;                                     \
  }
CR_DUAL_COMPARISON(<)
CR_DUAL_COMPARISON(>)
CR_DUAL_COMPARISON(<=)
CR_DUAL_COMPARISON(>=)
CR_DUAL_COMPARISON(==)
CR_DUAL_COMPARISON(!=)
#undef CR_DUAL_COMPARISON

// Found by argument-dependent lookup (Eigen calls them unqualified after `using std::...`).
template <int N>
Dual<N> sqrt(const Dual<N>& a) {
  const double value = std::sqrt(a.v);
  return {value, (0.5 / value) * a.d};
}
template <int N>
Dual<N> abs(const Dual<N>& a) {
  return a.v < 0.0 ? -a : a;
}
template <int N>
Dual<N> abs2(const Dual<N>& a) {
  return a * a;
}
template <int N>
bool isfinite(const Dual<N>& a) {
  return std::isfinite(a.v) && a.d.allFinite();
}
template <int N>
bool isnan(const Dual<N>& a) {
  return std::isnan(a.v);
}
template <int N>
bool isinf(const Dual<N>& a) {
  return std::isinf(a.v);
}
template <int N>
const Dual<N>& conj(const Dual<N>& a) {
  return a;
}
template <int N>
const Dual<N>& real(const Dual<N>& a) {
  return a;
}
template <int N>
Dual<N> imag(const Dual<N>&) {
  return Dual<N>(0.0);
}

// The value of a double or of a dual number.
inline double valueOf(double x) {
  return x;
}
template <int N>
double valueOf(const Dual<N>& x) {
  return x.v;
}

}  // namespace collision_response::core

namespace Eigen {

template <int N>
struct NumTraits<collision_response::core::Dual<N>> : NumTraits<double> {
  using Real = collision_response::core::Dual<N>;
  using NonInteger = collision_response::core::Dual<N>;
  using Nested = collision_response::core::Dual<N>;
  using Literal = double;
  enum {
    IsComplex = 0,
    IsInteger = 0,
    IsSigned = 1,
    RequireInitialization = 1,
    ReadCost = N + 1,
    AddCost = N + 1,
    MulCost = 2 * N + 1
  };
};

template <int N, typename BinaryOp>
struct ScalarBinaryOpTraits<collision_response::core::Dual<N>, double, BinaryOp> {
  using ReturnType = collision_response::core::Dual<N>;
};
template <int N, typename BinaryOp>
struct ScalarBinaryOpTraits<double, collision_response::core::Dual<N>, BinaryOp> {
  using ReturnType = collision_response::core::Dual<N>;
};

}  // namespace Eigen
