#include "toss_data.h"

#include "collision_response/calibration/csv_tracks.h"
#include "collision_response/calibration/object_model.h"

namespace collision_response::bench {

std::vector<TossFrames> readTosses(const std::string& gz_path) {
  std::vector<TossFrames> tosses;
  for (auto& numbered : calibration::readCsvTracks(gz_path)) {
    TossFrames toss;
    static_cast<calibration::PoseTrack&>(toss) = std::move(numbered.track);
    toss.index = numbered.number;
    tosses.push_back(std::move(toss));
  }
  return tosses;
}

detection::Shape cubeShape(const TossedCube& cube) {
  detection::Shape box;
  box.type = detection::Shape::Type::kBox;
  box.dimensions.assign(3, 2.0 * cube.half_width);
  return box;
}

double lowestCornerHeight(const Eigen::Vector3d& position, const Eigen::Quaterniond& orientation,
                          double half_width) {
  TossedCube cube;
  cube.half_width = half_width;
  return calibration::lowestPointHeight(cubeShape(cube), position, orientation);
}

double tableHeight(const TossFrames& toss, double half_width, int rest_frames) {
  TossedCube cube;
  cube.half_width = half_width;
  return calibration::restingFloorHeight(toss, cubeShape(cube), rest_frames);
}

Extraction extractLanding(const TossFrames& toss, const TossedCube& cube,
                          const ExtractionOptions& options) {
  ExtractionOptions first = options;
  first.max_landings = 1;
  Extraction x = calibration::extractLandings(toss, cubeShape(cube), std::nullopt, first).front();
  x.landing.recording = toss.index;
  return x;
}

double cubeEnergy(const CubeState& state, const TossedCube& cube, double gravity_z) {
  return 0.5 * cube.mass * state.linear_velocity.squaredNorm() +
         0.5 * cube.inertia * state.angular_velocity.squaredNorm() -
         cube.mass * gravity_z * state.position.z();
}

}  // namespace collision_response::bench
