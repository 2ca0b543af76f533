// readBagPoseTrack() (ros/bag_recording.h), without a master: the committed fixture
// (test/data/cube_tosses/tosses.bag, six real cube tosses on /tf and as PoseStamped) against the
// CSV it was made from, read here independently; a tf chain (world -> table -> cube, static and
// moving links) against the pose composed by hand; and bad recordings, each an InvalidInput
// naming the bag and the topic or frames.
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <sensor_msgs/JointState.h>
#include <tf2_msgs/TFMessage.h>
#include <zlib.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "collision_response/core/errors.h"
#include "collision_response/ros/bag_recording.h"

using collision_response::BagSource;
using collision_response::readBagJointTrack;
using collision_response::readBagPoseTrack;
using collision_response::calibration::JointTrack;
using collision_response::calibration::PoseTrack;
using collision_response::core::InvalidInput;

namespace {

// The fixture's tosses and their start times (test/data/cube_tosses/README.md): the k-th listed
// toss's CSV time t is stamped 100 + 10 k + t.
const std::vector<int> kFixtureTosses{4, 32, 43, 44, 46, 48};
double fixtureStart(int k) {
  return 100.0 + 10.0 * k;
}

struct CsvRow {
  double t, x, y, z, qw, qx, qy, qz;
};

/// The rows of the given tosses, from the gzip-compressed CSV (toss,t,x,y,z,qw,qx,qy,qz).
std::map<int, std::vector<CsvRow>> readCsv(const std::vector<int>& tosses) {
  std::map<int, std::vector<CsvRow>> rows;
  gzFile file = gzopen(TOSS_DATA, "rb");
  if (file == nullptr) {
    ADD_FAILURE() << "cannot open " << TOSS_DATA;
    return rows;
  }
  char line[512];
  gzgets(file, line, sizeof line);  // header
  while (gzgets(file, line, sizeof line) != nullptr) {
    int toss = 0;
    CsvRow r{};
    if (std::sscanf(line, "%d,%lf,%lf,%lf,%lf,%lf,%lf,%lf,%lf", &toss, &r.t, &r.x, &r.y, &r.z,
                    &r.qw, &r.qx, &r.qy, &r.qz) != 9) {
      ADD_FAILURE() << "malformed line: " << line;
      break;
    }
    for (int wanted : tosses) {
      if (toss == wanted) rows[toss].push_back(r);
    }
  }
  gzclose(file);
  return rows;
}

/// The track against the fixture's tosses in the CSV: the same number of samples, each at its
/// stamp, position to 1e-9 m, orientation the CSV's normalized quaternion up to sign to 1e-9.
void expectFixtureTrack(const PoseTrack& track) {
  const std::map<int, std::vector<CsvRow>> csv = readCsv(kFixtureTosses);
  std::size_t total = 0;
  for (const auto& [toss, rows] : csv) total += rows.size();
  ASSERT_EQ(total, 576u);  // the fixture's README
  ASSERT_EQ(track.size(), static_cast<int>(total));
  ASSERT_EQ(track.position.size(), total);
  ASSERT_EQ(track.orientation.size(), total);
  int i = 0;
  for (std::size_t k = 0; k < kFixtureTosses.size(); ++k) {
    for (const CsvRow& r : csv.at(kFixtureTosses[k])) {
      SCOPED_TRACE("toss " + std::to_string(kFixtureTosses[k]) + ", t = " + std::to_string(r.t));
      EXPECT_NEAR(track.time[i], fixtureStart(static_cast<int>(k)) + r.t, 1e-9);
      EXPECT_NEAR(track.position[i].x(), r.x, 1e-9);
      EXPECT_NEAR(track.position[i].y(), r.y, 1e-9);
      EXPECT_NEAR(track.position[i].z(), r.z, 1e-9);
      const double n = std::sqrt(r.qw * r.qw + r.qx * r.qx + r.qy * r.qy + r.qz * r.qz);
      const Eigen::Quaterniond& q = track.orientation[i];
      const double sign = q.w() * r.qw + q.x() * r.qx + q.y() * r.qy + q.z() * r.qz < 0 ? -1 : 1;
      EXPECT_NEAR(sign * q.w(), r.qw / n, 1e-9);
      EXPECT_NEAR(sign * q.x(), r.qx / n, 1e-9);
      EXPECT_NEAR(sign * q.y(), r.qy / n, 1e-9);
      EXPECT_NEAR(sign * q.z(), r.qz / n, 1e-9);
      ++i;
    }
  }
}

TEST(BagRecording, FixtureOnTfIsTheCsvsTosses) {
  const PoseTrack track = readBagPoseTrack({TOSSES_BAG, "", "world", "cube"});
  expectFixtureTrack(track);
  EXPECT_EQ(track.source, std::string(TOSSES_BAG) + ":/tf world->cube");
}

TEST(BagRecording, FixtureAsPoseStampedIsTheCsvsTosses) {
  expectFixtureTrack(readBagPoseTrack({TOSSES_BAG, "/cube/pose", "world", ""}));
  // Without a frame to check, and the topic named without its leading slash.
  const PoseTrack track = readBagPoseTrack({TOSSES_BAG, "cube/pose", "", ""});
  expectFixtureTrack(track);
  EXPECT_EQ(track.source, std::string(TOSSES_BAG) + ":/cube/pose");
}

// ---------------------------------------------------------------------------------------------
// Bags written here.

std::string tempBag(const std::string& name) {
  static const std::string dir = [] {
    char pattern[] = "/tmp/test_bag_recording.XXXXXX";
    const char* made = mkdtemp(pattern);
    return std::string(made != nullptr ? made : "/tmp");
  }();
  return dir + "/" + name + ".bag";
}

geometry_msgs::TransformStamped transform(double t, const std::string& parent,
                                          const std::string& child, double x, double y, double z,
                                          double qw, double qx, double qy, double qz) {
  geometry_msgs::TransformStamped m;
  m.header.stamp = ::ros::Time(t);
  m.header.frame_id = parent;
  m.child_frame_id = child;
  m.transform.translation.x = x;
  m.transform.translation.y = y;
  m.transform.translation.z = z;
  m.transform.rotation.w = qw;
  m.transform.rotation.x = qx;
  m.transform.rotation.y = qy;
  m.transform.rotation.z = qz;
  return m;
}

/// One TFMessage, received at `received` [s] (default: its first transform's stamp).
void writeTf(rosbag::Bag& bag, const std::string& topic,
             const std::vector<geometry_msgs::TransformStamped>& transforms,
             double received = 0.0) {
  tf2_msgs::TFMessage message;
  message.transforms = transforms;
  bag.write(topic, received > 0.0 ? ::ros::Time(received) : transforms.front().header.stamp,
            message);
}

geometry_msgs::PoseStamped pose(double t, const std::string& frame, double x, double qw,
                                double qx = 0.0) {
  geometry_msgs::PoseStamped m;
  m.header.stamp = ::ros::Time(t);
  m.header.frame_id = frame;
  m.pose.position.x = x;
  m.pose.orientation.w = qw;
  m.pose.orientation.x = qx;
  return m;
}

void expectInvalid(const BagSource& source, const std::string& field, const std::string& says);

const double kC45 = std::sqrt(0.5);  // cos 45 deg = sin 45 deg

// world -> table static (at (1, 2, 0.5), turned 90 deg about z), table -> cube moving: the cube at
// (0.3, 0.1, 0.2) + (0.1 s, 0, 0) in the table, turned by a(s) = 0.2 s rad about the table's x.
// By hand: the table's 90 deg turn about z maps (u, v, w) to (-v, u, w), so the cube's centre is
// (1 - 0.1, 2 + 0.3 + 0.1 s, 0.5 + 0.2); the orientations compose as (c + s k)(ca + sa i) =
// c ca + c sa i + s sa j + s ca k (k i = j), c = s = cos 45 deg.
TEST(BagRecording, StaticChainComposedByHand) {
  const std::string path = tempBag("static_chain");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    writeTf(bag, "/tf_static", {transform(0.5, "world", "table", 1, 2, 0.5, kC45, 0, 0, kC45)});
    for (int i = 0; i < 5; ++i) {
      const double s = 1.0 + i;
      const double a = 0.2 * s;
      writeTf(bag, "/tf",
              {transform(s, "table", "cube", 0.3 + 0.1 * s, 0.1, 0.2, std::cos(a / 2),
                         std::sin(a / 2), 0, 0),
               // another frame, with a broken transform that does not concern the cube
               transform(s, "world", "other", NAN, 0, 0, 1, 0, 0, 0)});
    }
  }
  const PoseTrack track = readBagPoseTrack({path, "", "world", "cube"});
  ASSERT_EQ(track.size(), 5);
  for (int i = 0; i < 5; ++i) {
    const double s = 1.0 + i;
    const double ca = std::cos(0.1 * s), sa = std::sin(0.1 * s);
    EXPECT_NEAR(track.time[i], s, 1e-12);
    EXPECT_NEAR(track.position[i].x(), 0.9, 1e-12);
    EXPECT_NEAR(track.position[i].y(), 2.3 + 0.1 * s, 1e-12);
    EXPECT_NEAR(track.position[i].z(), 0.7, 1e-12);
    const Eigen::Quaterniond& q = track.orientation[i];
    const double sign = q.w() < 0 ? -1.0 : 1.0;
    EXPECT_NEAR(sign * q.w(), kC45 * ca, 1e-12);
    EXPECT_NEAR(sign * q.x(), kC45 * sa, 1e-12);
    EXPECT_NEAR(sign * q.y(), kC45 * sa, 1e-12);
    EXPECT_NEAR(sign * q.z(), kC45 * ca, 1e-12);
  }
}

