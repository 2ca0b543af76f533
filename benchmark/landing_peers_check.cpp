// landing_peers_check: checks the peer engines' landing setups (landing_peers.h) against closed
// forms, and times them. Not a unit test (the engines are optional and the times are machine
// figures): run by hand after changing a peer, see docs/benchmarks.md. Exit status 1 when a check
// fails. Usage: landing_peers_check [step_s]
//
//  1. Free flight: a tilted, spinning cube high above the table: position ballistic, orientation
//     exp(w t) q0 with the world angular velocity w constant (a cube's inertia is isotropic, so
//     the torque-free motion is a steady spin): checks the frames the state crosses the engine in
//     (MuJoCo's free-joint angular velocity is in body axes).
//  2. Flat drop from rest, 0.1 m, restitution zero: at rest on the table after 0.5 s, the centre
//     at the half width within 0.1 mm (ODE: up to its contact surface layer, 1 mm, deeper).
//  3. Flat slide: speed v, friction mu, on the table: stops after v^2 / (2 mu g), at t = v / (mu
//  g),
//     and at t/2 has speed v/2.
//  4. Flat bounce, restitution 0.5 where the engine has one: rebound speed e sqrt(2 g h).
//  5. The same landing twice, another in between: the same answer (every call starts afresh).
//  6. A frictionless corner-first landing: the table pushes only along z, at points whose lever
//     about the centre gives no z moment, so the horizontal velocity and (isotropic inertia) the
//     world z spin stay as they were. MuJoCo with its default pyramidal cone is reported, not
//     checked (with friction near 0 the pyramid is not frictionless); with the elliptic cone,
//     checked.
//  7. The search box is safe to fit in: at each of its corners the landing gives a finite state
//     with the cube on the table (no corner deeper than 5 mm: not through it), no exception.
//  8. Time per landing: a corner-first landing, 0.5 s simulated, median wall time of 21.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "landing_peers.h"
#ifdef HAVE_LANDING_MUJOCO
#include "landing_mujoco.h"
#endif

using collision_response::bench::CubeState;
using collision_response::bench::LandingModel;
using collision_response::bench::makeLandingPeers;
using collision_response::bench::TossedCube;

namespace {

constexpr double kG = 9.81;
int failures = 0;

void check(bool ok, const std::string& engine, const std::string& what, double value,
           double expected, double tolerance) {
  std::printf("  %-6s %-4s %-44s %12.6g  expected %12.6g  (tol %.2g)\n", engine.c_str(),
              ok ? "ok" : "FAIL", what.c_str(), value, expected, tolerance);
  if (!ok) ++failures;
}
void near(const std::string& engine, const std::string& what, double value, double expected,
          double tolerance) {
  check(std::abs(value - expected) <= tolerance, engine, what, value, expected, tolerance);
}

// Each engine's parameter values for a restitution e (0: none) and a friction coefficient mu, in
// its own terms. MuJoCo has no restitution: e = 0 is its critically damped default solref
// (0.02 s, 1); it is left out of the bounce check.
std::vector<double> valuesFor(const LandingModel& model, double e, double mu) {
  const std::string n = model.name();
  if (n == "Bullet") return {e, mu};
  if (n == "ODE") return {mu, e};
  if (n.rfind("MuJoCo", 0) == 0) return {mu, 0.02, 1.0};
  std::fprintf(stderr, "unknown peer %s\n", n.c_str());
  std::exit(2);
}

double tilt(const CubeState& s) {  // angle between the cube's axis nearest to world z and z [rad]
  const Eigen::Matrix3d r = s.orientation.toRotationMatrix();
  const double c = r.row(2).cwiseAbs().maxCoeff();
  return std::acos(std::min(1.0, c));
}

}  // namespace

