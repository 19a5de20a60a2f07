// Replay engine: determinism, exact restore through the undo log, stepping, input checks.
#include <cmath>
#include <cstring>

#include <gtest/gtest.h>

#include "burrbench/data_schema/error.hpp"
#include "test_paper_scenes.hpp"

namespace bm = burrbench::model;

namespace {

bm::Trajectory wobble(int n, double rate_hz) {
  bm::Trajectory tr;
  for (int i = 0; i < n; ++i) {
    const double t = i / rate_hz;
    tr.t_s.push_back(t);
    tr.centre_vol_mm.push_back({1.0 + 0.8 * std::sin(3 * t), 1.0 + 0.5 * std::cos(2 * t),
                                1.5 + 0.4 - 0.3 * t});
    tr.omega_vol_rad_s.push_back({0, 100.0 * std::sin(t), 3000.0});
  }
  return tr;
}

bm::ModelParams params() {
  bm::ModelParams p;
  p.by_label[1] = {30.0, 12.0, 0.4};
  return p;
}

std::vector<double> flatten(const bm::ReplayResult& r) {
  std::vector<double> v;
  for (const auto& s : r.samples) {
    const auto& c = s.contact;
    for (int k = 0; k < 3; ++k) v.insert(v.end(), {c.force_N[k], c.elastic_N[k], c.friction_N[k], c.normal[k]});
    v.insert(v.end(), {c.depth_b_mm, c.bone_volume_mm3, double(c.class_mask), double(c.buried)});
  }
  v.insert(v.end(), r.removed_mm3.begin(), r.removed_mm3.end());
  v.insert(v.end(), r.friction_energy_mJ.begin(), r.friction_energy_mJ.end());
  return v;
}

std::vector<float> raw(const bm::Volume& v) {
  std::vector<float> out;
  for (std::size_t i = 0; i < v.voxel_count(); ++i) {
    const double c = v.chi(i);
    float hi = float(c);
    out.push_back(hi);
    out.push_back(float(c - double(hi)));
  }
  return out;
}

}  // namespace

TEST(Replay, IdenticalInputGivesIdenticalBytes) {
  const auto s = scenes::half_space(40, 40, 40, 0.05, {0, 0, 1}, 1.5 + 0.025 - 0.05);
  bm::Volume a = bm::Volume::from_sample(s), b = bm::Volume::from_sample(s);
  const auto tr = wobble(600, 1000.0);
  const auto ra = bm::replay(a, 0.5, params(), tr);
  const auto rb = bm::replay(b, 0.5, params(), tr);
  const auto fa = flatten(ra), fb = flatten(rb);
  ASSERT_EQ(fa.size(), fb.size());
  EXPECT_EQ(std::memcmp(fa.data(), fb.data(), fa.size() * sizeof(double)), 0);
  EXPECT_GT(ra.removed_mm3[1], 0.0);
  // and a second replay on the SAME (restored) volume too
  const auto rc = bm::replay(a, 0.5, params(), tr);
  const auto fc = flatten(rc);
  EXPECT_EQ(std::memcmp(fa.data(), fc.data(), fa.size() * sizeof(double)), 0);
}

TEST(Replay, RestoreLeavesTheVolumeBitIdentical) {
  const auto s = scenes::half_space(40, 40, 40, 0.05, {0, 0, 1}, 1.5 + 0.025 - 0.05);
  bm::Volume v = bm::Volume::from_sample(s);
  // Start from an already-eroded state so sub-float remainders are in play.
  const auto pre = bm::replay(v, 0.5, params(), wobble(200, 1000.0), {}, /*restore=*/false);
  ASSERT_GT(pre.removed_mm3[1], 0.0);
  const auto before = raw(v);
  const auto r = bm::replay(v, 0.5, params(), wobble(800, 1000.0), {}, /*restore=*/true);
  ASSERT_GT(r.removed_mm3[1], 0.0);
  EXPECT_EQ(raw(v), before);
  EXPECT_FALSE(v.undo_active());
  // restore = false keeps the erosion
  bm::replay(v, 0.5, params(), wobble(800, 1000.0), {}, false);
  EXPECT_NE(raw(v), before);
}

TEST(Replay, UndoLogRecordsEachVoxelOnce) {
  const auto s = scenes::half_space(40, 40, 40, 0.05, {0, 0, 1}, 1.5 + 0.025 - 0.05);
  bm::Volume v = bm::Volume::from_sample(s);
  v.begin_undo();
  std::array<double, bm::kMaxClasses> rem{};
  for (int k = 0; k < 50; ++k) bm::step(v, {1.0, 1.0, 1.8}, {0, 300, 0}, 0.5, params(), 1e-3, rem);
  const std::size_t once = v.undo_entries();
  for (int k = 0; k < 50; ++k) bm::step(v, {1.0, 1.0, 1.8}, {0, 300, 0}, 0.5, params(), 1e-3, rem);
  EXPECT_GT(once, 0u);
  EXPECT_EQ(v.undo_entries(), once);  // same voxels again: no new entries
  v.rollback();
  EXPECT_EQ(v.to_sample().fraction, s.fraction);
}

