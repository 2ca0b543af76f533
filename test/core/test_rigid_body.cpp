// Unit tests of the rigid-body building blocks: world mass properties, kinetic energy, frame
// changes, the contact-space inverse mass matrix K and the tangent basis.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <cmath>
#include <random>

#include "collision_response/core/body_state.h"
#include "collision_response/core/constants.h"
#include "collision_response/core/contact_space.h"
#include "collision_response/core/rigid_body.h"

#include "scene_builders.h"

namespace cr = collision_response::core;
using namespace collision_response::testing;  // NOLINT: shared builders

namespace {

constexpr double kTol = 1e-9;
using collision_response::core::kPi;

void expectMatNear(const Matrix3d& got, const Matrix3d& want, double tol) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(got(r, c), want(r, c), tol) << "(" << r << "," << c << ")";
  }
}

Quaterniond aboutZ(double angle) {
  return Quaterniond(Eigen::AngleAxisd(angle, Vector3d::UnitZ()));
}

cr::BodyState box(double m, const Vector3d& moments) {
  cr::BodyState b;
  b.id = "box";
  b.mass = m;
  b.inertia = moments.asDiagonal();
  return b;
}

struct Random : collision_response::testing::RandomSource {
  using RandomSource::RandomSource;
  cr::BodyState body() {
    const Vector3d size = boxSize();
    cr::BodyState b = box(uniform(0.2, 5.0), Vector3d::Zero());
    b.inertia = boxInertia(b.mass, size);
    b.com = vec(-0.3, 0.3);
    b.position = vec(-1, 1);
    b.orientation = rotation();
    b.linear_velocity = vec(-2, 2);
    b.angular_velocity = vec(-3, 3);
    return b;
  }
};

// ---------------------------------------------------------------------------------------------
// makeRigidBody.
TEST(MakeRigidBody, WorldInverseInertiaOfQuarterTurnAboutZ) {
  // Body moments diag(1, 2, 3). A quarter turn about z sends body x to world y and body y to
  // world -x, so in the world the moment about x is 2, about y is 1, about z is 3:
  // I_world = diag(2, 1, 3), I_world^-1 = diag(1/2, 1, 1/3).
  cr::BodyState b = box(4.0, Vector3d(1, 2, 3));
  b.orientation = aboutZ(kPi / 2);
  const cr::RigidBody rb = cr::makeRigidBody(b);
  expectMatNear(rb.inverse_inertia, Vector3d(0.5, 1.0, 1.0 / 3.0).asDiagonal().toDenseMatrix(),
                kTol);
  EXPECT_NEAR(rb.inverse_mass, 0.25, 1e-15);
  EXPECT_TRUE(rb.movable());
}

TEST(MakeRigidBody, WorldInverseInertiaEqualsRotatedBodyInverse) {
  // General case, R I^-1 R^T, and its inverse must be the world inertia R I R^T.
  Random rnd(3);
  for (int k = 0; k < 50; ++k) {
    cr::BodyState b = rnd.body();
    // a full (non-diagonal) body inertia
    const Matrix3d Q = rnd.rotation().toRotationMatrix();
    b.inertia = Q * b.inertia * Q.transpose();
    b.inertia = 0.5 * (b.inertia + b.inertia.transpose()).eval();
    const Matrix3d R = b.orientation.toRotationMatrix();
    const cr::RigidBody rb = cr::makeRigidBody(b);
    expectMatNear(rb.inverse_inertia, R * b.inertia.inverse() * R.transpose(), kTol * 100);
    expectMatNear(rb.inverse_inertia * (R * b.inertia * R.transpose()), Matrix3d::Identity(), kTol);
    expectMatNear(rb.inverse_inertia, rb.inverse_inertia.transpose(), 0.0);
  }
}

