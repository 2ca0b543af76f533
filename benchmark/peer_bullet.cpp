// Bullet peer adapter (see peer_bullet.h).
#include "peer_bullet.h"

#include <btBulletDynamicsCommon.h>

#include <BulletDynamics/MLCPSolvers/btDantzigSolver.h>
#include <BulletDynamics/MLCPSolvers/btMLCPSolver.h>
#include <algorithm>
#include <chrono>
#include <map>
#include <memory>

namespace collision_response::bench {
namespace {

btVector3 bt(const Eigen::Vector3d& v) {
  return btVector3(v.x(), v.y(), v.z());
}
Eigen::Vector3d eig(const btVector3& v) {
  return Eigen::Vector3d(v.x(), v.y(), v.z());
}

}  // namespace

PeerRun runBullet(const core::Scene& scene, const BulletConfig& config, int repetitions) {
  btSphereShape shape(0.1);  // the solver never looks at it; bodies need one
  std::vector<std::unique_ptr<btRigidBody>> bodies;
  std::vector<btCollisionObject*> movable;
  for (const auto& b : scene.bodies) {
    // Our bodies have a diagonal inertia in body axes (the scenes are built that way).
    const btVector3 local_inertia(b.inertia(0, 0), b.inertia(1, 1), b.inertia(2, 2));
    btRigidBody::btRigidBodyConstructionInfo info(b.mass, nullptr, &shape, local_inertia);
    auto body = std::make_unique<btRigidBody>(info);
    const Eigen::Quaterniond q = b.orientation.normalized();
    body->setCenterOfMassTransform(
        btTransform(btQuaternion(q.x(), q.y(), q.z(), q.w()), bt(b.worldCom())));
    body->setActivationState(DISABLE_DEACTIVATION);
    if (b.mass > 0.0) movable.push_back(body.get());
    bodies.push_back(std::move(body));
  }
  auto index = [&](const std::string& id) {
    for (std::size_t i = 0; i < scene.bodies.size(); ++i)
      if (scene.bodies[i].id == id) return static_cast<int>(i);
    return -1;
  };
  // One manifold per body pair, Bullet's layout: body0 = our b, body1 = our a, so that the normal
  // on B (our a) points towards A (our b) and Bullet's +impulse on body0 is our +P on b.
  std::map<std::pair<int, int>, std::unique_ptr<btPersistentManifold>> by_pair;
  std::vector<std::pair<btPersistentManifold*, int>> where;  // per contact: manifold, point index
  for (const auto& c : scene.contacts) {
    const int a = index(c.body_a), b = index(c.body_b);
    auto& manifold = by_pair[{b, a}];
    if (!manifold)
      manifold = std::make_unique<btPersistentManifold>(bodies[b].get(), bodies[a].get(), 0,
                                                        BT_LARGE_FLOAT, BT_LARGE_FLOAT);
    const btVector3 p = bt(c.point);
    btManifoldPoint point(bodies[b]->getWorldTransform().invXform(p),
                          bodies[a]->getWorldTransform().invXform(p), bt(c.normal), 0.0);
    point.m_positionWorldOnA = point.m_positionWorldOnB = p;
    point.m_combinedFriction = c.dynamic_friction;
    point.m_combinedRestitution = c.restitution;
    where.emplace_back(manifold.get(), manifold->addManifoldPoint(point));
  }
  std::vector<btPersistentManifold*> manifolds;
  for (auto& [pair, m] : by_pair) manifolds.push_back(m.get());

  btContactSolverInfo info;
  info.m_numIterations = config.iterations;
  info.m_erp = info.m_erp2 = 0.0;
  info.m_splitImpulse = 0;
  info.m_linearSlop = 0.0;
  info.m_restitutionVelocityThreshold = 0.0;
  info.m_solverMode = SOLVER_USE_2_FRICTION_DIRECTIONS | SOLVER_SIMD;  // no warm starting
  info.m_leastSquaresResidualThreshold = 0.0;  // run every iteration asked for
  info.m_globalCfm = 0.0;
  info.m_timeStep = 1.0 / 60.0;  // no effect on velocities with erp 0 and zero penetration

  btDantzigSolver dantzig;
  std::unique_ptr<btSequentialImpulseConstraintSolver> solver;
  if (config.solver == BulletSolver::kMlcpDantzig)
    solver = std::make_unique<btMLCPSolver>(&dantzig);
  else
    solver = std::make_unique<btSequentialImpulseConstraintSolver>();

  auto reset = [&] {
    for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
      bodies[i]->setLinearVelocity(bt(scene.bodies[i].linear_velocity));
      bodies[i]->setAngularVelocity(bt(scene.bodies[i].angular_velocity));
    }
    for (auto* m : manifolds) {
      for (int k = 0; k < m->getNumContacts(); ++k) {
        btManifoldPoint& pt = m->getContactPoint(k);
        pt.m_appliedImpulse = pt.m_appliedImpulseLateral1 = pt.m_appliedImpulseLateral2 = 0.0;
      }
    }
  };
  std::vector<double> times;
  PeerRun run;
  for (int r = 0; r < repetitions; ++r) {
    reset();
    const auto t0 = std::chrono::steady_clock::now();
    solver->solveGroup(movable.data(), static_cast<int>(movable.size()), manifolds.data(),
                       static_cast<int>(manifolds.size()), nullptr, 0, info, nullptr, nullptr);
    const auto t1 = std::chrono::steady_clock::now();
    times.push_back(std::chrono::duration<double, std::nano>(t1 - t0).count());
  }
  std::nth_element(times.begin(), times.begin() + times.size() / 2, times.end());
  run.ns_per_solve = times[times.size() / 2];
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    run.after.linear.push_back(eig(bodies[i]->getLinearVelocity()));
    run.after.angular.push_back(eig(bodies[i]->getAngularVelocity()));
  }
  for (std::size_t k = 0; k < scene.contacts.size(); ++k) {
    const btManifoldPoint& pt = where[k].first->getContactPoint(where[k].second);
    run.impulses.push_back(eig(pt.m_normalWorldOnB * pt.m_appliedImpulse +
                               pt.m_lateralFrictionDir1 * pt.m_appliedImpulseLateral1 +
                               pt.m_lateralFrictionDir2 * pt.m_appliedImpulseLateral2));
  }
  if (config.solver == BulletSolver::kMlcpDantzig) {
    const int fallbacks = static_cast<btMLCPSolver*>(solver.get())->getNumFallbacks();
    if (fallbacks > 0)
      run.note = "MLCP fell back to sequential impulses in " + std::to_string(fallbacks) + " of " +
                 std::to_string(repetitions) + " solves";
  }
  return run;
}

}  // namespace collision_response::bench
