// Bullet (libbullet-dev, double precision) as a peer: the same contacts, resolved by its
// constraint solvers.
#pragma once

#include "peer_run.h"

namespace collision_response::bench {

enum class BulletSolver {
  kSequentialImpulse,  ///< btSequentialImpulseConstraintSolver
  kMlcpDantzig,        ///< btMLCPSolver with btDantzigSolver
};

struct BulletConfig {
  BulletSolver solver = BulletSolver::kSequentialImpulse;
  int iterations = 10;  ///< btContactSolverInfo::m_numIterations
};

/// Builds btRigidBody objects for the scene's bodies and one btPersistentManifold per body pair
/// holding the scene's contacts (distance 0, our points and normals, friction mu_d: Bullet has a
/// single coefficient), then times solveGroup() alone, `repetitions` times from the same state.
/// Configuration: zero gravity, restitution velocity threshold 0, split impulse off, erp = erp2 =
/// 0, linear slop 0, no warm starting, two friction directions (the first along the slip).
PeerRun runBullet(const core::Scene& scene, const BulletConfig& config, int repetitions);

}  // namespace collision_response::bench