TEST(Replay, StepsAndSampleTimes) {
  const auto s = scenes::half_space(40, 40, 40, 0.05, {0, 0, 1}, 1.5 + 0.025 - 0.05);
  bm::Volume v = bm::Volume::from_sample(s);
  const auto tr = wobble(101, 1000.0);
  const auto r = bm::replay(v, 0.5, params(), tr);
  EXPECT_EQ(r.samples.size(), 101u);
  EXPECT_EQ(r.steps, 200u);  // default: half the sample period
  bm::ReplayOptions o;
  o.step_s = 0.3e-3;
  EXPECT_EQ(bm::replay(v, 0.5, params(), tr, o).steps, 400u);  // ceil(1/0.3) = 4 per interval
  // The contact at the first sample is the kernel's on the untouched volume.
  const auto c0 = bm::evaluate(v, tr.centre_vol_mm[0], tr.omega_vol_rad_s[0], 0.5, params());
  EXPECT_EQ(r.samples[0].contact.force_N, c0.force_N);
  // Without erosion every sample is exactly the kernel's force at that pose.
  bm::ReplayOptions off;
  off.erosion = false;
  const auto r2 = bm::replay(v, 0.5, params(), tr, off);
  const auto c50 = bm::evaluate(v, tr.centre_vol_mm[50], tr.omega_vol_rad_s[50], 0.5, params());
  EXPECT_EQ(r2.samples[50].contact.force_N, c50.force_N);
}

// A via is a point the burr passes without a reported contact: samples 40 … 59 made vias
// give bit-identical contacts at every other sample and the same removal, where the line
// from sample 39 to 60 (the replay before vias) erodes elsewhere.
TEST(Replay, ViasAreFollowedLikeSamplesButNotReported) {
  const auto s = scenes::half_space(40, 40, 40, 0.05, {0, 0, 1}, 1.5 + 0.025 - 0.05);
  const auto full = wobble(101, 20.0);  // 0.8 mm in x over the gap
  const auto gap = scenes::with_vias(full, 40, 60);
  ASSERT_EQ(gap.t_s.size(), 81u);
  ASSERT_EQ(gap.vias.size(), 20u);
  bm::Volume v = bm::Volume::from_sample(s);
  const auto rf = bm::replay(v, 0.5, params(), full), rg = bm::replay(v, 0.5, params(), gap);
  ASSERT_EQ(rg.samples.size(), 81u);
  EXPECT_EQ(rg.steps, rf.steps);
  for (std::size_t k = 0; k < 81; ++k)
    EXPECT_EQ(rg.samples[k].contact.force_N, rf.samples[k < 40 ? k : k + 20].contact.force_N) << k;
  EXPECT_EQ(rg.removed_mm3, rf.removed_mm3);
  auto line = gap;
  line.vias.clear();
  const auto rl = bm::replay(v, 0.5, params(), line);
  EXPECT_GT(glm::length(rl.samples[40].contact.force_N - rg.samples[40].contact.force_N),
            1e-3 * glm::length(rg.samples[40].contact.force_N));
  // A via outside its interval, or out of order, is refused.
  auto bad = gap;
  bad.vias[3].t_s = bad.t_s[41];
  EXPECT_THROW(bm::replay(v, 0.5, params(), bad), burrbench::InputError);
  bad = gap;
  std::swap(bad.vias[3], bad.vias[4]);
  EXPECT_THROW(bm::replay(v, 0.5, params(), bad), burrbench::InputError);
  bad = gap;
  bad.vias[0].after = 80;
  EXPECT_THROW(bm::replay(v, 0.5, params(), bad), burrbench::InputError);
}

