// MuJoCo landing peer (see landing_mujoco.h).
#include "landing_mujoco.h"

#include <mujoco/mujoco.h>

#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "landing_stepping.h"

namespace collision_response::bench {
namespace {

// The scene: the table a plane through the origin (z up), the cube a box with a free joint, mass
// and inertia given explicitly (the TossedCube's), the body frame at the centre of mass.
std::string mjcf(const TossedCube& c, double step) {
  char text[2048];
  std::snprintf(text, sizeof text,
                R"(<mujoco model="cube_landing">
  <option timestep="%.17g" gravity="0 0 -9.81"/>
  <worldbody>
    <geom name="table" type="plane" size="0 0 1"/>
    <body name="cube" pos="0 0 1">
      <joint name="free" type="free"/>
      <inertial pos="0 0 0" mass="%.17g" diaginertia="%.17g %.17g %.17g"/>
      <geom name="cube" type="box" size="%.17g %.17g %.17g"/>
    </body>
  </worldbody>
</mujoco>
)",
                step, c.mass, c.inertia, c.inertia, c.inertia, c.half_width, c.half_width,
                c.half_width);
  return text;
}

// MuJoCo's warnings go to stdout and to MUJOCO_LOG.TXT in the working directory by default: keep
// both clean. The one that matters here, an unstable simulation, is read from mjData::warning.
void quietWarning(const char*) {}

}  // namespace

struct MujocoLanding::World {
  mjModel* model = nullptr;
  mjData* data = nullptr;
  int table = -1, cube = -1;

  World(const TossedCube& c, double step) {
    mju_user_warning = quietWarning;
    // From memory through MuJoCo's virtual file system (the struct is 2 MB: on the heap).
    const std::string xml = mjcf(c, step);
    auto vfs = std::make_unique<mjVFS>();
    mj_defaultVFS(vfs.get());
    if (mj_makeEmptyFileVFS(vfs.get(), "cube_landing.xml", static_cast<int>(xml.size())) != 0)
      throw std::runtime_error("MuJoCo: cannot make the model file in the VFS");
    const int file = mj_findFileVFS(vfs.get(), "cube_landing.xml");
    std::memcpy(vfs->filedata[file], xml.data(), xml.size());
    char error[1000] = "";
    model = mj_loadXML("cube_landing.xml", vfs.get(), error, sizeof error);
    mj_deleteVFS(vfs.get());
    if (!model) throw std::runtime_error(std::string("MuJoCo: mj_loadXML: ") + error);
    data = mj_makeData(model);
    table = mj_name2id(model, mjOBJ_GEOM, "table");
    cube = mj_name2id(model, mjOBJ_GEOM, "cube");
  }
  ~World() {
    mj_deleteData(data);
    mj_deleteModel(model);
  }
};

MujocoLanding::MujocoLanding(double step, TossedCube cube, bool elliptic_cone)
    : step_(checkedStep(step)), elliptic_(elliptic_cone) {
  world_ = std::make_unique<World>(cube, step_);
  if (elliptic_) world_->model->opt.cone = mjCONE_ELLIPTIC;
}

MujocoLanding::~MujocoLanding() = default;

std::vector<LandingParameter> MujocoLanding::parameters() const {
  // MuJoCo's defaults as initial values: friction 1, solref (0.02 s, 1).
  return {{"friction", 0.01, 2.0, 1.0, false},
          {"solref_timeconst", 2.0 * step_, 0.05, 0.02, true},
          {"solref_dampratio", 0.05, 1.0, 1.0, true}};
}

CubeState MujocoLanding::simulate(const CubeState& before, const std::vector<double>& values,
                                  double duration) {
  checkInputs(name(), parameters(), values, {0.0, 0.0, 0.0}, before);
  if (values[1] <= 0.0 || values[2] <= 0.0)
    throw std::invalid_argument(
        name() +
        ": solref_timeconst, solref_dampratio: must be > 0 (negative values are MuJoCo's "
        "direct stiffness/damping form, not offered here)");
  const StepPlan plan = planSteps(duration, step_);
  mjModel* m = world_->model;
  mjData* d = world_->data;
  for (int g : {world_->table, world_->cube}) {
    m->geom_friction[3 * g] = values[0];
    m->geom_solref[mjNREF * g] = values[1];
    m->geom_solref[mjNREF * g + 1] = values[2];
  }
  mj_resetData(m, d);  // also clears the warm start: every call from the same solver state
  const Eigen::Quaterniond& q = before.orientation;
  const double qpos[7] = {
      before.position.x(), before.position.y(), before.position.z(), q.w(), q.x(), q.y(), q.z()};
  std::memcpy(d->qpos, qpos, sizeof qpos);
  // A free joint's velocity: the linear one in world axes, the angular one in the body's axes.
  const Eigen::Vector3d w_body = q.conjugate() * before.angular_velocity;
  const double qvel[6] = {before.linear_velocity.x(),
                          before.linear_velocity.y(),
                          before.linear_velocity.z(),
                          w_body.x(),
                          w_body.y(),
                          w_body.z()};
  std::memcpy(d->qvel, qvel, sizeof qvel);
  for (long k = 0; k < plan.full; ++k) mj_step(m, d);
  if (plan.rest > 0.0) {
    m->opt.timestep = plan.rest;
    mj_step(m, d);
    m->opt.timestep = step_;
  }
  if (d->warning[mjWARN_BADQACC].number > 0)  // MuJoCo has reset the state: no answer
    throw std::runtime_error(name() +
                             ": the simulation went unstable (mjWARN_BADQACC) with friction " +
                             std::to_string(values[0]) + ", solref (" + std::to_string(values[1]) +
                             ", " + std::to_string(values[2]) + ")");
  CubeState after;
  after.position = Eigen::Vector3d(d->qpos[0], d->qpos[1], d->qpos[2]);
  after.orientation =
      Eigen::Quaterniond(d->qpos[3], d->qpos[4], d->qpos[5], d->qpos[6]).normalized();
  after.linear_velocity = Eigen::Vector3d(d->qvel[0], d->qvel[1], d->qvel[2]);
  after.angular_velocity = after.orientation * Eigen::Vector3d(d->qvel[3], d->qvel[4], d->qvel[5]);
  return after;
}

}  // namespace collision_response::bench
