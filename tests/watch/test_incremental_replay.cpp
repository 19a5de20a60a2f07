// The live replay, fed a trajectory piece by piece, gives the batch replay's contacts and
// leaves the same eroded volume, bit for bit.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/replay.hpp"
#include "burrbench/watch/incremental_replay.hpp"

namespace bm = burrbench::model;
namespace bw = burrbench::watch;

namespace {

// 40×40×20 voxels of 0.1 mm: compact bone below z = 1 mm, partly filled near the top.
bm::Volume slab() {
  const std::size_t nx = 40, ny = 40, nz = 20;
  std::vector<std::uint8_t> labels(nx * ny * nz, 0), counters(nx * ny * nz, 0);
  for (std::size_t z = 0; z < 10; ++z)
    for (std::size_t y = 0; y < ny; ++y)
      for (std::size_t x = 0; x < nx; ++x) {
        const std::size_t i = x + nx * (y + ny * z);
        labels[i] = 1;
        counters[i] = z == 9 ? std::uint8_t(100 + (x * 7 + y * 3) % 150) : 255;
      }
  return bm::Volume::from_counters({nx, ny, nz}, 0.1, {0, 0, 0}, labels, counters);
}

// 600 samples at 1 kHz: down into the bone, then along x and back up.
bm::Trajectory path() {
  bm::Trajectory tr;
  const glm::dvec3 axis = glm::normalize(glm::dvec3(0.6, 0, 0.8));
  for (int i = 0; i < 600; ++i) {
    const double t = i * 1e-3;
    const double x = 1.5 + (i > 200 ? (i - 200) * 0.003 : 0.0);
    const double z = i < 200 ? 1.8 - i * 0.0025 : (i < 500 ? 1.3 : 1.3 + (i - 500) * 0.004);
    tr.t_s.push_back(t + (i % 3) * 1e-5);  // slightly uneven, as host timestamps are
    tr.centre_vol_mm.push_back({x, 2.0, z});
    tr.omega_vol_rad_s.push_back(axis * (2 * M_PI * 30000 / 60));
  }
  return tr;
}

bm::ModelParams params() {
  bm::ModelParams p;
  p.by_label[1] = {2.0, 80.0, 0.4};  // α small enough to erode visibly in 0.6 s
  return p;
}

bm::Trajectory prefix(const bm::Trajectory& tr, std::size_t n) {
  bm::Trajectory p;
  p.t_s.assign(tr.t_s.begin(), tr.t_s.begin() + std::ptrdiff_t(n));
  p.centre_vol_mm.assign(tr.centre_vol_mm.begin(), tr.centre_vol_mm.begin() + std::ptrdiff_t(n));
  p.omega_vol_rad_s.assign(tr.omega_vol_rad_s.begin(),
                           tr.omega_vol_rad_s.begin() + std::ptrdiff_t(n));
  return p;
}

}  // namespace

TEST(WatchIncrementalReplay, EqualsTheBatchReplayBitForBit) {
  const bm::Trajectory tr = path();
  bm::ReplayOptions opt;
  opt.step_s = 0.25e-3;
  bm::Volume batch_vol = slab();
  const bm::ReplayResult batch = bm::replay(batch_vol, 0.5, params(), tr, opt, /*restore=*/false);
  double removed = 0;
  for (double r : batch.removed_mm3) removed += r;
  ASSERT_GT(removed, 1e-3);  // the test erodes, so the order of erosion matters

  bw::IncrementalReplay live(slab(), 0.5, params(), opt);
  std::vector<bm::ContactResult> got(tr.t_s.size());
  std::size_t n = 0;
  // Pieces of 1, 2, 3, … samples (and a poll that brings nothing new).
  for (std::size_t piece = 1; n < tr.t_s.size(); ++piece) {
    n = std::min(tr.t_s.size(), n + piece);
    const bw::ReplayChunk c = live.extend(prefix(tr, n));
    for (std::size_t i = 0; i < c.contacts.size(); ++i) got[c.first_index + i] = c.contacts[i];
    EXPECT_TRUE(live.extend(prefix(tr, n)).contacts.empty());
  }
  ASSERT_EQ(live.reported(), tr.t_s.size());
  std::size_t in_contact = 0;
  for (std::size_t k = 0; k < tr.t_s.size(); ++k) {
    const auto &a = batch.samples[k].contact, &b = got[k];
    EXPECT_EQ(a.force_N, b.force_N) << "sample " << k;
    EXPECT_EQ(a.moment_Nmm, b.moment_Nmm) << "sample " << k;
    EXPECT_EQ(a.depth_b_mm, b.depth_b_mm) << "sample " << k;
    in_contact += glm::length(a.force_N) > 0;
  }
  EXPECT_GT(in_contact, 300u);
  EXPECT_EQ(batch_vol.to_sample().fraction, live.volume().to_sample().fraction);
}

TEST(WatchIncrementalReplay, RefusesAnUnfixedStep) {
  EXPECT_THROW(bw::IncrementalReplay(slab(), 0.5, params(), bm::ReplayOptions{}),
               burrbench::InputError);
}
