// Bullet landing peer (see landing_bullet.h).
#include "landing_bullet.h"

#include <btBulletDynamicsCommon.h>

#include "landing_stepping.h"

namespace collision_response::bench {
namespace {

// The table, making contacts only within `threshold` of it (Bullet takes the smaller of the two
// shapes' thresholds; the cube's default is 2 % of its bounding radius, 1.8 mm); see
// landing_bullet.h for why.
class LandingTable : public btStaticPlaneShape {
 public:
  explicit LandingTable(double threshold)
      : btStaticPlaneShape(btVector3(0, 0, 1), 0), threshold_(threshold) {}
  btScalar getContactBreakingThreshold(btScalar) const override { return threshold_; }

 private:
  double threshold_;
};

}  // namespace

struct BulletLanding::World {
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher{&configuration};
  btDbvtBroadphase broadphase;
  btSequentialImpulseConstraintSolver solver;
  btDiscreteDynamicsWorld world{&dispatcher, &broadphase, &solver, &configuration};
  btBoxShape box;
  LandingTable plane;
  std::unique_ptr<btRigidBody> cube, table;

  World(const TossedCube& c, double step)
      : box(btVector3(c.half_width, c.half_width, c.half_width)), plane(contactThreshold(step)) {
    configuration.setPlaneConvexMultipointIterations();
    box.setMargin(kMargin);  // btBoxShape keeps the half extents: margin inside, corners rounded
    world.setGravity(btVector3(0, 0, -9.81));
    // Split impulse for every penetration (Bullet's default only beyond 4 cm): pushing the cube out
    // of the table must not add to its rebound (see landing_bullet.h).
    world.getSolverInfo().m_splitImpulsePenetrationThreshold = 0.0;
    btRigidBody::btRigidBodyConstructionInfo table_info(0.0, nullptr, &plane);
    table = std::make_unique<btRigidBody>(table_info);
    table->setRestitution(1.0);  // Bullet's combined coefficients are products: the cube's rule
    table->setFriction(1.0);
    world.addRigidBody(table.get());
    btRigidBody::btRigidBodyConstructionInfo cube_info(c.mass, nullptr, &box,
                                                       btVector3(c.inertia, c.inertia, c.inertia));
    cube = std::make_unique<btRigidBody>(cube_info);
    cube->setActivationState(DISABLE_DEACTIVATION);  // no sleeping: the harness reads the state
    world.addRigidBody(cube.get());
  }
  ~World() {
    world.removeRigidBody(cube.get());
    world.removeRigidBody(table.get());
  }
};

BulletLanding::BulletLanding(double step, TossedCube cube)
    : world_(std::make_unique<World>(cube, checkedStep(step))), step_(step) {}

BulletLanding::~BulletLanding() = default;

std::vector<LandingParameter> BulletLanding::parameters() const {
  return {{"restitution", 0.0, 1.0, 0.5, false}, {"friction", 0.01, 2.0, 0.5, false}};
}

CubeState BulletLanding::simulate(const CubeState& before, const std::vector<double>& values,
                                  double duration) {
  checkInputs(name(), parameters(), values, {0.0, 0.0}, before);
  const StepPlan plan = planSteps(duration, step_);
  btRigidBody& cube = *world_->cube;
  // Out of the world and back in: drops the contact manifolds (and their warm-starting impulses)
  // of the previous call, so that every call starts from the same solver state.
  world_->world.removeRigidBody(&cube);
  world_->solver.reset();
  const Eigen::Quaterniond& q = before.orientation;
  const Eigen::Vector3d& p = before.position;
  cube.setCenterOfMassTransform(
      btTransform(btQuaternion(q.x(), q.y(), q.z(), q.w()), btVector3(p.x(), p.y(), p.z())));
  const Eigen::Vector3d& v = before.linear_velocity;
  const Eigen::Vector3d& w = before.angular_velocity;
  cube.setLinearVelocity(btVector3(v.x(), v.y(), v.z()));
  cube.setAngularVelocity(btVector3(w.x(), w.y(), w.z()));  // Bullet's is in world axes
  cube.clearForces();
  cube.setRestitution(values[0]);
  cube.setFriction(values[1]);
  world_->world.addRigidBody(&cube);
  // maxSubSteps = 0: one step of exactly the given length per call (no interpolation).
  for (long k = 0; k < plan.full; ++k) world_->world.stepSimulation(step_, 0);
  if (plan.rest > 0.0) world_->world.stepSimulation(plan.rest, 0);
  const btTransform& t = cube.getCenterOfMassTransform();
  const btQuaternion r = t.getRotation();
  CubeState after;
  after.position = Eigen::Vector3d(t.getOrigin().x(), t.getOrigin().y(), t.getOrigin().z());
  after.orientation = Eigen::Quaterniond(r.w(), r.x(), r.y(), r.z()).normalized();
  const btVector3& v1 = cube.getLinearVelocity();
  const btVector3& w1 = cube.getAngularVelocity();
  after.linear_velocity = Eigen::Vector3d(v1.x(), v1.y(), v1.z());
  after.angular_velocity = Eigen::Vector3d(w1.x(), w1.y(), w1.z());
  return after;
}

}  // namespace collision_response::bench