// A moving middle link: world -> table published at whole seconds, the table at (s, 0, 0) turned
// 90 deg about z; table -> cube fixed at (0.3, 0.1, 0.2) but published at half seconds. tf2
// interpolates the table linearly (exact for this motion): at s the cube is at
// (s - 0.1, 0.3, 0.2), turned 90 deg about z.
TEST(BagRecording, MovingChainInterpolatedAtTheObjectsStamps) {
  const std::string path = tempBag("moving_chain");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    for (int i = 1; i <= 4; ++i) {
      writeTf(bag, "/tf", {transform(i, "world", "table", i, 0, 0, kC45, 0, 0, kC45)});
      writeTf(bag, "/tf", {transform(i + 0.5, "table", "cube", 0.3, 0.1, 0.2, 1, 0, 0, 0)});
    }
  }
  // The last cube sample (4.5 s) is after the table's last (4 s): tf2 would extrapolate.
  try {
    readBagPoseTrack({path, "", "world", "cube"});
    FAIL() << "no error for a sample past the chain's data";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), path + ":/tf world->cube");
    EXPECT_NE(std::string(e.what()).find("4.5 s"), std::string::npos) << e.what();
  }
  {
    rosbag::Bag bag(path, rosbag::bagmode::Append);
    writeTf(bag, "/tf", {transform(5, "world", "table", 5, 0, 0, kC45, 0, 0, kC45)});
  }
  const PoseTrack track = readBagPoseTrack({path, "", "world", "cube"});
  ASSERT_EQ(track.size(), 4);
  for (int i = 0; i < 4; ++i) {
    const double s = 1.5 + i;
    EXPECT_NEAR(track.time[i], s, 1e-12);
    EXPECT_NEAR(track.position[i].x(), s - 0.1, 1e-12);
    EXPECT_NEAR(track.position[i].y(), 0.3, 1e-12);
    EXPECT_NEAR(track.position[i].z(), 0.2, 1e-12);
    const Eigen::Quaterniond& q = track.orientation[i];
    const double sign = q.w() < 0 ? -1.0 : 1.0;
    EXPECT_NEAR(sign * q.w(), kC45, 1e-12);
    EXPECT_NEAR(q.x(), 0.0, 1e-12);
    EXPECT_NEAR(q.y(), 0.0, 1e-12);
    EXPECT_NEAR(sign * q.z(), kC45, 1e-12);
  }
}

