// A replay on the part of a sample it can reach (reach.hpp) gives the forces, removed
// volumes and sensitivities of a replay on the whole sample, bit for bit, from a fraction
// of its voxels.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "burrbench/model/experiment.hpp"
#include "burrbench/model/reach.hpp"
#include "burrbench/model/replay.hpp"
#include "lumpy_scene.hpp"

namespace bm = burrbench::model;
using Kind = bm::Direction::Kind;

namespace {

constexpr double kR = 1.0;  // burr radius, mm

// A plunge 0.4 mm into the lumpy surface (z ≈ 0.8 mm) near (x0, y0), then a sweep along x.
bm::Trajectory plunge_and_sweep(double x0, double y0, int n = 240) {
  bm::Trajectory tr;
  for (int i = 0; i < n; ++i) {
    const double plunge = std::min(1.0, i / 80.0);
    tr.t_s.push_back(i * 1e-3);
    tr.centre_vol_mm.push_back({x0 + 0.006 * std::max(0, i - 80), y0 + 0.1 * std::sin(0.02 * i),
                                0.8 + kR - 0.4 * plunge});
    tr.omega_vol_rad_s.push_back(4000.0 * glm::dvec3(0.8, 0.0, 0.6));
  }
  return tr;
}

std::vector<bm::Direction> directions(const bm::Trajectory& tr) {
  std::vector<bm::Direction> d{{Kind::kLogAlpha, 1, {}}, {Kind::kLogC1, 1, {}}, {Kind::kLogMu, 1, {}},
                               {Kind::kLogAlpha, 2, {}}, {Kind::kLogC1, 2, {}}, {Kind::kPath, 0, {}}};
  for (std::size_t k = 0; k < tr.t_s.size(); ++k)  // a depth offset: along z
    d.back().dcentre_vol_mm.push_back({0, 0, 1});
  return d;
}

struct Outcome {
  bm::ReplayResult res;
  bm::Sensitivities sens;
};

Outcome replay_on(bm::Volume& vol, const bm::Trajectory& tr) {
  const auto dirs = directions(tr);
  Outcome o;
  bm::ReplayOptions opt;
  opt.directions = &dirs;
  opt.sensitivities = &o.sens;
  opt.moment_sensitivities = true;
  o.res = bm::replay(vol, kR, scenes::two_classes(), tr, opt, true);
  return o;
}

// Bit for bit: the kernel places each voxel by its index in the sample's grid.
void expect_same(const Outcome& whole, const Outcome& cut) {
  double scale = 0;
  for (const auto& s : whole.res.samples) scale = std::max(scale, glm::length(s.contact.force_N));
  ASSERT_GT(scale, 1.0) << "the trajectory must cut bone";
  ASSERT_EQ(whole.res.samples.size(), cut.res.samples.size());
  for (std::size_t k = 0; k < whole.res.samples.size(); ++k) {
    const auto &a = whole.res.samples[k].contact, &b = cut.res.samples[k].contact;
    ASSERT_EQ(a.force_N, b.force_N) << "sample " << k;
    ASSERT_EQ(a.moment_Nmm, b.moment_Nmm) << "sample " << k;
    ASSERT_EQ(a.power_W_mJ_per_s, b.power_W_mJ_per_s) << "sample " << k;
    ASSERT_EQ(a.class_mask, b.class_mask) << "sample " << k;
  }
  EXPECT_EQ(whole.res.removed_mm3, cut.res.removed_mm3);
  EXPECT_EQ(whole.res.friction_energy_mJ, cut.res.friction_energy_mJ);
  EXPECT_EQ(whole.res.steps, cut.res.steps);
  ASSERT_EQ(whole.sens.dforce_N.size(), cut.sens.dforce_N.size());
  for (std::size_t j = 0; j < whole.sens.dforce_N.size(); ++j) {
    ASSERT_EQ(whole.sens.dforce_N[j], cut.sens.dforce_N[j]) << "direction " << j;
    ASSERT_EQ(whole.sens.dmoment_Nmm[j], cut.sens.dmoment_Nmm[j]) << "direction " << j;
  }
  EXPECT_EQ(whole.sens.dremoved_mm3, cut.sens.dremoved_mm3);
  EXPECT_EQ(whole.sens.carried_directions, cut.sens.carried_directions);
}

}  // namespace

