// The alarms as pure functions and a small state machine, and the display's thinning
// rule: closed-form cases.
#include <gtest/gtest.h>

#include <string>

#include "burrbench/watch/alarms.hpp"
#include "burrbench/watch/session.hpp"

namespace bw = burrbench::watch;

TEST(WatchAlarms, BandIsKSigmaOnAnyAxis) {
  // σ = 0.02 N, k = 5: the band is ±0.1 N on each axis; on it is inside.
  EXPECT_FALSE(bw::beyond_band({0.1, -0.1, 0.1}, 0.02, 5));
  EXPECT_TRUE(bw::beyond_band({0.0, -0.1001, 0.0}, 0.02, 5));
  EXPECT_TRUE(bw::beyond_band({0.0, 0.0, 0.1001}, 0.02, 5));
  // Three axes each just inside stay inside, though the norm (0.17 N) is beyond 0.1 N.
  EXPECT_FALSE(bw::beyond_band({0.099, 0.099, 0.099}, 0.02, 5));
}

TEST(WatchAlarms, ContactMismatchBothWays) {
  const double s = 0.02, k = 5;  // |F| > 0.1 N reads as contact
  EXPECT_EQ(bw::contact_mismatch({0, 0, 0.05}, {0, 0, 1.0}, s, k),
            bw::ContactMismatch::kPredictedOnly);
  EXPECT_EQ(bw::contact_mismatch({0, 0, 1.0}, {0, 0, 0}, s, k), bw::ContactMismatch::kMeasuredOnly);
  EXPECT_EQ(bw::contact_mismatch({0, 0, 1.0}, {0, 0, 0.5}, s, k), bw::ContactMismatch::kNone);
  EXPECT_EQ(bw::contact_mismatch({0.01, 0, 0}, {0, 0, 0}, s, k), bw::ContactMismatch::kNone);
  // The norm decides: 0.06 N on each axis is 0.104 N.
  EXPECT_EQ(bw::contact_mismatch({0.06, 0.06, 0.06}, {0, 0, 0}, s, k),
            bw::ContactMismatch::kMeasuredOnly);
}

TEST(WatchAlarms, SustainedFiresOnceAfterTheHold) {
  bw::Sustained s(0.2);
  int fired = 0;
  double fired_at = -1;
  for (int i = 0; i <= 1000; ++i) {  // 1 kHz; true from sample 100 (t = 0.1 s) on
    const double t = i * 1e-3;  // (0.301 − 0.1 and 0.3 − 0.1 fall either side of 0.2 in binary too)
    if (s.update(t, i >= 100)) {
      ++fired;
      fired_at = t;
    }
  }
  EXPECT_EQ(fired, 1);
  EXPECT_NEAR(fired_at, 0.301, 1e-12);  // first sample with t − 0.1 > 0.2
}

TEST(WatchAlarms, SustainedRestartsAfterABreak) {
  bw::Sustained s(0.2);
  int fired = 0;
  for (int i = 0; i <= 1000; ++i) {
    // True except at samples 250 and 700: the first run (100–249) is too short, the
    // second (251–699) fires at 452, the third (701–1000) at 902.
    const bool c = i >= 100 && i != 250 && i != 700;
    if (s.update(i * 1e-3, c)) ++fired;
  }
  EXPECT_EQ(fired, 2);
}

TEST(WatchAlarms, MonitorResidualAfterHold) {
  bw::AlarmSettings set;  // k = 5
  set.residual_hold_ms = 250;
  bw::AlarmMonitor m(set);
  const double sigma = 0.02;
  std::vector<bw::Alarm> alarms;
  // Samples every 1/1024 s: every time and difference below is exact in binary.
  for (int i = 0; i < 2048; ++i) {
    const double t = i / 1024.0;
    // Both in contact; from t = 0.5 s the measured force is 0.3 N (15σ) above the prediction.
    const glm::dvec3 pred(0, 0, 1.0), meas = pred + glm::dvec3(0, 0, t >= 0.5 ? 0.3 : 0.0);
    if (auto a = m.update(t, meas, pred, sigma)) alarms.push_back(*a);
  }
  ASSERT_EQ(alarms.size(), 1u);
  EXPECT_EQ(alarms[0].kind, "residual");
  EXPECT_EQ(alarms[0].t_s, 769 / 1024.0);  // the first sample with t − 0.5 > 0.25
  EXPECT_EQ(alarms[0].since_s, 0.5);
  EXPECT_NE(alarms[0].message.find(bw::kStopAndCheck), std::string::npos);
}

TEST(WatchAlarms, MonitorPredictedContactOnlyIsNamed) {
  bw::AlarmSettings set;
  set.contact_hold_ms = 100;
  set.residual_hold_ms = 1000;
  bw::AlarmMonitor m(set);
  std::vector<bw::Alarm> alarms;
  for (int i = 0; i < 1000; ++i) {
    const double t = i * 1e-3;
    // The model puts the burr in bone from 0.2 s; the sensor reads noise only.
    const glm::dvec3 pred(0, 0, t >= 0.2 ? 0.8 : 0.0), meas(0.01, -0.01, 0.02);
    if (auto a = m.update(t, meas, pred, 0.02)) alarms.push_back(*a);
  }
  ASSERT_GE(alarms.size(), 1u);
  EXPECT_EQ(alarms[0].kind, "predicted_contact_only");
  EXPECT_NEAR(alarms[0].t_s, 0.301, 1e-12);
  EXPECT_NE(alarms[0].message.find("predicted in bone"), std::string::npos);
  // The residual is beyond the band too, for longer than its own 1 s hold only after 1.2 s.
  EXPECT_EQ(alarms.size(), 1u);
}

TEST(WatchAlarms, NothingFiresWithoutABand) {
  bw::AlarmMonitor m(bw::AlarmSettings{});
  for (int i = 0; i < 1000; ++i)
    EXPECT_FALSE(m.update(i * 1e-3, {0, 0, 5}, {0, 0, 0}, 0.0).has_value());
}

TEST(WatchAlarms, SettingsValidated) {
  bw::AlarmSettings s;
  EXPECT_EQ(s.invalid(), "");
  s.residual_k = 0;
  EXPECT_NE(s.invalid().find("residual_k"), std::string::npos);
  s = {};
  s.contact_hold_ms = -1;
  EXPECT_NE(s.invalid().find("contact_hold_ms"), std::string::npos);
}

TEST(WatchDisplay, ThinnedOnlyWhenBehindByMoreThanHalfASecond) {
  EXPECT_EQ(bw::display_every(0.0), 1u);
  EXPECT_EQ(bw::display_every(0.5), 1u);
  EXPECT_EQ(bw::display_every(0.6), 2u);  // ⌈1.2⌉
  EXPECT_EQ(bw::display_every(3.2), 7u);  // ⌈6.4⌉
}