// The world frame two links below the tree's root: map -> room (at (1, 0, 0)), room -> world
// (turned 90 deg about z), so the world is at (1, 0, 0) in the map turned 90 deg about z; and
// map -> cube (at (1, 2, 3), not turned). By hand: the cube in the world is R^T (p_cube - p_world)
// with R^T mapping (u, v, w) to (v, -u, w): (2, 0, 3), turned -90 deg about z. A non-finite value
// in map -> room, on the path from the cube to the world, is an error; one in map -> elsewhere is
// not.
TEST(BagRecording, PathThroughACommonParent) {
  for (const bool broken : {false, true}) {
    const std::string path = tempBag(broken ? "common_parent_broken" : "common_parent");
    {
      rosbag::Bag bag(path, rosbag::bagmode::Write);
      for (int i = 1; i <= 3; ++i) {
        const double x = broken && i == 2 ? NAN : 1.0;
        writeTf(bag, "/tf",
                {transform(i, "map", "room", x, 0, 0, 1, 0, 0, 0),
                 transform(i, "room", "world", 0, 0, 0, kC45, 0, 0, kC45),
                 transform(i, "map", "cube", 1, 2, 3, 1, 0, 0, 0),
                 transform(i, "map", "elsewhere", NAN, 0, 0, 1, 0, 0, 0)});
      }
    }
    if (broken) {
      expectInvalid({path, "", "world", "cube"}, path + ":/tf world->cube",
                    "(map->room, header.stamp 2 s): transform.translation.x is not finite");
      continue;
    }
    const PoseTrack track = readBagPoseTrack({path, "", "world", "cube"});
    ASSERT_EQ(track.size(), 3);
    for (int i = 0; i < 3; ++i) {
      EXPECT_NEAR(track.position[i].x(), 2.0, 1e-12);
      EXPECT_NEAR(track.position[i].y(), 0.0, 1e-12);
      EXPECT_NEAR(track.position[i].z(), 3.0, 1e-12);
      const Eigen::Quaterniond& q = track.orientation[i];
      const double sign = q.w() < 0 ? -1.0 : 1.0;
      EXPECT_NEAR(sign * q.w(), kC45, 1e-12);
      EXPECT_NEAR(q.x(), 0.0, 1e-12);
      EXPECT_NEAR(q.y(), 0.0, 1e-12);
      EXPECT_NEAR(sign * q.z(), -kC45, 1e-12);
    }
  }
}