TEST(Reach, ACutVolumeHoldsExactlyTheVoxelsOfItsBox) {
  const auto s = scenes::lumpy(20, 0.1, 3);
  const bm::VoxelBox box{{0, 5, 2}, {20, 9, 17}};
  const bm::Volume cut = bm::Volume::from_sample(s, box);
  EXPECT_EQ(cut.box(), box);
  EXPECT_EQ(cut.dims(), (std::array<std::size_t, 3>{20, 4, 15}));
  EXPECT_EQ(cut.voxel_count(), 20u * 4u * 15u);
  EXPECT_EQ(cut.grid_origin_mm(), s.origin_mm);
  EXPECT_NEAR(cut.origin_mm().x, s.origin_mm.x, 1e-15);
  EXPECT_NEAR(cut.origin_mm().y, s.origin_mm.y + 0.5, 1e-15);
  EXPECT_NEAR(cut.origin_mm().z, s.origin_mm.z + 0.2, 1e-15);
  for (std::size_t z = 0; z < 15; ++z)
    for (std::size_t y = 0; y < 4; ++y)
      for (std::size_t x = 0; x < 20; ++x) {
        const std::size_t j = s.index(x, y + 5, z + 2), i = cut.index(x, y, z);
        ASSERT_EQ(cut.label(i), s.labels[j]);
        ASSERT_EQ(cut.chi(i), s.labels[j] ? double(s.fraction[j]) : 0.0);
      }
  // Its bone volume per class is the whole sample's (the bone outside kept as a sum).
  const bm::Volume whole = bm::Volume::from_sample(s);
  EXPECT_EQ(whole.box(), bm::VoxelBox::whole(s.dims));
  EXPECT_EQ(whole.origin_mm(), s.origin_mm);
  for (int k = 0; k < bm::kMaxClasses; ++k)
    EXPECT_NEAR(cut.bone_volume_by_class()[std::size_t(k)], whole.bone_volume_by_class()[std::size_t(k)], 1e-12) << k;
  // A box past the grid, empty, or cutting rows along x is a programming error.
  EXPECT_THROW(bm::Volume::from_sample(s, {{0, 0, 0}, {20, 21, 20}}), std::logic_error);
  EXPECT_THROW(bm::Volume::from_sample(s, {{0, 4, 0}, {20, 4, 20}}), std::logic_error);
  EXPECT_THROW(bm::Volume::from_sample(s, {{3, 0, 0}, {20, 20, 20}}), std::logic_error);
}

TEST(Reach, TheBoxHoldsEveryVoxelWithinReachOfThePath) {
  const auto s = scenes::lumpy(64, 0.1, 5);
  const bm::Trajectory tr = plunge_and_sweep(2.0, 2.0);
  const bm::VoxelBox box = bm::reach_box(s, tr, kR).value();
  // Brute force: every voxel whose centre comes within R + η of a centre.
  const double reach = kR + bm::voxel_sphere_radius(s.voxel_mm);
  bm::VoxelBox need{{64, 64, 64}, {0, 0, 0}};
  for (std::size_t z = 0; z < 64; ++z)
    for (std::size_t y = 0; y < 64; ++y)
      for (std::size_t x = 0; x < 64; ++x) {
        const glm::dvec3 c = s.origin_mm + 0.1 * glm::dvec3(double(x), double(y), double(z));
        bool near = false;
        for (const auto& p : tr.centre_vol_mm) near = near || glm::length(c - p) < reach;
        if (!near) continue;
        const std::size_t i[3] = {x, y, z};
        for (int a = 0; a < 3; ++a) {
          need.lo[a] = std::min(need.lo[a], i[a]);
          need.hi[a] = std::max(need.hi[a], i[a] + 1);
        }
      }
  EXPECT_TRUE(box.contains(need));
  // ... whole rows along x, and across them not much more: a few voxels of rounding.
  EXPECT_EQ(box.lo[0], 0u);
  EXPECT_EQ(box.hi[0], 64u);
  for (int a = 1; a < 3; ++a) EXPECT_LE(box.hi[a] - box.lo[a], need.hi[a] - need.lo[a] + 6) << a;
  EXPECT_LT(box.voxel_count(), s.voxel_count() / 4);
  // A path nowhere near the sample reaches no voxel: any volume replays it, one row will do.
  bm::Trajectory far = tr;
  for (auto& p : far.centre_vol_mm) p += glm::dvec3(0, 0, 50);
  EXPECT_FALSE(bm::reach_box(s, far, kR).has_value());
  EXPECT_EQ(bm::replay_box(s, far, kR).voxel_count(), 64u);
  EXPECT_FALSE(bm::reach_box(s, bm::Trajectory{}, kR).has_value());
}

