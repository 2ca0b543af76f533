// The sliding cube landing flat on its 4 bottom corners (a unit cube, m = 1 kg, I = 1/6 kg m^2,
// sliding at v_x = 0.3 m/s, landing at 1 m/s, e = 0.5, mu_s = 0.6, mu_d = 0.5) under Stronge's law
// integrated simultaneously with the velocity-consistent sharing rule, derived by hand in
// test_simultaneous_impact.cpp, "(5)": compression ends stuck with p_L = 0.65, p_T = 0.35 on the
// leading and trailing corner pairs (W_c,L = -0.355 J, W_c,T = -0.145 J, per pair); in
// restitution both pairs stay stuck with rates (0.325, 0.175); the leading pair's work reaches
// e^2 |W_c,L| at t1, the trailing pair goes on alone by an impulse n until its own work does.
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace collision_response::testing {

struct CubeMotion {
  Eigen::Vector3d linear;   ///< [m/s]
  Eigen::Vector3d angular;  ///< [rad/s]
};

inline CubeMotion slidingCubeLandingUnderStronge() {
  const double t1 = std::sqrt(0.25 * 0.355 / (0.325 * 0.59 / 2));
  const double need = 0.25 * 0.145 - 0.175 * 0.41 * t1 * t1 / 2;
  const double n = (-0.41 * t1 + std::sqrt(0.41 * t1 * 0.41 * t1 + 4 * 0.8 * need)) / (2 * 0.8);
  return {Eigen::Vector3d(-0.09 * t1 + 0.6 * n, 0, 0.5 * t1 + n),
          Eigen::Vector3d(0, -0.18 * t1 + 1.2 * n, 0)};
}

}  // namespace collision_response::testing