int main(int argc, char** argv) {
  const double step = argc > 1 ? std::atof(argv[1]) : 1e-3;
  const TossedCube cube;
  const double a = cube.half_width;
  auto peers = makeLandingPeers(step);
  if (peers.empty()) {
    std::printf("no peer engine in this build (Bullet, ODE, MuJoCo all missing)\n");
    return 0;
  }
  std::printf("landing_peers_check: step %.3g s, cube half width %.4f m\n", step, a);

  std::printf("1. free flight, 0.2 s (frames)\n");
  for (auto& peer : peers) {
    CubeState s;
    s.position = Eigen::Vector3d(0.1, -0.2, 1.0);
    s.orientation =
        Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, -0.5).normalized()));
    s.linear_velocity = Eigen::Vector3d(0.5, -0.3, 1.0);
    s.angular_velocity = Eigen::Vector3d(3.0, -5.0, 7.0);
    const double t = 0.2;
    const CubeState e = peer->simulate(s, valuesFor(*peer, 0.0, 0.5), t);
    const Eigen::Vector3d p =
        s.position + s.linear_velocity * t + Eigen::Vector3d(0, 0, -kG) * t * t / 2;
    const Eigen::Quaterniond q(
        Eigen::AngleAxisd(s.angular_velocity.norm() * t, s.angular_velocity.normalized()) *
        s.orientation);
    // Fixed-step integrators of gravity: position off by at most g t step / 2 (symplectic Euler).
    near(peer->name(), "position error [m]", (e.position - p).norm(), 0.0,
         1.001 * kG * t * step / 2);
    near(peer->name(), "orientation error [rad]", e.orientation.angularDistance(q), 0.0, 1e-3);
    near(peer->name(), "angular velocity change [rad/s]",
         (e.angular_velocity - s.angular_velocity).norm(), 0.0, 1e-6);
    near(peer->name(), "linear velocity error [m/s]",
         (e.linear_velocity - (s.linear_velocity + Eigen::Vector3d(0, 0, -kG) * t)).norm(), 0.0,
         1e-6);
  }

  std::printf("2. flat drop from rest, 0.1 m, restitution 0, 0.5 s\n");
  for (auto& peer : peers) {
    CubeState s;
    s.position = Eigen::Vector3d(0, 0, a + 0.1);
    const CubeState e = peer->simulate(s, valuesFor(*peer, 0.0, 0.5), 0.5);
    // Bullet and MuJoCo (its solimp width is 1 mm at most) rest on the table; ODE corrects
    // penetration only down to its contact surface layer (1 mm), so it rests up to that deep.
    const bool ode = peer->name() == "ODE";
    const double rest = ode ? a - 0.5e-3 : a, tolerance = ode ? 0.6e-3 : 1e-4;
    near(peer->name(), "centre height [m]", e.position.z(), rest, tolerance);
    std::printf("         penetration %.3g mm\n", (a - e.position.z()) * 1e3);
    near(peer->name(), "speed [m/s]", e.linear_velocity.norm(), 0.0, 1e-2);
    near(peer->name(), "angular speed [rad/s]", e.angular_velocity.norm(), 0.0, 5e-2);
    near(peer->name(), "tilt [rad]", tilt(e), 0.0, 1e-3);
  }

  std::printf("3. flat slide, v = 2 m/s, mu = 0.4\n");
  {
    const double v = 2.0, mu = 0.4;
    const double t_stop = v / (mu * kG), d_stop = v * v / (2 * mu * kG);
    for (auto& peer : peers) {
      CubeState s;
      s.position = Eigen::Vector3d(0, 0, a);
      s.linear_velocity = Eigen::Vector3d(v, 0, 0);
      const std::vector<double> values = valuesFor(*peer, 0.0, mu);
      const CubeState half = peer->simulate(s, values, t_stop / 2);
      const CubeState end = peer->simulate(s, values, t_stop + 0.3);
      near(peer->name(), "speed at t_stop / 2 [m/s]", half.linear_velocity.x(), v / 2,
           0.03 * v / 2);
      near(peer->name(), "sliding distance [m]", end.position.x(), d_stop, 0.03 * d_stop);
      near(peer->name(), "speed after t_stop + 0.3 s [m/s]", end.linear_velocity.norm(), 0.0, 1e-2);
      near(peer->name(), "lateral drift [m]", std::abs(end.position.y()), 0.0, 1e-3);
    }
  }

  std::printf("4. flat bounce from 0.1 m, restitution 0.5\n");
  for (auto& peer : peers) {
    const double h = 0.1, e = 0.5;
    const double t_impact = std::sqrt(2 * h / kG), expected = e * std::sqrt(2 * kG * h);
    CubeState s;
    s.position = Eigen::Vector3d(0, 0, a + h);
    double rebound = -1e9;  // the largest upward speed after the impact (just after separation)
    for (double t = t_impact; t < t_impact + 0.06; t += 1e-3)
      rebound =
          std::max(rebound, peer->simulate(s, valuesFor(*peer, e, 0.5), t).linear_velocity.z());
    if (peer->name() == "MuJoCo") {
      std::printf(
          "  %-6s info largest rebound speed with solref (0.02, 1): %.4g m/s (no restitution)\n",
          peer->name().c_str(), rebound);
      continue;
    }
    near(peer->name(), "rebound speed [m/s]", rebound, expected, 0.05 * expected);
  }

  // A toss-like landing: corner first, tumbling; the state the harness gives (in flight).
  CubeState toss;
  toss.position = Eigen::Vector3d(0, 0, 0.2);
  toss.orientation =
      Eigen::Quaterniond(Eigen::AngleAxisd(0.6, Eigen::Vector3d(1, 1, 0).normalized()));
  toss.linear_velocity = Eigen::Vector3d(1.0, 0.2, -1.5);
  toss.angular_velocity = Eigen::Vector3d(2.0, 5.0, -3.0);

  std::printf("5. repeatability: the same landing twice, another in between\n");
  for (auto& peer : peers) {
    const std::vector<double> values = valuesFor(*peer, 0.3, 0.5);
    const CubeState first = peer->simulate(toss, values, 0.3);
    peer->simulate(toss, valuesFor(*peer, 0.8, 1.5), 0.4);
    const CubeState second = peer->simulate(toss, values, 0.3);
    near(peer->name(), "state difference",
         (first.position - second.position).norm() +
             (first.linear_velocity - second.linear_velocity).norm() +
             (first.angular_velocity - second.angular_velocity).norm(),
         0.0, 0.0);
  }

  std::printf(
      "6. frictionless corner-first landing, 0.3 s: horizontal velocity and vertical spin "
      "kept (table forces vertical, with no moment about z)\n");
  {
    std::vector<LandingModel*> models;
    for (auto& peer : peers) models.push_back(peer.get());
#ifdef HAVE_LANDING_MUJOCO
    collision_response::bench::MujocoLanding elliptic(step, cube, true);
    models.push_back(&elliptic);
#endif
    for (LandingModel* model : models) {
      const CubeState e = model->simulate(toss, valuesFor(*model, 0.3, 0.0), 0.3);
      const double dv = (e.linear_velocity - toss.linear_velocity).head<2>().norm();
      const double dw = std::abs(e.angular_velocity.z() - toss.angular_velocity.z());
      if (model->name() == "MuJoCo") {  // its pyramidal cone is not frictionless at mu = 0
        std::printf(
            "  %-6s info horizontal velocity change %.3g m/s, vertical spin change %.3g "
            "rad/s (pyramidal cone)\n",
            model->name().c_str(), dv, dw);
        continue;
      }
      // MuJoCo raises friction to at least 1e-5 (mjMINMU): over this landing's normal impulse
      // (about 4.4 m/s times the mass) that allows 4.4e-5 m/s and, at a 0.09 m lever, 2e-3 rad/s.
      const bool mujoco = model->name().rfind("MuJoCo", 0) == 0;
      near(model->name(), "horizontal velocity change [m/s]", dv, 0.0, mujoco ? 1e-4 : 1e-6);
      near(model->name(), "vertical spin change [rad/s]", dw, 0.0, mujoco ? 5e-3 : 1e-6);
      std::printf("         (it landed: speed change %.3g m/s)\n",
                  (e.linear_velocity - toss.linear_velocity).norm());
    }
  }

  std::printf(
      "7. every corner of each peer's search box: the toss landing's state finite, on "
      "or above the table\n");
  for (auto& peer : peers) {
    const auto parameters = peer->parameters();
    const std::size_t n = parameters.size();
    int bad = 0;
    double lowest = 1e9;
    for (unsigned corner = 0; corner < (1u << n); ++corner) {
      std::vector<double> values(n);
      for (std::size_t i = 0; i < n; ++i)
        values[i] = (corner >> i) & 1u ? parameters[i].upper : parameters[i].lower;
      try {
        const CubeState e = peer->simulate(toss, values, 0.5);
        const bool finite = e.position.allFinite() && e.linear_velocity.allFinite() &&
                            e.angular_velocity.allFinite();
        if (!finite) ++bad;
        // The lowest point of the cube: its centre less the largest extent along z.
        const Eigen::Matrix3d r = e.orientation.toRotationMatrix();
        const double low = e.position.z() - a * r.row(2).cwiseAbs().sum();
        if (low < -5e-3) {
          std::printf("  %-6s corner", peer->name().c_str());
          for (double v : values) std::printf(" %.3g", v);
          std::printf(": lowest corner %.3g m\n", low);
        }
        lowest = std::min(lowest, low);
      } catch (const std::exception& error) {
        std::printf("  %-6s %s\n", peer->name().c_str(), error.what());
        ++bad;
      }
    }
    near(peer->name(), "corners failing", bad, 0.0, 0.0);
    near(peer->name(), "lowest corner over all corners [m]", lowest, 0.0, 5e-3);
  }

  std::printf("8. time per landing (corner first, 0.5 s simulated at %.3g s steps; median of 21)\n",
              step);
  for (auto& peer : peers) {
    const std::vector<double> values = valuesFor(*peer, 0.3, 0.5);
    std::vector<double> us;
    CubeState end;
    for (int r = 0; r < 21; ++r) {
      const auto t0 = std::chrono::steady_clock::now();
      end = peer->simulate(toss, values, 0.5);
      us.push_back(
          std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count());
    }
    std::sort(us.begin(), us.end());
    std::printf(
        "  %-6s %9.1f us per landing, %.2f us per step (min %.1f, max %.1f); end height %.4f m, "
        "speed %.3g m/s\n",
        peer->name().c_str(), us[us.size() / 2], us[us.size() / 2] * step / 0.5, us.front(),
        us.back(), end.position.z(), end.linear_velocity.norm());
  }

  std::printf("%s: %d check(s) failed\n", failures ? "FAILED" : "passed", failures);
  return failures ? 1 : 0;
}