TEST(Reach, AReplayOnTheReachableBoxEqualsOneOnTheWholeSample) {
  const auto s = scenes::lumpy(64, 0.1, 5);
  const bm::Trajectory tr = plunge_and_sweep(2.0, 2.0);
  bm::Volume whole = bm::Volume::from_sample(s);
  const Outcome a = replay_on(whole, tr);
  bm::Volume cut = bm::Volume::from_sample(s, bm::replay_box(s, tr, kR));
  const Outcome b = replay_on(cut, tr);
  expect_same(a, b);
  EXPECT_GT(b.sens.tangent_voxels, 0u);
}

TEST(Reach, AWorkerCutsAgainOnlyWhenAPathLeavesItsBox) {
  const auto s = scenes::lumpy(64, 0.1, 5);
  std::map<std::string, burrbench::data_schema::SampleVolume> samples{{"S", s}};
  bm::ReachVolumes worker(samples);
  const bm::Trajectory tr = plunge_and_sweep(2.0, 2.0);
  bm::Volume whole = bm::Volume::from_sample(s);

  const Outcome first = replay_on(worker.for_replay("S", tr, kR), tr);
  expect_same(replay_on(whole, tr), first);
  EXPECT_EQ(worker.builds(), 1u);
  EXPECT_LT(worker.for_replay("S", tr, kR).voxel_count(), s.voxel_count() / 2);

  // A lag or depth offset moves the path by less than the burr's radius: the same cut,
  // restored by the replay's undo log, gives the same replay again.
  bm::Trajectory shifted = tr;
  for (auto& p : shifted.centre_vol_mm) p += glm::dvec3(0.3, -0.2, 0.05);
  expect_same(replay_on(whole, shifted), replay_on(worker.for_replay("S", shifted, kR), shifted));
  expect_same(first, replay_on(worker.for_replay("S", tr, kR), tr));
  EXPECT_EQ(worker.builds(), 1u);

  // A path elsewhere in the sample: cut again, covering both.
  const bm::Trajectory other = plunge_and_sweep(4.0, 4.5);
  expect_same(replay_on(whole, other), replay_on(worker.for_replay("S", other, kR), other));
  EXPECT_EQ(worker.builds(), 2u);
  expect_same(first, replay_on(worker.for_replay("S", tr, kR), tr));
  EXPECT_EQ(worker.builds(), 2u);
  // A path that reaches no voxel replays on whatever the worker holds: no cut, no force.
  bm::Trajectory far = tr;
  for (auto& p : far.centre_vol_mm) p += glm::dvec3(0, 0, 50);
  bm::Volume& held = worker.for_replay("S", far, kR);
  EXPECT_EQ(worker.builds(), 2u);
  const bm::ReplayResult none = bm::replay(held, kR, scenes::two_classes(), far, {}, true);
  for (const auto& smp : none.samples) ASSERT_EQ(smp.contact.force_N, glm::dvec3(0));

  // A worker whose first path reached nothing holds the first row only, and its next cut
  // is the path's own box, not the hull with that row.
  bm::ReachVolumes fresh(samples);
  EXPECT_EQ(fresh.for_replay("S", far, kR).voxel_count(), 64u);
  const bm::VoxelBox own = fresh.for_replay("S", other, kR).box();
  EXPECT_GT(own.lo[1], 0u);
  EXPECT_EQ(fresh.builds(), 2u);
  expect_same(replay_on(whole, other), replay_on(fresh.for_replay("S", other, kR), other));
}

namespace {
// A recording whose stage follows `tr` (rig frame = volume frame, no tool offset).
bm::AlignedRecording recording_along(const std::string& id, const bm::Trajectory& tr) {
  bm::AlignedRecording r;
  r.id = id;
  r.sample_id = "S";
  r.t_s = tr.t_s;
  r.force_sensor_N.assign(tr.t_s.size(), glm::dvec3(0));
  r.use.assign(tr.t_s.size(), 1);
  r.use_calibrate = r.use;
  r.use_validate.assign(tr.t_s.size(), 0);
  r.stage_rig_mm = {tr.t_s, tr.centre_vol_mm};
  r.spindle_rpm = {tr.t_s, std::vector<double>(tr.t_s.size(), 40000.0)};
  r.shaft_axis_vol = glm::normalize(glm::dvec3(0.8, 0.0, 0.6));
  r.radius_mm = kR;
  return r;
}
}  // namespace

