// ODE landing peer (see landing_ode.h).
#include "landing_ode.h"

#include <ode/ode.h>

#include "landing_stepping.h"

namespace collision_response::bench {

struct OdeLanding::World {
  dWorldID world = nullptr;
  dSpaceID space = nullptr;
  dBodyID body = nullptr;
  dGeomID box = nullptr, plane = nullptr;
  dJointGroupID contacts = nullptr;

  explicit World(const TossedCube& c) {
    static const bool initialised = (dInitODE2(0), true);
    (void)initialised;
    world = dWorldCreate();
    dWorldSetGravity(world, 0, 0, -9.81);
    dWorldSetERP(world, kErp);
    dWorldSetCFM(world, kCfm);
    dWorldSetContactSurfaceLayer(world, kSurfaceLayer);
    dWorldSetContactMaxCorrectingVel(world, kMaxCorrectingVelocity);
    dWorldSetAutoDisableFlag(world, 0);
    space = dSimpleSpaceCreate(nullptr);
    body = dBodyCreate(world);
    dMass mass;
    dMassSetParameters(&mass, c.mass, 0, 0, 0, c.inertia, c.inertia, c.inertia, 0, 0, 0);
    dBodySetMass(body, &mass);
    const double side = 2.0 * c.half_width;
    box = dCreateBox(space, side, side, side);
    dGeomSetBody(box, body);
    plane = dCreatePlane(space, 0, 0, 1, 0);
    contacts = dJointGroupCreate(0);
  }
  ~World() {
    dJointGroupDestroy(contacts);
    dSpaceDestroy(space);  // destroys the geoms it holds
    dWorldDestroy(world);
  }
};

OdeLanding::OdeLanding(double step, TossedCube cube)
    : world_(std::make_unique<World>(cube)), step_(checkedStep(step)) {}

OdeLanding::~OdeLanding() = default;

std::vector<LandingParameter> OdeLanding::parameters() const {
  return {{"mu", 0.01, 2.0, 0.5, false}, {"bounce", 0.0, 1.0, 0.5, false}};
}

CubeState OdeLanding::simulate(const CubeState& before, const std::vector<double>& values,
                               double duration) {
  checkInputs(name(), parameters(), values, {0.0, 0.0}, before);
  if (values[1] > 1.0)
    throw std::invalid_argument("ODE: bounce: must be <= 1, got " + std::to_string(values[1]));
  const StepPlan plan = planSteps(duration, step_);
  World& w = *world_;
  const Eigen::Quaterniond& q = before.orientation;
  const dQuaternion dq = {q.w(), q.x(), q.y(), q.z()};
  dBodySetPosition(w.body, before.position.x(), before.position.y(), before.position.z());
  dBodySetQuaternion(w.body, dq);
  const Eigen::Vector3d& v = before.linear_velocity;
  const Eigen::Vector3d& om = before.angular_velocity;
  dBodySetLinearVel(w.body, v.x(), v.y(), v.z());
  dBodySetAngularVel(w.body, om.x(), om.y(), om.z());  // ODE's is in world axes
  dBodySetForce(w.body, 0, 0, 0);
  dBodySetTorque(w.body, 0, 0, 0);

  dContact contact{};
  contact.surface.mode = dContactBounce | dContactApprox1;
  contact.surface.mu = values[0];
  contact.surface.bounce = values[1];
  contact.surface.bounce_vel = kBounceVelocity;
  constexpr int kMaxContacts = 8;  // dCollide gives a box at most 4 against a plane
  dContactGeom geoms[kMaxContacts];
  auto step = [&](double dt) {
    // One pair: dCollide directly, what dSpaceCollide's near callback would do.
    const int n = dCollide(w.box, w.plane, kMaxContacts, geoms, sizeof(dContactGeom));
    for (int k = 0; k < n; ++k) {
      contact.geom = geoms[k];
      dJointAttach(dJointCreateContact(w.world, w.contacts, &contact), w.body, nullptr);
    }
    dWorldStep(w.world, dt);
    dJointGroupEmpty(w.contacts);
  };
  for (long k = 0; k < plan.full; ++k) step(step_);
  if (plan.rest > 0.0) step(plan.rest);

  CubeState after;
  const dReal* p = dBodyGetPosition(w.body);
  const dReal* r = dBodyGetQuaternion(w.body);
  const dReal* v1 = dBodyGetLinearVel(w.body);
  const dReal* w1 = dBodyGetAngularVel(w.body);
  after.position = Eigen::Vector3d(p[0], p[1], p[2]);
  after.orientation = Eigen::Quaterniond(r[0], r[1], r[2], r[3]).normalized();
  after.linear_velocity = Eigen::Vector3d(v1[0], v1[1], v1[2]);
  after.angular_velocity = Eigen::Vector3d(w1[0], w1[1], w1[2]);
  return after;
}

}  // namespace collision_response::bench