TEST(MakeRigidBody, CentreOfMassOffsetIsPlacedInTheWorld) {
  // Body origin at (1, 2, 3), quarter turn about z, com at (1, 0, 0) in the body frame: the body
  // x axis points along world y, so the world com is (1, 2, 3) + (0, 1, 0) = (1, 3, 3).
  cr::BodyState b = box(1.0, Vector3d(1, 1, 1));
  b.position = Vector3d(1, 2, 3);
  b.orientation = aboutZ(kPi / 2);
  b.com = Vector3d(1, 0, 0);
  b.linear_velocity = Vector3d(0.5, -0.5, 2);
  b.angular_velocity = Vector3d(1, 2, 3);
  const cr::RigidBody rb = cr::makeRigidBody(b);
  expectVecNear(rb.com, Vector3d(1, 3, 3), kTol);
  expectVecNear(b.worldCom(), Vector3d(1, 3, 3), kTol);
  expectVecNear(rb.linear_velocity, b.linear_velocity, 0.0);
  expectVecNear(rb.angular_velocity, b.angular_velocity, 0.0);
  // Velocity of the body origin, 1 m from the com along world -y: v + w x (0, -1, 0).
  expectVecNear(rb.pointVelocity(Vector3d(0, -1, 0)), Vector3d(0.5 + 3, -0.5, 2 - 1), kTol);
}

TEST(MakeRigidBody, ImmovableBodyHasZeroInverseMassAndIsNeverChanged) {
  cr::BodyState b = box(0.0, Vector3d::Zero());
  b.linear_velocity = Vector3d(1, 0, 0);
  cr::RigidBody rb = cr::makeRigidBody(b);
  EXPECT_FALSE(rb.movable());
  EXPECT_EQ(rb.inverse_mass, 0.0);
  EXPECT_EQ(rb.inverse_inertia, Matrix3d::Zero());
  rb.applyImpulse(Vector3d(5, 5, 5), Vector3d(1, 0, 0));
  expectVecNear(rb.linear_velocity, Vector3d(1, 0, 0), 0.0);
  expectVecNear(rb.angular_velocity, Vector3d::Zero(), 0.0);
}

TEST(RigidBody, ApplyImpulseChangesMomentumAndAngularMomentum) {
  // dv = P / m, dw = I_world^-1 (r x P). Sphere-like body m = 2, I = 0.5 * identity:
  // P = (0, 4, 0) at r = (1, 0, 0): dv = (0, 2, 0), r x P = (0, 0, 4), dw = (0, 0, 8).
  cr::BodyState b = box(2.0, Vector3d(0.5, 0.5, 0.5));
  cr::RigidBody rb = cr::makeRigidBody(b);
  rb.applyImpulse(Vector3d(0, 4, 0), Vector3d(1, 0, 0));
  expectVecNear(rb.linear_velocity, Vector3d(0, 2, 0), kTol);
  expectVecNear(rb.angular_velocity, Vector3d(0, 0, 8), kTol);
}

// ---------------------------------------------------------------------------------------------
// Kinetic energy T = 1/2 m |v|^2 + 1/2 w^T I_world w.
TEST(KineticEnergy, TranslationPlusRotationHandValue) {
  // m = 2, v = (1, 2, 2): 1/2 * 2 * 9 = 9. Body moments diag(1, 2, 3) turned a quarter about z;
  // w = (0, 1, 0) in the world is body x, moment 1: 1/2 * 1 * 1 = 0.5. Total 9.5.
  cr::BodyState b = box(2.0, Vector3d(1, 2, 3));
  b.orientation = aboutZ(kPi / 2);
  b.linear_velocity = Vector3d(1, 2, 2);
  b.angular_velocity = Vector3d(0, 1, 0);
  EXPECT_NEAR(cr::kineticEnergy(b), 9.5, kTol);
  // Spinning about world x (body -y, moment 2) at 3 rad/s: 1/2 * 2 * 9 = 9 more than translation.
  b.angular_velocity = Vector3d(3, 0, 0);
  EXPECT_NEAR(cr::kineticEnergy(b), 9.0 + 9.0, kTol);
}

TEST(KineticEnergy, ImmovableBodyHasNone) {
  cr::BodyState b = box(0.0, Vector3d::Zero());
  b.linear_velocity = Vector3d(10, 0, 0);
  b.angular_velocity = Vector3d(0, 10, 0);
  EXPECT_EQ(cr::kineticEnergy(b), 0.0);
}

TEST(KineticEnergy, MatchesWorldFormulaForRandomBodies) {
  Random rnd(11);
  for (int k = 0; k < 50; ++k) {
    const cr::BodyState b = rnd.body();
    const Matrix3d R = b.orientation.toRotationMatrix();
    const double expected =
        0.5 * b.mass * b.linear_velocity.squaredNorm() +
        0.5 * b.angular_velocity.dot(R * b.inertia * R.transpose() * b.angular_velocity);
    EXPECT_NEAR(cr::kineticEnergy(b), expected, kTol * std::max(1.0, expected));
  }
}

