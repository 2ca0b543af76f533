// The sliding path's Taylor coefficients (slip_taylor.h; docs/physics.md, "Rotating slip in 3D:
// Taylor steps").
//
// With U1, U2, UN the coefficients of u_t1, u_t2, u_n and S those of sigma (u_t and sigma scaled
// by 1 / sigma0, so that S_0 = 1), order k of the state (k >= 0) gives order k of the velocities
// (linear in y; the constants u0 at order 0 only), then
//   sigma^2 = u_t1^2 + u_t2^2:
//     2 S_0 S_k = sum_j (U1_j U1_(k-j) + U2_j U2_(k-j)) - sum_(0<j<k) S_j S_(k-j)
//   dy/ds at order k (s = xi / T):
//     T sigma0 (S_k, -mu_d U1_k, -mu_d U2_k, sum_j S_j UN_(k-j))
// and Y_(k+1) = (dy/ds)_k / (k + 1). The first two sums are symmetric in j <-> k - j: each pair is
// taken once.
#include "collision_response/core/slip_taylor.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace collision_response::core {

bool SlipTaylor::expand(const Eigen::Matrix2d& A, const Eigen::Vector2d& b, double c,
                        const Eigen::Vector2d& u0_t, double u0_n, double mu_d,
                        const Eigen::Vector4d& y, int n, double clock) {
  n = std::clamp(n, 1, kMaxOrder);
  double U1[kMaxOrder + 1], U2[kMaxOrder + 1], UN[kMaxOrder + 1], S[kMaxOrder + 1];
  const double a00 = A(0, 0), a01 = A(0, 1), a10 = A(1, 0), a11 = A(1, 1);
  const double b1 = b.x(), b2 = b.y();
  const double u1 = u0_t.x() + a00 * y[1] + a01 * y[2] + b1 * y[0];
  const double u2 = u0_t.y() + a10 * y[1] + a11 * y[2] + b2 * y[0];
  const double sigma0 = std::hypot(u1, u2);
  if (!(sigma0 > 0.0 && sigma0 < std::numeric_limits<double>::infinity()) || !(clock > 0.0))
    return false;
  const double inverse_sigma0 = 1.0 / sigma0;
  const double step = clock * sigma0;  // T sigma0 [N s]: dp/ds at S = 1
  U1[0] = u1 * inverse_sigma0;
  U2[0] = u2 * inverse_sigma0;
  UN[0] = u0_n + b1 * y[1] + b2 * y[2] + c * y[0];
  S[0] = 1.0;
  for (int i = 0; i < 4; ++i) Y_[0][i] = y[i];
  for (int k = 0; k < n; ++k) {
    if (k > 0) {
      const double* Yk = Y_[k];
      U1[k] = (a00 * Yk[1] + a01 * Yk[2] + b1 * Yk[0]) * inverse_sigma0;
      U2[k] = (a10 * Yk[1] + a11 * Yk[2] + b2 * Yk[0]) * inverse_sigma0;
      UN[k] = b1 * Yk[1] + b2 * Yk[2] + c * Yk[0];
      // The pairs (j, k - j), 0 < j < k / 2, twice; the middle term (k even) once; j = 0 and k.
      double pairs = 0.0, pairs2 = 0.0;  // two sums: shorter dependency chains
      int j = 1;
      for (; 2 * (j + 1) < k; j += 2) {
        pairs += U1[j] * U1[k - j] + U2[j] * U2[k - j] - S[j] * S[k - j];
        pairs2 += U1[j + 1] * U1[k - j - 1] + U2[j + 1] * U2[k - j - 1] - S[j + 1] * S[k - j - 1];
      }
      for (; 2 * j < k; ++j) pairs += U1[j] * U1[k - j] + U2[j] * U2[k - j] - S[j] * S[k - j];
      double sum = 2.0 * (pairs + pairs2 + U1[0] * U1[k] + U2[0] * U2[k]);
      if (2 * j == k) sum += U1[j] * U1[j] + U2[j] * U2[j] - S[j] * S[j];
      S[k] = 0.5 * sum;  // S_0 = 1
    }
    double work = 0.0, work2 = 0.0;
    int j = 0;
    for (; j + 1 <= k; j += 2) {
      work += S[j] * UN[k - j];
      work2 += S[j + 1] * UN[k - j - 1];
    }
    if (j == k) work += S[k] * UN[0];
    const double scale = step / (k + 1);
    Y_[k + 1][0] = S[k] * scale;
    Y_[k + 1][1] = -mu_d * U1[k] * scale;
    Y_[k + 1][2] = -mu_d * U2[k] * scale;
    Y_[k + 1][3] = (work + work2) * scale;
  }
  order_ = n;
  return true;
}

double SlipTaylor::size(int k, double work_scale) const {
  const double* Yk = Y_[k];
  return std::max(std::max(std::abs(Yk[0]), std::abs(Yk[1])),
                  std::max(std::abs(Yk[2]), std::abs(Yk[3]) / work_scale));
}

Eigen::Vector4d SlipTaylor::at(double t) const {
  double v0 = Y_[order_][0], v1 = Y_[order_][1], v2 = Y_[order_][2], v3 = Y_[order_][3];
  for (int k = order_ - 1; k >= 0; --k) {
    v0 = v0 * t + Y_[k][0];
    v1 = v1 * t + Y_[k][1];
    v2 = v2 * t + Y_[k][2];
    v3 = v3 * t + Y_[k][3];
  }
  return Eigen::Vector4d(v0, v1, v2, v3);
}

Eigen::Vector4d SlipTaylor::rate(double t) const {
  double d0 = order_ * Y_[order_][0], d1 = order_ * Y_[order_][1], d2 = order_ * Y_[order_][2],
         d3 = order_ * Y_[order_][3];
  for (int k = order_ - 1; k >= 1; --k) {
    d0 = d0 * t + k * Y_[k][0];
    d1 = d1 * t + k * Y_[k][1];
    d2 = d2 * t + k * Y_[k][2];
    d3 = d3 * t + k * Y_[k][3];
  }
  return Eigen::Vector4d(d0, d1, d2, d3);
}

void SlipTaylor::linear(const Eigen::Vector4d& grad, double offset, double* e) const {
  for (int k = 0; k <= order_; ++k)
    e[k] = grad[0] * Y_[k][0] + grad[1] * Y_[k][1] + grad[2] * Y_[k][2] + grad[3] * Y_[k][3];
  e[0] += offset;
}

double SlipTaylor::value(const double* e, int order, double t) {
  double v = e[order];
  for (int k = order - 1; k >= 0; --k) v = v * t + e[k];
  return v;
}

double SlipTaylor::value(const double* e, int order, double t, double& slope) {
  double v = e[order], d = 0.0;
  for (int k = order - 1; k >= 0; --k) {
    d = d * t + v;
    v = v * t + e[k];
  }
  slope = d;
  return v;
}

}  // namespace collision_response::core