// The removed bone is kept only over the rows the recordings reach; against the whole
// sample eroded by each recording in turn (as before the cut), the same maps bit for bit.
TEST(Reach, TheRemovedBoneOfAnExperimentIsTheWholeSamplesBitForBit) {
  bm::Experiment e;
  e.samples["S"] = scenes::lumpy(64, 0.1, 5);
  e.manifest.samples.push_back({});
  e.manifest.samples.back().id = "S";
  e.recordings = {recording_along("a", plunge_and_sweep(1.6, 1.6)), recording_along("b", plunge_and_sweep(4.0, 4.5))};
  bm::PredictOptions po;
  po.removed_bone = true;
  po.threads = 2;
  const bm::ExperimentPrediction pred = bm::predict_experiment(e, scenes::two_classes(), po);
  ASSERT_EQ(pred.removed.size(), 1u);
  const auto& got = pred.removed[0];

  // Brute force over the whole sample: each recording erodes a whole copy; per voxel the
  // largest removal; summed along z in the sample's order.
  const auto& s = e.samples.at("S");
  std::vector<float> most(s.voxel_count(), 0.0f);
  double removed_by_replays = 0;
  for (const auto& r : e.recordings) {
    bm::Volume whole = bm::Volume::from_sample(s);
    const bm::ReplayResult res =
        bm::replay(whole, kR, scenes::two_classes(), r.trajectory(0, 0), {}, false);
    for (double v : res.removed_mm3) removed_by_replays += v;
    for (std::size_t j = 0; j < most.size(); ++j)
      most[j] = std::max(most[j], float((s.labels[j] ? double(s.fraction[j]) : 0.0) - whole.chi(j)));
  }
  std::vector<float> depth(s.dims[0] * s.dims[1], 0.0f);
  double total = 0;
  for (std::size_t z = 0; z < s.dims[2]; ++z)
    for (std::size_t y = 0; y < s.dims[1]; ++y)
      for (std::size_t x = 0; x < s.dims[0]; ++x) {
        const float v = most[s.index(x, y, z)];
        depth[x + s.dims[0] * y] += float(v * s.voxel_mm);
        total += v;
      }
  EXPECT_EQ(got.removed_depth_mm, depth);
  EXPECT_EQ(got.removed_volume_mm3, total * std::pow(s.voxel_mm, 3));
  // The two drillings do not overlap, so the map holds what both replays removed.
  EXPECT_GT(got.removed_volume_mm3, 0.1);
  EXPECT_NEAR(got.removed_volume_mm3, removed_by_replays, 1e-6 * removed_by_replays);
}

// Recordings of one sample that removed the same bone are named (each is replayed from the
// sample as scanned, so the one drilled second was predicted against bone already gone).
namespace {
bm::Experiment experiment_of(std::vector<bm::AlignedRecording> recordings) {
  bm::Experiment e;
  e.samples["S"] = scenes::lumpy(64, 0.1, 5);
  e.manifest.samples.push_back({});
  e.manifest.samples.back().id = "S";
  e.recordings = std::move(recordings);
  return e;
}

std::vector<bm::RemovedOverlap> overlaps_of(const bm::Experiment& e, bool removed_bone = true,
                                            bool erosion = true) {
  bm::PredictOptions po;
  po.removed_bone = removed_bone;
  po.replay.erosion = erosion;
  po.threads = 2;
  return bm::predict_experiment(e, scenes::two_classes(), po).overlaps;
}

// Brute force: each recording erodes a whole copy of the sample; per voxel its removal.
std::vector<std::vector<double>> removals(const bm::Experiment& e) {
  const auto& s = e.samples.at("S");
  std::vector<std::vector<double>> out;
  for (const auto& r : e.recordings) {
    bm::Volume whole = bm::Volume::from_sample(s);
    (void)bm::replay(whole, kR, scenes::two_classes(), r.trajectory(0, 0), {}, false);
    out.emplace_back(s.voxel_count());
    for (std::size_t j = 0; j < s.voxel_count(); ++j)
      out.back()[j] = float((s.labels[j] ? double(s.fraction[j]) : 0.0) - whole.chi(j));
  }
  return out;
}
}  // namespace

