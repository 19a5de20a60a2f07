// Sampling a protocol: find the bone surface along the approach line, turn the moves into
// straight segments at constant speed, sample them at the protocol's rate.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/protocol.hpp"

namespace burrbench::model {
namespace {

bool is_bone(const data_schema::SampleVolume& s, std::size_t i) {
  return s.labels[i] != 0 && s.fraction[i] >= 0.5f;
}

struct Segment {
  double t0, t1;
  glm::dvec3 p0, p1;
  double rpm;
  int move;
};

}  // namespace

std::vector<glm::dvec3> ProtocolPath::omega_vol_rad_s(const Protocol& p) const {
  std::vector<glm::dvec3> w(spindle_rpm.size());
  for (std::size_t k = 0; k < w.size(); ++k)
    w[k] = (2 * M_PI * spindle_rpm[k] / 60.0 * p.spin_sign) * p.burr_axis_vol;
  return w;
}

double distance_to_surface(const data_schema::SampleVolume& s, const glm::dvec3& start,
                           const glm::dvec3& approach, double radius_mm, const std::string& file) {
  // Amanatides–Woo traversal of the voxel cells met by the leading point's line, in grid
  // units where cell i spans [i, i+1) (voxel centres sit at i + 1/2).
  const double l = s.voxel_mm;
  const glm::dvec3 g0 = (start + radius_mm * approach - s.origin_mm) / l + 0.5;
  const glm::dvec3 dir = approach / l;  // grid units per mm along the line
  double t_in = 0, t_out = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const double n = double(s.dims[std::size_t(k)]);
    if (dir[k] == 0) {
      if (g0[k] < 0 || g0[k] >= n) t_out = -1;
      continue;
    }
    double a = (0 - g0[k]) / dir[k], b = (n - g0[k]) / dir[k];
    if (a > b) std::swap(a, b);
    t_in = std::max(t_in, a);
    t_out = std::min(t_out, b);
  }
  auto no_bone = [&] {
    return InputError(file, "start", "an approach line that meets bone in the sample",
                      fmt::format("no voxel with label ≠ 0 and χ ≥ 0.5 along {}+s·({}, {}, {})",
                                  "start.point_mm", approach.x, approach.y, approach.z));
  };
  if (!(t_in < t_out)) throw no_bone();
  std::array<long, 3> cell{}, step{};
  glm::dvec3 t_next, t_delta;
  const glm::dvec3 g_in = g0 + t_in * dir;
  for (int k = 0; k < 3; ++k) {
    const long n = long(s.dims[std::size_t(k)]);
    cell[std::size_t(k)] = std::clamp(long(std::floor(g_in[k])), 0L, n - 1);
    if (dir[k] > 0) {
      step[std::size_t(k)] = 1;
      t_next[k] = (double(cell[std::size_t(k)] + 1) - g0[k]) / dir[k];
      t_delta[k] = 1 / dir[k];
    } else if (dir[k] < 0) {
      step[std::size_t(k)] = -1;
      t_next[k] = (double(cell[std::size_t(k)]) - g0[k]) / dir[k];
      t_delta[k] = -1 / dir[k];
    } else {
      step[std::size_t(k)] = 0;
      t_next[k] = t_delta[k] = std::numeric_limits<double>::infinity();
    }
  }
  double t_cell = t_in;  // where the line enters the current cell
  for (;;) {
    const std::size_t idx =
        s.index(std::size_t(cell[0]), std::size_t(cell[1]), std::size_t(cell[2]));
    if (is_bone(s, idx)) {
      if (t_cell <= 0)
        throw InputError(
            file, "start.point_mm",
            "a burr centre whose leading point (centre + R·approach) is clear of bone");
      return t_cell;
    }
    int k = 0;
    if (t_next[1] < t_next[k]) k = 1;
    if (t_next[2] < t_next[k]) k = 2;
    t_cell = t_next[k];
    t_next[k] += t_delta[k];
    cell[std::size_t(k)] += step[std::size_t(k)];
    if (cell[std::size_t(k)] < 0 || cell[std::size_t(k)] >= long(s.dims[std::size_t(k)]))
      throw no_bone();
  }
}

