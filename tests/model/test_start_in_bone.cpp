// Where a recording's path begins, is the burr already in bone? (model::start_in_bone):
// the immersion depth against the closed form of a flat surface, the tolerance (a voxel,
// or the registration's error), and the first point a lead-in via makes.
#include <gtest/gtest.h>

#include "burrbench/model/experiment.hpp"
#include "test_paper_scenes.hpp"

namespace bm = burrbench::model;

namespace {

constexpr double kSurfaceZ = 1.95;  // the top face of the half-space's bone voxels (centres z < 1.96)
constexpr double kRadius = 0.5;

// Bone below z = 1.95 mm, 0.1 mm voxels; a recording whose stage holds the burr centre
// `depth_mm` below the touch of that surface from t = −1 s on, its force samples from 0.
bm::Experiment experiment(double depth_mm) {
  bm::Experiment e;
  e.samples["S"] = scenes::half_space(40, 40, 40, 0.1, {0, 0, 1}, 1.96);
  bm::AlignedRecording r;
  r.id = "plunge";
  r.sample_id = "S";
  r.radius_mm = kRadius;
  r.t_s = {0, 0.001, 0.002};
  const glm::dvec3 centre(2, 2, kSurfaceZ + kRadius - depth_mm);
  r.stage_rig_mm.t_s = {-1, 0.002};
  r.stage_rig_mm.value = {centre + glm::dvec3(0, 0, 1), centre};  // approaching from 1 mm above
  r.spindle_rpm.t_s = {-1};
  r.spindle_rpm.value = {30000};
  e.recordings.push_back(r);
  return e;
}

}  // namespace

TEST(StartInBone, TheDepthWhereThePathBeginsIsNamedBeyondOneVoxel) {
  const bm::Experiment deep = experiment(0.3);
  const bm::StartInBone s = bm::start_in_bone(deep, deep.recordings[0]);
  EXPECT_EQ(s.t_s, 0);
  // The cap below a flat face: b = the centre's depth below the touch, to the voxels'
  // sampling of the sphere.
  EXPECT_NEAR(s.depth_b_mm, 0.3, 0.01);
  EXPECT_EQ(s.tolerance_mm, 0.1);
  const std::string w = s.text(deep.recordings[0]);
  EXPECT_EQ(w.rfind("Recording plunge: the burr is already 0.", 0), 0u) << w;
  EXPECT_NE(w.find("mm deep in the bone of sample S where its path begins (t = 0 s"), std::string::npos) << w;
  // Half a voxel: a touch at the scanned surface can show that much.
  const bm::Experiment touch = experiment(0.05);
  const bm::StartInBone t = bm::start_in_bone(touch, touch.recordings[0]);
  EXPECT_NEAR(t.depth_b_mm, 0.05, 0.01);
  EXPECT_EQ(t.text(touch.recordings[0]), "");
  // Clear of the bone: nothing.
  const bm::Experiment clear = experiment(-0.2);
  EXPECT_EQ(bm::start_in_bone(clear, clear.recordings[0]).depth_b_mm, 0);
}

TEST(StartInBone, TheRegistrationsErrorWidensTheTolerance) {
  bm::Experiment e = experiment(0.3);
  e.recordings[0].registration.tre_path_max_mm = 0.4;
  const bm::StartInBone s = bm::start_in_bone(e, e.recordings[0]);
  EXPECT_EQ(s.tolerance_mm, 0.4);
  EXPECT_EQ(s.text(e.recordings[0]), "");
  e.recordings[0].registration.tre_path_max_mm = 0.02;  // below a voxel: the voxel holds
  EXPECT_EQ(bm::start_in_bone(e, e.recordings[0]).tolerance_mm, 0.1);
}

TEST(StartInBone, ALeadInViaIsWhereThePathBegins) {
  // The stage logged the approach from 1 mm above; the sensor started with the burr in
  // bone. The replay follows the stage from its first sample, so nothing was cut before.
  bm::Experiment e = experiment(0.3);
  e.recordings[0].via_times = {{bm::Trajectory::Via::kBeforeFirst, -1.0}};
  const bm::StartInBone s = bm::start_in_bone(e, e.recordings[0]);
  EXPECT_EQ(s.t_s, -1.0);
  EXPECT_EQ(s.depth_b_mm, 0);
  EXPECT_EQ(s.text(e.recordings[0]), "");
}