// ---------------------------------------------------------------------------------------------
// transformed(): a fixed change of frame.
TEST(Transformed, KnownIsometryMovesPoseAndRotatesVelocities) {
  // new_T_old: quarter turn about x (y -> z, z -> -y), then translation (1, 0, 0).
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.rotate(Eigen::AngleAxisd(kPi / 2, Vector3d::UnitX()));
  T.pretranslate(Vector3d(1, 0, 0));
  cr::BodyState b = box(3.0, Vector3d(1, 2, 3));
  b.position = Vector3d(0, 1, 0);
  b.com = Vector3d(0, 0, 0.5);
  b.linear_velocity = Vector3d(0, 1, 0);
  b.angular_velocity = Vector3d(0, 0, 1);
  const cr::BodyState t = cr::transformed(b, T);
  expectVecNear(t.position, Vector3d(1, 0, 1), kTol);
  expectVecNear(t.linear_velocity, Vector3d(0, 0, 1), kTol);
  expectVecNear(t.angular_velocity, Vector3d(0, -1, 0), kTol);
  // The body's own frame turned with it: body z (com offset) now points along world -y.
  expectVecNear(t.worldCom(), Vector3d(1, -0.5, 1), kTol);
  // Body-frame data is untouched.
  EXPECT_EQ(t.mass, b.mass);
  EXPECT_EQ(t.inertia, b.inertia);
  EXPECT_EQ(t.com, b.com);
  EXPECT_EQ(t.id, b.id);
  EXPECT_NEAR(cr::kineticEnergy(t), cr::kineticEnergy(b), kTol);
}

TEST(Transformed, RandomIsometriesKeepKineticEnergyAndMapTheCom) {
  Random rnd(21);
  for (int k = 0; k < 50; ++k) {
    const cr::BodyState b = rnd.body();
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.rotate(rnd.rotation());
    T.pretranslate(rnd.vec(-5, 5));
    const cr::BodyState t = cr::transformed(b, T);
    const double e = cr::kineticEnergy(b);
    EXPECT_NEAR(cr::kineticEnergy(t), e, kTol * std::max(1.0, e));
    expectVecNear(t.worldCom(), T * b.worldCom(), kTol);
    EXPECT_NEAR(t.orientation.norm(), 1.0, 1e-12);
    // The velocity of a material point maps like a free vector: R (v + w x r).
    const Vector3d r_old = rnd.vec(-1, 1);
    const Vector3d v_old = b.linear_velocity + b.angular_velocity.cross(r_old);
    const Vector3d v_new = t.linear_velocity + t.angular_velocity.cross(T.rotation() * r_old);
    expectVecNear(v_new, T.rotation() * v_old, kTol);
  }
}

// ---------------------------------------------------------------------------------------------
// ContactSpace::K = sum over movable bodies of I3/m - [r]x Iw^-1 [r]x.
TEST(ContactSpaceK, SphereOnGroundHasDiagonalK) {
  // Sphere m = 2, R = 0.5, I = 2/5 m R^2 = 0.2, centre (0, 0.5, 0), contact at the origin:
  // r = (0, -0.5, 0). For isotropic I: -[r]x [r]x / I = (|r|^2 I3 - r r^T) / I, so
  // K = diag(1/m + R^2/I, 1/m, 1/m + R^2/I) = diag(0.5 + 1.25, 0.5, 1.75).
  cr::BodyState ground = box(0.0, Vector3d::Zero());
  ground.id = "ground";
  cr::BodyState ball = box(2.0, Vector3d::Constant(0.2));
  ball.position = Vector3d(0, 0.5, 0);
  const cr::RigidBody a = cr::makeRigidBody(ground), b = cr::makeRigidBody(ball);
  const cr::ContactSpace cs(a, b, Vector3d::Zero());
  expectVecNear(cs.r_b, Vector3d(0, -0.5, 0), kTol);
  expectMatNear(cs.K, Vector3d(1.75, 0.5, 1.75).asDiagonal().toDenseMatrix(), kTol);
  // Swapping the roles gives the same K (it is a sum over the movable bodies).
  const cr::ContactSpace swapped(b, a, Vector3d::Zero());
  expectMatNear(swapped.K, cs.K, kTol);
}