// Vias before the first sample (a sensor that started late while the burr cut): the bone
// removed along them is gone when the first contact is reported, as in the full replay.
TEST(Replay, ViasBeforeTheFirstSampleErodeAheadOfIt) {
  const auto s = scenes::half_space(40, 40, 40, 0.05, {0, 0, 1}, 1.5 + 0.025 - 0.05);
  const auto full = wobble(101, 20.0);
  const auto late = scenes::with_vias(full, 0, 30);
  ASSERT_EQ(late.vias.size(), 30u);
  bm::Volume v = bm::Volume::from_sample(s);
  const auto rf = bm::replay(v, 0.5, params(), full), rl = bm::replay(v, 0.5, params(), late);
  ASSERT_EQ(rl.samples.size(), 71u);
  EXPECT_EQ(rl.steps, rf.steps);
  for (std::size_t k = 0; k < 71; ++k) EXPECT_EQ(rl.samples[k].contact.force_N, rf.samples[k + 30].contact.force_N) << k;
  EXPECT_EQ(rl.removed_mm3, rf.removed_mm3);
  auto none = late;
  none.vias.clear();  // the replay before vias: the bone cut before the first sample is whole
  EXPECT_GT(glm::length(bm::replay(v, 0.5, params(), none).samples[0].contact.force_N - rl.samples[0].contact.force_N),
            1e-3 * glm::length(rl.samples[0].contact.force_N));
  auto bad = late;
  bad.vias.back().t_s = bad.t_s[0];  // not before the first sample
  EXPECT_THROW(bm::replay(v, 0.5, params(), bad), burrbench::InputError);
  bad = late;  // a lead-in after an interval's via
  bad.vias.insert(bad.vias.begin(), {39, 0.5 * (bad.t_s[39] + bad.t_s[40]), bad.centre_vol_mm[39], bad.omega_vol_rad_s[39]});
  EXPECT_THROW(bm::replay(v, 0.5, params(), bad), burrbench::InputError);
}

TEST(Replay, BadTrajectoriesAreRejected) {
  bm::Volume v = bm::Volume::from_sample(scenes::half_space(8, 8, 8, 0.1, {0, 0, 1}, 0.35));
  auto tr = wobble(10, 1000.0);
  tr.t_s[5] = tr.t_s[4];
  EXPECT_THROW(bm::replay(v, 0.5, params(), tr), burrbench::InputError);
  tr = wobble(10, 1000.0);
  tr.omega_vol_rad_s.pop_back();
  EXPECT_THROW(bm::replay(v, 0.5, params(), tr), burrbench::InputError);
  tr = wobble(10, 1000.0);
  tr.centre_vol_mm[3].x = NAN;
  EXPECT_THROW(bm::replay(v, 0.5, params(), tr), burrbench::InputError);
  tr = wobble(10, 1000.0);
  EXPECT_THROW(bm::replay(v, -0.5, params(), tr), burrbench::InputError);
  bm::ReplayOptions o;
  o.step_s = 1e-15;
  EXPECT_THROW(bm::replay(v, 0.5, params(), tr, o), burrbench::InputError);
  EXPECT_TRUE(bm::replay(v, 0.5, params(), bm::Trajectory{}).samples.empty());
}

namespace {
// Requests the token when the replay reports sample `at` (it reports every 1024th).
class CancelAt final : public burrbench::Progress {
 public:
  CancelAt(burrbench::CancelToken& t, std::size_t at) : t_(t), at_(at) {}
  void update(double fraction, const std::string&) override {
    if (fraction >= 0 && std::size_t(fraction * 2048.0 + 0.5) >= at_) t_.request();
  }
  void finish(const std::string&) override { finished = true; }
  bool finished = false;

 private:
  burrbench::CancelToken& t_;
  std::size_t at_;
};
}  // namespace

// The Python module's interrupt (docs/python.md): a requested token stops the replay, which
// throws Cancelled with the volume rolled back; an unrequested one changes nothing.
TEST(Replay, ACancelledReplayThrowsAndRestoresTheVolume) {
  const auto s = scenes::half_space(40, 40, 40, 0.05, {0, 0, 1}, 1.5 + 0.025 - 0.05);
  bm::Volume v = bm::Volume::from_sample(s);
  const auto before = raw(v);
  const auto tr = wobble(2048, 1000.0);
  burrbench::CancelToken token;
  bm::ReplayOptions o;
  o.cancel = &token;
  const auto plain = bm::replay(v, 0.5, params(), tr);
  const auto with_token = bm::replay(v, 0.5, params(), tr, o);
  const auto fa = flatten(plain), fb = flatten(with_token);
  ASSERT_EQ(fa.size(), fb.size());
  EXPECT_EQ(std::memcmp(fa.data(), fb.data(), fa.size() * sizeof(double)), 0);

  // The first half of the path erodes: a rollback has something to undo.
  {
    bm::Trajectory half = tr;
    half.t_s.resize(1024);
    half.centre_vol_mm.resize(1024);
    half.omega_vol_rad_s.resize(1024);
    ASSERT_GT(bm::replay(v, 0.5, params(), half).removed_mm3[1], 0.0);
  }
  CancelAt mid(token, 1024);  // requested halfway
  EXPECT_THROW(bm::replay(v, 0.5, params(), tr, o, /*restore=*/true, &mid), burrbench::Cancelled);
  EXPECT_TRUE(token.requested());
  EXPECT_FALSE(mid.finished);
  EXPECT_EQ(raw(v), before);
  EXPECT_FALSE(v.undo_active());
  // Requested before the start: not a single step, even where the erosion would be kept.
  EXPECT_THROW(bm::replay(v, 0.5, params(), tr, o, /*restore=*/false), burrbench::Cancelled);
  EXPECT_EQ(raw(v), before);
}