// ---------------------------------------------------------------------------------------------
// Bad recordings: InvalidInput whose field names the bag and the topic or frames, the message
// saying what.

void expectInvalid(const BagSource& source, const std::string& field, const std::string& says) {
  try {
    const PoseTrack track = readBagPoseTrack(source);
    ADD_FAILURE() << "no error; read " << track.size() << " samples";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), field);
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos)
        << e.what() << "\n  should say: " << says;
  }
}

TEST(BagRecording, MissingFile) {
  const std::string path = tempBag("does_not_exist");
  expectInvalid({path, "", "world", "cube"}, path + ":/tf world->cube", "cannot open the bag");
  expectInvalid({path, "/cube/pose", "", ""}, path + ":/cube/pose", "cannot open the bag");
  // A file that is not a bag.
  const std::string text = tempBag("not_a_bag");
  std::FILE* file = std::fopen(text.c_str(), "w");
  ASSERT_NE(file, nullptr);
  std::fputs("toss,t,x,y,z,qw,qx,qy,qz\n", file);
  std::fclose(file);
  expectInvalid({text, "", "world", "cube"}, text + ":/tf world->cube", "cannot open the bag");
}

TEST(BagRecording, MissingTopicOrFrame) {
  expectInvalid({TOSSES_BAG, "/sphere/pose", "", ""}, std::string(TOSSES_BAG) + ":/sphere/pose",
                "no such topic");
  expectInvalid({TOSSES_BAG, "", "world", "sphere"}, std::string(TOSSES_BAG) + ":/tf world->sphere",
                "'sphere'");
  expectInvalid({TOSSES_BAG, "", "map", "cube"}, std::string(TOSSES_BAG) + ":/tf map->cube",
                "'map'");
  expectInvalid({TOSSES_BAG, "", "", "cube"}, std::string(TOSSES_BAG) + ":/tf ->cube",
                "no world frame");
  // A PoseStamped topic in another frame than the one asked for; /tf read as PoseStamped.
  expectInvalid({TOSSES_BAG, "/cube/pose", "map", ""}, std::string(TOSSES_BAG) + ":/cube/pose",
                "header.frame_id is 'world', not 'map'");
  expectInvalid({TOSSES_BAG, "/tf", "", ""}, std::string(TOSSES_BAG) + ":/tf",
                "not geometry_msgs/PoseStamped");
  // Frames that exist but are not connected.
  const std::string path = tempBag("two_trees");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    writeTf(bag, "/tf", {transform(1, "world", "table", 0, 0, 0, 1, 0, 0, 0)});
    writeTf(bag, "/tf", {transform(1, "mocap", "cube", 0, 0, 0, 1, 0, 0, 0)});
  }
  expectInvalid({path, "", "world", "cube"}, path + ":/tf world->cube", "no transform world->cube");
  // A bag without tf.
  const std::string no_tf = tempBag("no_tf");
  {
    rosbag::Bag bag(no_tf, rosbag::bagmode::Write);
    bag.write("/cube/pose", ::ros::Time(1), pose(1, "world", 0, 1));
  }
  expectInvalid({no_tf, "", "world", "cube"}, no_tf + ":/tf world->cube", "no /tf or /tf_static");
}