TEST(ContactSpaceK, TwoBodiesOffCentreHandValue) {
  // Body a: m = 1, I = identity, com at origin, r_a = p - c_a = (1, 0, 0).
  // Body b: m = 2, I = 2 * identity, com at (1, 1, 0), r_b = (0, -1, 0).
  // For isotropic I = k I3: -[r]x I^-1 [r]x = (|r|^2 I3 - r r^T) / k. So
  // a: 1 * I3 + (I3 - diag(1, 0, 0)) / 1 = diag(1, 2, 2);
  // b: 0.5 * I3 + (I3 - diag(0, 1, 0)) / 2 = diag(1, 0.5, 1);  K = diag(2, 2.5, 3).
  cr::BodyState A = box(1.0, Vector3d::Constant(1.0));
  cr::BodyState B = box(2.0, Vector3d::Constant(2.0));
  B.position = Vector3d(1, 1, 0);
  const cr::ContactSpace cs(cr::makeRigidBody(A), cr::makeRigidBody(B), Vector3d(1, 0, 0));
  expectMatNear(cs.K, Vector3d(2.0, 2.5, 3.0).asDiagonal().toDenseMatrix(), kTol);
}

TEST(ContactSpaceK, ExplicitFormulaSymmetricPositiveDefiniteAndMapsImpulseToVelocityChange) {
  Random rnd(5);
  for (int k = 0; k < 100; ++k) {
    cr::BodyState A = rnd.body(), B = rnd.body();
    if (k % 4 == 0) A.mass = 0.0;  // one immovable body
    const Vector3d p = rnd.vec(-1, 1);
    cr::RigidBody a = cr::makeRigidBody(A), b = cr::makeRigidBody(B);
    const cr::ContactSpace cs(a, b, p);
    // Explicit formula, from the body states.
    const auto skew = [](const Vector3d& r) {
      Matrix3d s;
      s << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
      return s;
    };
    Matrix3d K = Matrix3d::Zero();
    for (const cr::BodyState* s : {&A, &B}) {
      if (s->mass == 0.0) continue;
      const Matrix3d R = s->orientation.toRotationMatrix();
      const Matrix3d rx = skew(p - (s->position + R * s->com));
      K += Matrix3d::Identity() / s->mass - rx * (R * s->inertia.inverse() * R.transpose()) * rx;
    }
    const double scale = K.norm();
    expectMatNear(cs.K, K, kTol * scale);
    expectMatNear(cs.K, cs.K.transpose(), 1e-12 * scale);
    const Eigen::SelfAdjointEigenSolver<Matrix3d> eig(cs.K);
    EXPECT_GT(eig.eigenvalues().minCoeff(), 0.0);
    // Definition: +P on b and -P on a at p changes u by K P.
    const Vector3d P = rnd.vec(-1, 1);
    const Vector3d u0 = cs.relativeVelocity(a, b);
    cs.applyImpulse(a, b, P);
    expectVecNear(cs.relativeVelocity(a, b) - u0, cs.K * P, kTol * std::max(1.0, scale));
  }
}

// ---------------------------------------------------------------------------------------------
TEST(TangentBasis, OrthonormalAndRightHanded) {
  Random rnd(9);
  std::vector<Vector3d> normals = {Vector3d::UnitX(),
                                   Vector3d::UnitY(),
                                   Vector3d::UnitZ(),
                                   -Vector3d::UnitX(),
                                   -Vector3d::UnitY(),
                                   -Vector3d::UnitZ(),
                                   Vector3d(1, 1, 1).normalized(),
                                   Vector3d(0.57735, 0.57735, 0.57735027).normalized(),
                                   Vector3d(1e-12, 1, -1e-12).normalized()};
  for (int k = 0; k < 200; ++k) normals.push_back(rnd.unit());
  for (const Vector3d& n : normals) {
    SCOPED_TRACE(n.transpose());
    Vector3d t1, t2;
    cr::tangentBasis(n, t1, t2);
    EXPECT_NEAR(t1.norm(), 1.0, 1e-12);
    EXPECT_NEAR(t2.norm(), 1.0, 1e-12);
    EXPECT_NEAR(t1.dot(n), 0.0, 1e-12);
    EXPECT_NEAR(t2.dot(n), 0.0, 1e-12);
    EXPECT_NEAR(t1.dot(t2), 0.0, 1e-12);
    // (t1, t2, n) right-handed: t1 x t2 = n, det [t1 t2 n] = +1.
    expectVecNear(t1.cross(t2), n, 1e-12);
    Matrix3d M;
    M << t1, t2, n;
    EXPECT_NEAR(M.determinant(), 1.0, 1e-12);
  }
}

}  // namespace