ProtocolPath sample_protocol(const Protocol& p, const data_schema::SampleVolume& sample) {
  const double s0 =
      distance_to_surface(sample, p.start_vol_mm, p.approach_vol, p.burr_radius_mm, p.file);
  const glm::dvec3 a = p.approach_vol;
  ProtocolPath out;
  out.surface_vol_mm = p.start_vol_mm + s0 * a;
  auto depth_of = [&](const glm::dvec3& x) { return glm::dot(x - out.surface_vol_mm, a); };

  double n_segments = 0;  // refuse a path bomb (e.g. 10⁵ moves × 10⁵ strokes) before allocating
  for (const auto& m : p.moves) n_segments += 2.0 * m.strokes + 2;
  if (n_segments > 1e7)
    throw InputError(p.file, "moves", "at most 1e7 path segments (strokes count twice)");
  std::vector<Segment> segs;
  glm::dvec3 cur = p.start_vol_mm;
  double t = 0, rpm = p.spindle_rpm;
  auto go = [&](const glm::dvec3& to, double duration, int move) {
    if (!(duration > 0)) return;  // zero-length move: nothing to sample
    segs.push_back({t, t + duration, cur, to, rpm, move});
    t += duration;
    cur = to;
  };
  auto move_to = [&](const glm::dvec3& to, double speed, int move) {
    go(to, glm::length(to - cur) / speed, move);
  };
  auto to_depth = [&](double depth, double speed, int move) {
    move_to(cur + (depth - depth_of(cur)) * a, speed, move);
  };
  for (std::size_t i = 0; i < p.moves.size(); ++i) {
    const ProtocolMove& m = p.moves[i];
    const int mi = int(i);
    if (m.spindle_rpm) rpm = *m.spindle_rpm;
    switch (m.kind) {
      case MoveKind::kPlunge:
        to_depth(*m.depth_mm, m.speed_mm_s, mi);
        break;
      case MoveKind::kSweep:
        if (m.depth_mm) to_depth(*m.depth_mm, m.feed_mm_s.value_or(m.speed_mm_s), mi);
        move_to(cur + m.length_mm * m.direction, m.speed_mm_s, mi);
        break;
      case MoveKind::kPolish:
        if (m.depth_mm) to_depth(*m.depth_mm, m.feed_mm_s.value_or(m.speed_mm_s), mi);
        for (int k = 0; k < m.strokes; ++k) {
          const glm::dvec3 home = cur;
          move_to(home + m.length_mm * m.direction, m.speed_mm_s, mi);
          move_to(home, m.speed_mm_s, mi);
        }
        break;
      case MoveKind::kDwell:
        go(cur, m.duration_s, mi);
        break;
      case MoveKind::kRetract:
        if (m.distance_mm) {
          move_to(cur - *m.distance_mm * a, m.speed_mm_s, mi);
        } else if (depth_of(cur) > -s0) {
          to_depth(-s0, m.speed_mm_s, mi);
        }
        break;
    }
  }
  out.duration_s = t;
  const double n_samples = std::floor(t * p.sample_rate_hz + 1e-9) + 1;
  if (n_samples > 5e7)
    throw InputError(p.file, "moves", "a protocol of at most 5e7 samples",
                     fmt::format("{:.0f} s at {} Hz", t, p.sample_rate_hz));
  const std::size_t n = std::size_t(n_samples);
  out.t_s.resize(n);
  out.centre_vol_mm.resize(n);
  out.spindle_rpm.resize(n);
  out.depth_mm.resize(n);
  out.move.resize(n);
  std::size_t j = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const double tk = double(k) / p.sample_rate_hz;
    // A sample on a segment boundary belongs to the later segment (its rpm applies).
    while (j + 1 < segs.size() && tk >= segs[j].t1) ++j;
    glm::dvec3 x = cur;
    double r = rpm;
    int mi = p.moves.empty() ? -1 : int(p.moves.size()) - 1;
    if (!segs.empty()) {
      const Segment& s = segs[j];
      const double u = std::clamp((tk - s.t0) / (s.t1 - s.t0), 0.0, 1.0);
      x = s.p0 + u * (s.p1 - s.p0);
      r = s.rpm;
      mi = s.move;
    }
    out.t_s[k] = tk;
    out.centre_vol_mm[k] = x;
    out.spindle_rpm[k] = r;
    out.depth_mm[k] = depth_of(x);
    out.move[k] = mi;
  }
  return out;
}

}  // namespace burrbench::model