TEST(BagRecording, NonFiniteOrNonUnitSamples) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  {  // tf: the object's own transform, and a link of its chain
    const std::string path = tempBag("nan_tf");
    {
      rosbag::Bag bag(path, rosbag::bagmode::Write);
      writeTf(bag, "/tf", {transform(1, "world", "cube", 0, 0, 0, 1, 0, 0, 0)});
      writeTf(bag, "/tf", {transform(2, "world", "cube", 0, nan, 0, 1, 0, 0, 0)});
    }
    expectInvalid({path, "", "world", "cube"}, path + ":/tf world->cube",
                  "transform.translation.y is not finite");
    const std::string chain = tempBag("inf_chain");
    {
      rosbag::Bag bag(chain, rosbag::bagmode::Write);
      writeTf(bag, "/tf_static", {transform(1, "world", "table", 0, 0, 0, 1, 0, inf, 0)});
      writeTf(bag, "/tf", {transform(1, "table", "cube", 0, 0, 0, 1, 0, 0, 0)});
    }
    expectInvalid({chain, "", "world", "cube"}, chain + ":/tf world->cube",
                  "transform.rotation.y is not finite");
    const std::string scaled = tempBag("scaled_tf");
    {
      rosbag::Bag bag(scaled, rosbag::bagmode::Write);
      writeTf(bag, "/tf", {transform(1, "world", "cube", 0, 0, 0, 1.1, 0, 0, 0)});
    }
    expectInvalid({scaled, "", "world", "cube"}, scaled + ":/tf world->cube",
                  "not a unit quaternion");
  }
  {  // PoseStamped
    const std::string path = tempBag("nan_pose");
    {
      rosbag::Bag bag(path, rosbag::bagmode::Write);
      bag.write("/cube/pose", ::ros::Time(1), pose(1, "world", 0, 1));
      bag.write("/cube/pose", ::ros::Time(2), pose(2, "world", inf, 1));
    }
    expectInvalid({path, "/cube/pose", "world", ""}, path + ":/cube/pose",
                  "message 1 (header.stamp 2 s): pose.position.x is not finite");
    const std::string scaled = tempBag("scaled_pose");
    {
      rosbag::Bag bag(scaled, rosbag::bagmode::Write);
      bag.write("/cube/pose", ::ros::Time(1), pose(1, "world", 0, 0.6, 0.6));  // norm 0.85
    }
    expectInvalid({scaled, "/cube/pose", "", ""}, scaled + ":/cube/pose", "not a unit quaternion");
  }
}

TEST(BagRecording, TimeGoingBackwards) {
  // Received at 1, 2, 3 s (the bag's order), stamped 1, 2, 1.5 s.
  const std::string path = tempBag("backwards");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    const double stamps[3] = {1.0, 2.0, 1.5};
    for (int i = 0; i < 3; ++i) {
      writeTf(bag, "/tf", {transform(stamps[i], "world", "cube", stamps[i], 0, 0, 1, 0, 0, 0)},
              1.0 + i);
      bag.write("/cube/pose", ::ros::Time(1.0 + i), pose(stamps[i], "world", 0, 1));
    }
  }
  expectInvalid({path, "", "world", "cube"}, path + ":/tf world->cube",
                "time 1.5 s is not after the previous sample's 2 s");
  expectInvalid({path, "/cube/pose", "", ""}, path + ":/cube/pose",
                "time 1.5 s is not after the previous sample's 2 s");
  // A repeated stamp, and an unset one.
  const std::string repeated = tempBag("repeated");
  {
    rosbag::Bag bag(repeated, rosbag::bagmode::Write);
    bag.write("/cube/pose", ::ros::Time(1), pose(1, "world", 0, 1));
    bag.write("/cube/pose", ::ros::Time(2), pose(1, "world", 0, 1));
    bag.write("/unset/pose", ::ros::Time(2), pose(0, "world", 0, 1));
  }
  expectInvalid({repeated, "/cube/pose", "", ""}, repeated + ":/cube/pose", "is not after");
  expectInvalid({repeated, "/unset/pose", "", ""}, repeated + ":/unset/pose", "header.stamp is 0");
}

}  // namespace