TEST(RemovedOverlap, TwoRecordingsThatCutTheSameBoneAreNamedWithTheBoneTheyShare) {
  // Each plunges 0.4 mm (a footprint of radius 0.8 mm) and sweeps 1 mm along x. b runs
  // 0.6 mm beside a: they cut the same bone. c runs 1.4 mm beside a: the holes touch, and
  // share only a partly eroded rim voxel, which is not an overlap to report.
  const bm::Experiment e = experiment_of({recording_along("a", plunge_and_sweep(1.6, 1.6)),
                                          recording_along("b", plunge_and_sweep(1.6, 1.0)),
                                          recording_along("c", plunge_and_sweep(1.6, 3.0))});
  const auto got = overlaps_of(e);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].sample_id, "S");
  EXPECT_EQ(got[0].first, "a");
  EXPECT_EQ(got[0].second, "b");

  const auto rem = removals(e);
  const double l3 = std::pow(e.samples.at("S").voxel_mm, 3);
  double shared = 0, ra = 0, rb = 0, rc = 0, ac = 0, bc = 0;
  for (std::size_t j = 0; j < rem[0].size(); ++j) {
    shared += std::min(rem[0][j], rem[1][j]);
    ac += std::min(rem[0][j], rem[2][j]);
    bc += std::min(rem[1][j], rem[2][j]);
    ra += rem[0][j];
    rb += rem[1][j];
    rc += rem[2][j];
  }
  EXPECT_NEAR(got[0].shared_mm3, shared * l3, 1e-9 * shared * l3);
  EXPECT_NEAR(got[0].removed_first_mm3, ra * l3, 1e-9 * ra * l3);
  EXPECT_NEAR(got[0].removed_second_mm3, rb * l3, 1e-9 * rb * l3);
  EXPECT_GT(shared, 0.1 * std::min(ra, rb)) << "the test needs a real overlap";
  EXPECT_GT(rc, 0.1 * ra) << "c must cut bone";
  EXPECT_GT(ac, 0.0) << "the test needs holes that touch";
  EXPECT_LE(ac, bm::kOverlapShare * std::min(ra, rc));
  EXPECT_EQ(bc, 0.0);

  // A plain replay (`replay`, Python's replay()) checks too, without the removed-bone
  // maps: the same pair and figures. Without erosion nothing is removed, no pair.
  const auto plain = overlaps_of(e, false);
  ASSERT_EQ(plain.size(), 1u);
  EXPECT_EQ(plain[0].text(), got[0].text());
  EXPECT_EQ(plain[0].shared_mm3, got[0].shared_mm3);
  EXPECT_TRUE(overlaps_of(e, false, false).empty());
  EXPECT_TRUE(overlaps_of(e, true, false).empty());
  EXPECT_NE(got[0].text().find("Recordings a and b removed the same bone of sample S: "), std::string::npos)
      << got[0].text();
}

TEST(RemovedOverlap, OneFileListedTwiceIsOneDrillingAndTwoFilesOfOnePathAreTwo) {
  const std::filesystem::path dir = testing::TempDir();
  bm::AlignedRecording a = recording_along("plunge", plunge_and_sweep(1.6, 1.6));
  bm::AlignedRecording b = recording_along("plunge@validate", plunge_and_sweep(1.6, 1.6));
  a.file = dir / "plunge.h5";
  b.file = dir / "sub" / ".." / "plunge.h5";  // the same file, spelled otherwise
  EXPECT_TRUE(overlaps_of(experiment_of({a, b})).empty());
  // The same file through a hard link (both exist).
  std::filesystem::remove(dir / "plunge.h5");
  std::filesystem::remove(dir / "plunge_link.h5");
  { std::ofstream(dir / "plunge.h5") << "x"; }
  std::filesystem::create_hard_link(dir / "plunge.h5", dir / "plunge_link.h5");
  b.file = dir / "plunge_link.h5";
  EXPECT_TRUE(overlaps_of(experiment_of({a, b})).empty());
  std::filesystem::remove(dir / "plunge_link.h5");
  std::filesystem::remove(dir / "plunge.h5");
  b.file = dir / "sub" / ".." / "plunge.h5";

  // The same path drilled again, from another file: all of it shared. It is one pair with
  // the drilling listed twice, not one with each listing.
  bm::AlignedRecording c = recording_along("plunge_again", plunge_and_sweep(1.6, 1.6));
  c.file = dir / "plunge_again.h5";
  const auto got = overlaps_of(experiment_of({a, b, c}));
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0].first, "plunge");
  EXPECT_EQ(got[0].second, "plunge_again");
  EXPECT_GT(got[0].shared_mm3, 0.05);
  EXPECT_EQ(got[0].shared_mm3, got[0].removed_first_mm3);
  EXPECT_EQ(got[0].removed_first_mm3, got[0].removed_second_mm3);
}
