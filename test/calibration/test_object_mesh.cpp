// The object file's mesh shape (object_model.h, object_file.h, stl_file.h): a box given as a mesh
// (inline, binary STL, ASCII STL) is the box. Independent references: the box's inertia in closed
// form (and rotated, R I R'), its lowest corner by brute force over the corners, and the box
// itself through the calibration (the predicted landing, the extracted landing and a fit of e and
// mu on the same noisy landings must not see the difference). Bad meshes: errors naming the file
// and the key.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>

#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/identification.h"
#include "collision_response/calibration/identify_program.h"
#include "collision_response/calibration/landing_extraction.h"
#include "collision_response/calibration/landing_prediction.h"
#include "collision_response/calibration/object_file.h"
#include "collision_response/calibration/stl_file.h"
#include "collision_response/core/worker_pool.h"
#include "synthetic_recordings.h"

using namespace collision_response;
using namespace collision_response::calibration;
using namespace collision_response::calibration::test;
namespace fs = std::filesystem;

namespace {

/// The box's corners in a scrambled order (the mesh's indices are not the box's corner numbers)
/// and its 12 triangles, wound outward (or inward), rotated by R.
detection::Shape boxMesh(const Eigen::Vector3d& size, bool outward = true,
                         const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  const int order[8] = {5, 2, 7, 0, 3, 6, 1, 4};  // mesh vertex v is box corner order[v]
  int vertex_of[8];
  detection::Shape mesh;
  mesh.type = detection::Shape::Type::kMesh;
  for (int v = 0; v < 8; ++v) {
    const int k = order[v];
    vertex_of[k] = v;
    mesh.vertices.push_back(
        R * (0.5 * Eigen::Vector3d((k & 1 ? 1 : -1) * size.x(), (k & 2 ? 1 : -1) * size.y(),
                                   (k & 4 ? 1 : -1) * size.z())));
  }
  for (int axis = 0; axis < 3; ++axis) {
    for (int side = 0; side < 2; ++side) {
      const int j = 1 << ((axis + 1) % 3), l = 1 << ((axis + 2) % 3), base = side << axis;
      const int quad[4] = {base, base | j, base | j | l, base | l};  // a cycle round the face
      for (int t = 0; t < 2; ++t) {
        std::array<int, 3> tri{vertex_of[quad[0]], vertex_of[quad[1 + t]], vertex_of[quad[2 + t]]};
        const Eigen::Vector3d a = mesh.vertices[tri[0]], b = mesh.vertices[tri[1]],
                              c = mesh.vertices[tri[2]];
        if (((b - a).cross(c - a).dot(a + b + c) > 0.0) != outward) std::swap(tri[1], tri[2]);
        mesh.triangles.push_back(tri);
      }
    }
  }
  return mesh;
}

std::string flow(const detection::Shape& mesh) {
  std::ostringstream out;
  out.precision(17);
  out << "shape: {type: mesh, vertices: [";
  for (std::size_t k = 0; k < mesh.vertices.size(); ++k) {
    const auto& v = mesh.vertices[k];
    out << (k ? ", " : "") << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
  }
  out << "], triangles: [";
  for (std::size_t k = 0; k < mesh.triangles.size(); ++k) {
    const auto& t = mesh.triangles[k];
    out << (k ? ", " : "") << "[" << t[0] << ", " << t[1] << ", " << t[2] << "]";
  }
  out << "]}\n";
  return out.str();
}

const std::string kRest = "mass: 0.37\nmaterial_a: cube\nmaterial_b: floor\n";

Eigen::Matrix3d boxInertia(const Eigen::Vector3d& s, double m) {
  return Eigen::Vector3d(m / 12 * (s.y() * s.y() + s.z() * s.z()),
                         m / 12 * (s.x() * s.x() + s.z() * s.z()),
                         m / 12 * (s.x() * s.x() + s.y() * s.y()))
      .asDiagonal();
}

TEST(ObjectMesh, BoxAsMeshHasTheBoxInertiaLowestPointAndLength) {
  const Eigen::Vector3d size(0.1, 0.2, 0.3);
  const double m = 1.7;
  for (bool outward : {true, false}) {
    const detection::Shape mesh = boxMesh(size, outward);
    ASSERT_EQ(meshProblem(mesh), "");
    EXPECT_TRUE(uniformInertia(mesh, m).isApprox(boxInertia(size, m), 1e-14))
        << uniformInertia(mesh, m);
    EXPECT_NEAR(meshVolume(mesh).volume, 0.1 * 0.2 * 0.3, 1e-17);
    EXPECT_LT(meshVolume(mesh).centroid.norm(), 1e-17);
  }
  EXPECT_DOUBLE_EQ(lengthScale(boxMesh(size)), 0.15);
  // Rotated: the off-diagonal terms, R I R'.
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  EXPECT_TRUE(uniformInertia(boxMesh(size, true, R), m)
                  .isApprox(R * boxInertia(size, m) * R.transpose(), 1e-14));
  // The lowest point: the lowest corner, found by brute force.
  std::mt19937 rng(3);
  std::normal_distribution<double> n;
  const detection::Shape mesh = boxMesh(size);
  for (int k = 0; k < 20; ++k) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
    const Eigen::Vector3d p(n(rng), n(rng), n(rng));
    double lowest = 1e9;
    for (int c = 0; c < 8; ++c)
      lowest = std::min(lowest, (p + q * (0.5 * Eigen::Vector3d((c & 1 ? 1 : -1) * size.x(),
                                                                (c & 2 ? 1 : -1) * size.y(),
                                                                (c & 4 ? 1 : -1) * size.z())))
                                    .z());
    EXPECT_NEAR(lowestPointHeight(mesh, p, q), lowest, 1e-15);
  }
}

class ObjectMeshFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("object_mesh_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "parts");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string write(const std::string& name, const std::string& text) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }
  /// The message of loadObjectModel(path)'s error ("" if none).
  static std::string error(const std::string& path) {
    try {
      loadObjectModel(path);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

/// The mesh's triangles, each with its own three corners, as STL stores them, scaled by `scale`.
std::string binaryStl(const detection::Shape& mesh, double scale) {
  std::string out(80, ' ');
  auto put32 = [&](std::uint32_t u) {
    for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((u >> (8 * i)) & 0xff));
  };
  auto putFloat = [&](double x) {
    const float f = static_cast<float>(x);
    std::uint32_t u;
    std::memcpy(&u, &f, 4);
    put32(u);
  };
  put32(static_cast<std::uint32_t>(mesh.triangles.size()));
  for (const auto& t : mesh.triangles) {
    for (int i = 0; i < 3; ++i) putFloat(0.0);  // the normal, ignored
    for (int v : t)
      for (int i = 0; i < 3; ++i) putFloat(scale * mesh.vertices[v][i]);
    out += std::string(2, '\0');
  }
  return out;
}

std::string asciiStl(const detection::Shape& mesh, double scale) {
  std::ostringstream out;
  out << "solid cube\n";
  for (const auto& t : mesh.triangles) {
    out << "  facet normal 0 0 0\n    outer loop\n";
    for (int v : t)
      out << "      vertex " << scale * mesh.vertices[v].x() << " " << scale * mesh.vertices[v].y()
          << " " << scale * mesh.vertices[v].z() << "\n";
    out << "    endloop\n  endfacet\n";
  }
  out << "endsolid cube\n";
  return out.str();
}

TEST_F(ObjectMeshFiles, InlineAndStlCubesAreTheBoxCube) {
  // A side exact in float and in millimetres: the STL's floats lose nothing.
  const double side = 0.125;
  const detection::Shape mesh = boxMesh(Eigen::Vector3d::Constant(side));
  const Eigen::Matrix3d box = boxInertia(Eigen::Vector3d::Constant(side), 0.37);
  write("parts/cube_binary.stl", binaryStl(mesh, 1000.0));
  write("parts/cube_ascii.stl", asciiStl(mesh, 1000.0));
  for (const std::string& shape :
       {flow(mesh), std::string("shape: {type: mesh, file: parts/cube_binary.stl, scale: 0.001}\n"),
        std::string("shape: {type: mesh, file: parts/cube_ascii.stl, scale: 0.001}\n")}) {
    SCOPED_TRACE(shape.substr(0, 60));
    const ObjectModel o = loadObjectModel(write("cube.yaml", shape + kRest));
    ASSERT_EQ(o.shape.type, detection::Shape::Type::kMesh);
    EXPECT_EQ(o.shape.vertices.size(), 8u);  // STL's repeated corners merged
    EXPECT_EQ(o.shape.triangles.size(), 12u);
    EXPECT_TRUE(o.inertia.isApprox(box, 1e-14)) << o.inertia;
    EXPECT_DOUBLE_EQ(lengthScale(o.shape), side / 2);
  }
}

TEST_F(ObjectMeshFiles, BadMeshesNameTheFileAndKey) {
  const detection::Shape good = boxMesh(Eigen::Vector3d(0.1, 0.1, 0.1));
  auto expect = [&](const std::string& yaml, const std::string& message) {
    const std::string path = write("bad.yaml", yaml + kRest);
    const std::string e = error(path);
    EXPECT_NE(e.find(path + ": " + message), std::string::npos) << e << "\nwanted: " << message;
  };
  detection::Shape m = good;
  m.vertices[3].x() = std::numeric_limits<double>::quiet_NaN();
  expect(flow(m), "shape.vertices[3][0]: must be finite");
  m = good;
  m.triangles[5][1] = 8;
  expect(flow(m), "shape.triangles[5]: index 8 is not a vertex (0..7)");
  m = good;
  m.triangles[5][1] = m.triangles[5][0];
  expect(flow(m), "shape.triangles[5]: repeats a vertex");
  m = good;
  m.triangles.pop_back();
  expect(flow(m), "shape.triangles: the mesh is open: edge ");
  m = good;
  std::swap(m.triangles[4][1], m.triangles[4][2]);  // wound inward, its neighbours outward
  expect(flow(m), "shape.triangles[4]: its edge ");
  m = good;
  m.vertices.push_back(Eigen::Vector3d(1, 1, 1));
  expect(flow(m), "shape.vertices[8]: is in no triangle");
  m.vertices.resize(3);
  m.triangles = {{0, 1, 2}};
  expect(flow(m), "shape.vertices: a closed mesh needs at least 4 vertices, not 3");
  expect(
      "shape: {type: mesh, vertices: [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "
      "triangles: [[0, 1, 2.5]]}\n",
      "shape.triangles[0][2]: must be an integer vertex index, not '2.5'");
  expect("shape: {type: mesh, vertices: [[0, 0, 0], [1, 0]], triangles: []}\n",
         "shape.vertices[1]: must be [a, b, c]");
  m = good;
  m.vertices[0] *= 1e200;
  expect(flow(m), "shape.vertices: too large (the solid's volume integrals overflow)");
  m = good;
  for (auto& v : m.vertices) v.z() *= 1e-12;  // flat: a square of two sheets
  expect(flow(m), "shape.triangles: the mesh encloses no volume");
  for (auto& v : m.vertices) v.z() = 0.0;  // exactly flat: no volume at all
  expect(flow(m), "shape.triangles: the mesh encloses no volume");
  // Uniform density needs the centroid at the origin; with inertia given it is the user's word.
  m = good;
  for (auto& v : m.vertices) v.x() += 0.01;
  expect(flow(m), "shape: the mesh's centroid (0.01");
  EXPECT_EQ(error(write("given.yaml", flow(m) + "inertia: [1e-3, 1e-3, 1e-3]\n" + kRest)), "");
  expect("shape: {type: mesh, file: parts/none.stl}\n", "shape.file: ");
  EXPECT_NE(error(write("x.yaml", "shape: {type: mesh, file: parts/none.stl}\n" + kRest))
                .find("parts/none.stl: cannot read"),
            std::string::npos);
  EXPECT_NE(error(write("d.yaml", "shape: {type: mesh, file: parts}\n" + kRest))
                .find("d.yaml: shape.file: "),
            std::string::npos);
  EXPECT_NE(error((dir_ / "d.yaml").string()).find("parts: cannot read (not a regular file)"),
            std::string::npos);
  expect("shape: {type: mesh, file: a.stl, vertices: [[0, 0, 0]]}\n",
         "shape.file: give either file or vertices and triangles, not both");
  // A truncated binary STL is not binary, and not ASCII either; an ASCII one with a bad vertex.
  write("parts/cut.stl", binaryStl(good, 1.0).substr(0, 84 + 50 * 5 + 20));
  expect("shape: {type: mesh, file: parts/cut.stl}\n", "shape.file: ");
  EXPECT_NE(error(write("y.yaml", "shape: {type: mesh, file: parts/cut.stl}\n" + kRest))
                .find("cut.stl: neither a binary STL"),
            std::string::npos);
  std::string ascii = asciiStl(good, 1.0);
  ascii.replace(ascii.find("vertex ") + 7, 1, "x");
  write("parts/bad.stl", ascii);
  EXPECT_NE(error(write("z.yaml", "shape: {type: mesh, file: parts/bad.stl}\n" + kRest))
                .find("bad.stl:4: 'vertex' needs three numbers"),
            std::string::npos)
      << error((dir_ / "z.yaml").string());
  // An open STL (a triangle missing) is checked like an inline mesh, naming the STL.
  detection::Shape open = good;
  open.triangles.pop_back();
  write("parts/open.stl", binaryStl(open, 1.0));
  expect("shape: {type: mesh, file: parts/open.stl}\n", "shape.file: ");
  EXPECT_NE(error(write("w.yaml", "shape: {type: mesh, file: parts/open.stl}\n" + kRest))
                .find("open.stl: shape.triangles: the mesh is open"),
            std::string::npos);
}

// The shipped meshes/hand.stl (ASCII, mm): a prism 140 mm along y over a hexagon, the 80 x 60 mm
// rectangle (x in +-40, z in +-30) without two 15 mm corner triangles at z = -30: area 4575 mm^2,
// centroid z = 2 * 112.5 * 25 / 4575 mm (the rectangle's at 0, each triangle's at -25).
TEST_F(ObjectMeshFiles, ShippedHandStl) {
  const detection::Shape hand = readStl(std::string(MESHES_DIR) + "/hand.stl", 0.001);
  EXPECT_EQ(hand.vertices.size(), 12u);
  EXPECT_EQ(hand.triangles.size(), 20u);
  EXPECT_EQ(meshProblem(hand), "");
  const MeshVolume v = meshVolume(hand);
  EXPECT_NEAR(v.volume, 4575e-6 * 0.14, 1e-15);
  EXPECT_NEAR(v.centroid.z(), 2 * 112.5 * 25 / 4575 * 1e-3, 1e-15);
  EXPECT_NEAR(v.centroid.x(), 0.0, 1e-15);
  EXPECT_NEAR(v.centroid.y(), 0.0, 1e-15);
  // Its centroid is 1.2 mm off its origin: uniform density would move the centre of mass.
  const std::string yaml =
      "shape: {type: mesh, file: " + std::string(MESHES_DIR) + "/hand.stl, scale: 0.001}\n";
  EXPECT_NE(error(write("hand.yaml", yaml + kRest)).find(", 0.00122951) m is not the origin"),
            std::string::npos)
      << error((dir_ / "hand.yaml").string());
  EXPECT_EQ(error(write("hand2.yaml", yaml + "inertia: [1e-3, 1e-3, 1e-3]\n" + kRest)), "");
}

// identify end to end (object file -> CSV recordings -> ~materials YAML): the synthetic cube as a
// box and as a binary STL give the same file, apart from the object file's name.
TEST_F(ObjectMeshFiles, IdentifyProgramWithAnStlObject) {
  std::mt19937 rng(31), noise(32);
  std::vector<std::string> csv;
  while (csv.size() < 8) {
    const PoseTrack truth = trueToss(rng, 0.4, 0.25, core::ImpactLaw::kStronge);
    if (truth.size() < 30) continue;
    const PoseTrack track = noisy(truth, noise, 3e-4, 3e-3);
    if (!extractLandings(track, syntheticCube().shape, 0.0).front().ok) continue;
    std::ostringstream out;
    out.precision(10);
    out << "t,x,y,z,qw,qx,qy,qz\n";
    for (int k = 0; k < track.size(); ++k) {
      const auto& p = track.position[k];
      const auto& q = track.orientation[k];
      out << track.time[k] << "," << p.x() << "," << p.y() << "," << p.z() << "," << q.w() << ","
          << q.x() << "," << q.y() << "," << q.z() << "\n";
    }
    csv.push_back(write("toss_" + std::to_string(csv.size()) + ".csv", out.str()));
  }
  write("parts/cube.stl", binaryStl(boxMesh(Eigen::Vector3d::Constant(0.1048)), 1.0));
  const std::string rest = kRest + "floor_height: 0.0\n";
  std::string text[2];
  int i = 0;
  for (const std::string& object :
       {write("box.yaml", "shape: {type: box, size: [0.1048, 0.1048, 0.1048]}\n" + rest),
        write("mesh.yaml", "shape: {type: mesh, file: parts/cube.stl}\n" + rest)}) {
    IdentifyArguments a;
    a.inputs.push_back({object, csv, {}});
    a.output = (dir_ / ("out_" + std::to_string(i) + ".yaml")).string();
    a.folds = 0;
    a.threads = 2;
    a.quiet = true;
    runIdentify(a, BagReader(), [](const std::string&) {});
    std::ifstream in(a.output);
    std::stringstream s;
    s << in.rdbuf();
    text[i++] = s.str();
  }
  const auto entry = text[1].find("  - {a: \"cube\", b: \"floor\", restitution: ");
  ASSERT_NE(entry, std::string::npos) << text[1];
  double e = 0.0, mu = 0.0;
  ASSERT_EQ(std::sscanf(text[1].c_str() + entry + 41, "%lf, static_friction: %lf", &e, &mu), 2)
      << text[1];
  EXPECT_NEAR(e, 0.4, 0.03);  // the truth, from 8 noisy landings
  EXPECT_NEAR(mu, 0.25, 0.03);
  const auto line = [](const std::string& s, std::size_t at) {
    return s.substr(at, s.find('\n', at) - at);
  };
  EXPECT_EQ(line(text[0], text[0].find("  - {a:")), line(text[1], entry));
  EXPECT_EQ(line(text[0], text[0].find("#   restitution")),
            line(text[1], text[1].find("#   restitution")));
}

/// The cube of the synthetic recordings, as a box and as a mesh.
std::pair<ObjectModel, ObjectModel> boxAndMeshCube() {
  const ObjectModel box = syntheticCube();
  ObjectModel mesh = box;
  mesh.shape = boxMesh(Eigen::Vector3d::Constant(box.shape.dimensions[0]));
  mesh.inertia = uniformInertia(mesh.shape, mesh.mass);
  return {box, mesh};
}

// The landings of noisy synthetic tosses, extracted with either shape, predicted with either
// shape under two laws: the same, to round-off (the floor meets the cube at its corners either
// way; only the order of the corners differs).
TEST(ObjectMesh, MeshCubeLandsAsTheBoxCube) {
  const auto [box, mesh] = boxAndMeshCube();
  std::mt19937 rng(7), noise(8);
  int compared = 0;
  for (int toss = 0; toss < 400 && compared < 8; ++toss) {
    const PoseTrack truth = trueToss(rng, 0.4, 0.25, core::ImpactLaw::kStronge);
    if (truth.size() < 30) continue;
    const PoseTrack recorded = noisy(truth, noise, 3e-4, 3e-3);
    const Extraction xb = extractLandings(recorded, box.shape, 0.0).front();
    const Extraction xm = extractLandings(recorded, mesh.shape, 0.0).front();
    ASSERT_EQ(xb.ok, xm.ok);
    if (!xb.ok) continue;
    ASSERT_EQ(xb.landing.contact_frame, xm.landing.contact_frame);
    EXPECT_EQ(xb.landing.t_before, xm.landing.t_before);
    EXPECT_EQ(xb.landing.t_after, xm.landing.t_after);
    for (core::ImpactLaw law : {core::ImpactLaw::kStronge, core::ImpactLaw::kNewton}) {
      PredictionOptions options;
      options.law = law;
      const LandingPredictor pb(box, options), pm(mesh, options);
      const Coefficients c{0.4, 0.25, 0.25, 1.0};
      const MotionState b = pb.predict(xb.landing, c), m = pm.predict(xb.landing, c);
      const double speed = xb.landing.before.linear_velocity.norm();
      EXPECT_LT((b.linear_velocity - m.linear_velocity).norm(), 1e-9 * speed);
      EXPECT_LT((b.angular_velocity - m.angular_velocity).norm() * 0.0524, 1e-9 * speed);
      EXPECT_LT((b.position - m.position).norm(), 1e-10);
      EXPECT_LT((pb.residual(xb.landing, c) - pm.residual(xb.landing, c)).norm(), 1e-8);
    }
    ++compared;
  }
  EXPECT_EQ(compared, 8);
}

// A short fit of e and mu on the same 8 noisy landings: the box and the mesh cube agree.
TEST(ObjectMesh, IdentifyFitsTheMeshCubeAsTheBoxCube) {
  const auto [box, mesh] = boxAndMeshCube();
  std::mt19937 rng(17), noise(18);
  std::vector<ObjectLandings> as_box{{box, {}}}, as_mesh{{mesh, {}}};
  while (as_box[0].landings.size() < 8) {
    const PoseTrack truth = trueToss(rng, 0.4, 0.25, core::ImpactLaw::kStronge);
    if (truth.size() < 30) continue;
    const Extraction x = extractLandings(noisy(truth, noise, 3e-4, 3e-3), box.shape, 0.0).front();
    if (!x.ok) continue;
    as_box[0].landings.push_back(x.landing);
    as_mesh[0].landings.push_back(x.landing);
  }
  IdentificationOptions o;
  o.starts = 1;
  core::WorkerPool pool(2);
  const IdentificationResult fb = identifyCoefficients(as_box, o, pool);
  const IdentificationResult fm = identifyCoefficients(as_mesh, o, pool);
  ASSERT_EQ(fb.estimates.size(), fm.estimates.size());
  for (std::size_t k = 0; k < fb.estimates.size(); ++k) {
    SCOPED_TRACE(fb.estimates[k].name);
    EXPECT_NEAR(fb.estimates[k].value, fm.estimates[k].value, 1e-6);
    EXPECT_NEAR(fb.estimates[k].std_dev, fm.estimates[k].std_dev, 1e-4 * fb.estimates[k].std_dev);
  }
  // And the fit is a fit: near the true values (8 noisy landings).
  EXPECT_NEAR(fm.estimates[0].value, 0.4, 0.05);
  EXPECT_NEAR(fm.estimates[1].value, 0.25, 0.05);
}

// The real cube tosses (the first 40), the floor found from the object at rest: the same landings
// and the same predictions (at e 0.34, mu 0.2) with the cube as a box and as a mesh. (A fit on
// these real landings is not compared: it moves by more than its round-off, e 0.291 -> 0.279 on 22
// landings when the box's own inertia changes by 4e-16, so only the synthetic fit above is.)
TEST(ObjectMesh, RealTossesMeshCubeAsTheBoxCube) {
  ObjectModel box;
  box.source = "cube";
  box.shape.type = detection::Shape::Type::kBox;
  box.shape.dimensions.assign(3, 0.1048);
  box.mass = 0.37;
  box.inertia = uniformInertia(box.shape, box.mass);
  ObjectModel mesh = box;
  mesh.shape = boxMesh(Eigen::Vector3d::Constant(0.1048));
  mesh.inertia = uniformInertia(mesh.shape, mesh.mass);
  std::vector<Landing> landings;
  const LandingPredictor pb(box, {}), pm(mesh, {});
  const Coefficients c{0.34, 0.2, 0.2, 1.0};
  double worst = 0.0;
  for (const auto& t : readCsvTracks(TOSS_DATA)) {
    if (t.number >= 40) break;
    const Extraction xb = extractLandings(t.track, box.shape, std::nullopt).front();
    const Extraction xm = extractLandings(t.track, mesh.shape, std::nullopt).front();
    ASSERT_EQ(xb.ok, xm.ok);
    if (!xb.ok) continue;
    EXPECT_EQ(xb.landing.contact_frame, xm.landing.contact_frame);
    EXPECT_NEAR(xb.landing.table, xm.landing.table, 1e-15);
    const LandingResidual rb = pb.residual(xb.landing, c), rm = pm.residual(xm.landing, c);
    worst = std::max(worst, (rb - rm).norm());
    landings.push_back(xb.landing);
  }
  EXPECT_LT(worst, 1e-12);  // dimensionless residuals of about 0.1 (relative to the speed)
  EXPECT_GE(landings.size(), 15u);
}

}  // namespace