// A robot's joint states (readBagJointTrack()): the first message sets the joints' order, later
// ones may list them in another; every position read at its stamp.
namespace {

sensor_msgs::JointState jointState(double t, const std::vector<std::string>& names,
                                   const std::vector<double>& positions) {
  sensor_msgs::JointState m;
  m.header.stamp = ::ros::Time(t);
  m.name = names;
  m.position = positions;
  return m;
}

void expectJointInvalid(const std::string& bag, const std::string& topic, const std::string& field,
                        const std::string& says) {
  try {
    const JointTrack track = readBagJointTrack(bag, topic);
    ADD_FAILURE() << "no error; read " << track.size() << " samples";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), field);
    EXPECT_NE(std::string(e.what()).find(says), std::string::npos)
        << e.what() << "\n  should say: " << says;
  }
}

}  // namespace

TEST(BagRecording, JointStatesInTheFirstMessagesOrder) {
  const std::string path = tempBag("joint_states");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.write("/joint_states", ::ros::Time(1), jointState(1.0, {"shoulder", "elbow"}, {0.1, 0.2}));
    bag.write("/joint_states", ::ros::Time(2), jointState(1.5, {"elbow", "shoulder"}, {0.4, 0.3}));
    bag.write("/joint_states", ::ros::Time(3), jointState(2.0, {"shoulder", "elbow"}, {0.5, 0.6}));
  }
  const JointTrack track = readBagJointTrack(path, "joint_states");
  EXPECT_EQ(track.source, path + ":/joint_states");
  ASSERT_EQ(track.names, (std::vector<std::string>{"shoulder", "elbow"}));
  ASSERT_EQ(track.size(), 3);
  EXPECT_EQ(track.time, (std::vector<double>{1.0, 1.5, 2.0}));
  EXPECT_EQ(track.position[1][0], 0.3);
  EXPECT_EQ(track.position[1][1], 0.4);
  EXPECT_EQ(track.position[2][1], 0.6);
}

TEST(BagRecording, BadJointStates) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::string path = tempBag("bad_joint_states");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    bag.write("/joint_states", ::ros::Time(1), jointState(1.0, {"shoulder", "elbow"}, {0.1, 0.2}));
    bag.write("/joint_states", ::ros::Time(2), jointState(2.0, {"shoulder", "elbow"}, {0.1, nan}));
    bag.write("/cube/pose", ::ros::Time(1), pose(1, "world", 0, 1));
    bag.write("/renamed", ::ros::Time(1), jointState(1.0, {"shoulder", "elbow"}, {0.1, 0.2}));
    bag.write("/renamed", ::ros::Time(2), jointState(2.0, {"shoulder", "wrist"}, {0.1, 0.2}));
    bag.write("/short", ::ros::Time(1), jointState(1.0, {"shoulder", "elbow"}, {0.1}));
    bag.write("/backwards", ::ros::Time(1), jointState(2.0, {"shoulder"}, {0.1}));
    bag.write("/backwards", ::ros::Time(2), jointState(1.0, {"shoulder"}, {0.1}));
  }
  expectJointInvalid(path, "/joint_states", path + ":/joint_states",
                     "message 1 (header.stamp 2 s): the position of joint 'elbow' is not finite");
  expectJointInvalid(path, "/arm/joint_states", path + ":/arm/joint_states", "no such topic");
  expectJointInvalid(path, "/cube/pose", path + ":/cube/pose", "not sensor_msgs/JointState");
  expectJointInvalid(path, "/renamed", path + ":/renamed", "joint 'elbow' (of the first message)");
  expectJointInvalid(path, "/short", path + ":/short", "1 positions for 2 names");
  expectJointInvalid(path, "/backwards", path + ":/backwards", "not after the previous");
}
