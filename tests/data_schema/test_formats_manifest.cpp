// Experiment manifest (TOML): round trip, path resolution, and every validation rule of
// CONTRACTS.md A with the message naming file and key path.
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "test_formats_util.hpp"

namespace bb = burrbench::data_schema;
using burrbench::test::expect_input_error;
using burrbench::test::TempDir;

namespace {

const char* kBase = R"(format = "burrbench.experiment"
format_version = "1.0"
name = "demo"
description = "free text"

[[samples]]
id = "S1"
path = "../data/sample.h5"

[burr]
radius_mm = 1.0
shaft_axis_rig = [0.0, 0.0, 2.0]
spin_sign = -1
tool_offset_mm = [0.1, 0.0, -0.2]

[sensor]
rotation_sensor_to_rig = [[0,-1,0],[1,0,0],[0,0,1]]
measures = "force_on_burr"
sigma_N = 0.02

[[recordings]]
id = "plunge"
path = "../data/plunge.h5"
sample = "S1"
role = "calibrate"
lag_ms = 1.5
  [recordings.registration]
  rotation = [[1,0,0],[0,1,0],[0,0,1]]
  translation_mm = [1.0, 2.0, 3.0]
  [[recordings.segments]]
  start_s = 0.0
  end_s = 5.0
  use = true
  label = "plunge"
  [[recordings.segments]]
  start_s = 5.0
  end_s = 6.5
  use = false

[[recordings]]
id = "sweep"
path = "../data/plunge.h5"
sample = "S1"
role = "validate"
  [recordings.registration]
  fiducials_rig_mm = [[0,0,0],[10,0,0],[0,10,0],[0,0,10]]
  fiducials_vol_mm = [[1,1,1],[11,1,1],[1,11,1],[1,1,11]]

[fit]
loss = "cauchy"
loss_scale = 2.5
buried = "downweight"
seed = 42
multistart = 4
  [fit.precision]
  mu = 0.05
  c1 = 0.02
  [fit.classes.compact]
  alpha = { initial = 20.0, lower = 0.1, upper = 1000.0, fixed = false }
  c1    = { initial = 10.0, lower = 0.01, upper = 1000.0 }
  mu    = { initial = 0.3,  lower = 0.01, upper = 2.0 }
  [fit.classes.2]
  alpha = { initial = inf, fixed = true }
  c1    = { initial = 4.0, lower = 0.5, upper = 100.0 }
  mu    = { initial = 0.2, fixed = true }
  [fit.nuisance]
  bias = true
  lag = true
  lag_bounds_ms = [-20.0, 20]
  depth_offset = true
)";

struct Files {
  TempDir dir;
  std::filesystem::path manifest;
  Files() {
    std::filesystem::create_directories(dir / "data");
    std::filesystem::create_directories(dir / "exp");
    bb::SampleVolume v;
    v.dims = {2, 2, 2};
    v.voxel_mm = 0.5;
    v.labels = {1, 1, 1, 1, 2, 2, 0, 0};
    v.fraction = {1, 1, 1, 1, 0.5f, 0.5f, 0, 0};
    bb::write_sample(dir / "data" / "sample.h5", v);
    bb::Recording r;
    bb::write_recording(dir / "data" / "plunge.h5", r);
    manifest = dir / "exp" / "E.toml";
  }
  // Writes the base manifest with `from` replaced by `to` (must occur) and reads it.
  bb::ExperimentManifest read_with(const std::string& from = "", const std::string& to = "") const {
    std::string text = kBase;
    if (!from.empty()) {
      const auto pos = text.find(from);
      EXPECT_NE(pos, std::string::npos) << from;
      if (pos != std::string::npos) text.replace(pos, from.size(), to);
    }
    burrbench::test::write_text(manifest, text);
    return bb::read_manifest(manifest);
  }
  void expect_error(const std::string& from, const std::string& to, std::initializer_list<std::string> frags) const {
    expect_input_error([&] { read_with(from, to); }, frags);
  }
};

}  // namespace

TEST(FormatsManifest, ReadsEveryFieldAndResolvesPaths) {
  Files f;
  const auto m = f.read_with();
  EXPECT_EQ(m.name, "demo");
  EXPECT_EQ(m.description, "free text");
  ASSERT_EQ(m.samples.size(), 1u);
  EXPECT_EQ(m.samples[0].path, std::filesystem::absolute(f.dir / "data" / "sample.h5").lexically_normal());
  EXPECT_EQ(m.burr.radius_mm, 1.0);
  EXPECT_EQ(m.burr.shaft_axis_rig, glm::dvec3(0, 0, 1));  // normalised
  EXPECT_EQ(m.burr.spin_sign, -1);
  EXPECT_EQ(m.burr.tool_offset_mm, glm::dvec3(0.1, 0.0, -0.2));
  // TOML rows → glm columns: R·(1,0,0) = first column = (0,1,0).
  EXPECT_EQ(m.sensor.rotation_sensor_to_rig * glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0));
  EXPECT_EQ(m.sensor.measures, bb::SensorMeasures::kForceOnBurr);
  EXPECT_EQ(m.sensor.sigma_N.value(), 0.02);
  ASSERT_EQ(m.recordings.size(), 2u);
  const auto& p = m.recordings[0];
  EXPECT_EQ(p.lag_ms, 1.5);
  EXPECT_EQ(p.role, bb::RecordingRole::kCalibrate);
  EXPECT_EQ(p.registration.translation_mm, glm::dvec3(1, 2, 3));
  ASSERT_EQ(p.segments.size(), 2u);
  EXPECT_EQ(p.segments[1].end_s, 6.5);
  EXPECT_FALSE(p.segments[1].use);
  EXPECT_EQ(p.segments[0].label, "plunge");
  EXPECT_TRUE(m.recordings[1].registration.from_fiducials());
  EXPECT_EQ(m.recordings[1].registration.fiducials_vol_mm[3], glm::dvec3(1, 1, 11));
  EXPECT_EQ(m.recordings[1].role, bb::RecordingRole::kValidate);
  EXPECT_EQ(m.fit.loss, bb::LossKind::kCauchy);
  EXPECT_EQ(m.fit.buried, bb::BuriedPolicy::kDownweight);
  EXPECT_EQ(m.fit.seed, 42u);
  EXPECT_EQ(m.fit.multistart, 4);
  EXPECT_EQ(m.fit.precision_mu, 0.05);
  EXPECT_EQ(m.fit.precision_c1, 0.02);
  EXPECT_FALSE(m.fit.precision_alpha.has_value());
  ASSERT_EQ(m.fit.classes.size(), 2u);
  for (const auto& c : m.fit.classes) {
    if (c.key == "compact") {
      EXPECT_EQ(c.label, 1);
      EXPECT_EQ(c.alpha.lower, 0.1);
      EXPECT_FALSE(c.c1.fixed);
    } else {
      EXPECT_EQ(c.key, "2");
      EXPECT_EQ(c.label, 2);  // by id
      EXPECT_TRUE(std::isinf(c.alpha.initial));
      EXPECT_TRUE(c.alpha.fixed);
      EXPECT_EQ(c.mu.lower, 0.2);  // fixed without bounds: bounds = initial
    }
  }
  EXPECT_EQ(m.fit.nuisance.lag_bounds_ms[1], 20.0);
  EXPECT_TRUE(m.fit.nuisance.depth_offset);
}

TEST(FormatsManifest, WriteReadRoundTrip) {
  Files f;
  const auto a = f.read_with();
  bb::write_manifest(f.dir / "exp" / "copy.toml", a);
  const auto text = burrbench::test::file_bytes(f.dir / "exp" / "copy.toml");
  EXPECT_NE(text.find("'../data/sample.h5'"), std::string::npos) << "paths stored relative to the manifest";
  const auto b = bb::read_manifest(f.dir / "exp" / "copy.toml");
  EXPECT_EQ(b.samples[0].path, a.samples[0].path);
  EXPECT_EQ(b.burr.shaft_axis_rig, a.burr.shaft_axis_rig);
  EXPECT_EQ(b.sensor.rotation_sensor_to_rig, a.sensor.rotation_sensor_to_rig);
  ASSERT_EQ(b.recordings.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(b.recordings[i].id, a.recordings[i].id);
    EXPECT_EQ(b.recordings[i].path, a.recordings[i].path);
    EXPECT_EQ(b.recordings[i].lag_ms, a.recordings[i].lag_ms);
    EXPECT_EQ(b.recordings[i].registration.rotation, a.recordings[i].registration.rotation);
    EXPECT_EQ(b.recordings[i].registration.fiducials_rig_mm, a.recordings[i].registration.fiducials_rig_mm);
    EXPECT_EQ(b.recordings[i].segments.size(), a.recordings[i].segments.size());
  }
  ASSERT_EQ(b.fit.classes.size(), a.fit.classes.size());
  for (std::size_t i = 0; i < a.fit.classes.size(); ++i) {
    EXPECT_EQ(b.fit.classes[i].key, a.fit.classes[i].key);
    EXPECT_EQ(b.fit.classes[i].label, a.fit.classes[i].label);
    EXPECT_EQ(b.fit.classes[i].c1.upper, a.fit.classes[i].c1.upper);
    EXPECT_EQ(b.fit.classes[i].alpha.initial, a.fit.classes[i].alpha.initial);
  }
  EXPECT_EQ(b.fit.loss_scale, a.fit.loss_scale);
  EXPECT_EQ(b.fit.seed, a.fit.seed);
  EXPECT_EQ(b.fit.precision_mu, a.fit.precision_mu);
  EXPECT_EQ(b.fit.precision_alpha, a.fit.precision_alpha);
}

TEST(FormatsManifest, NewerMinorAcceptedUnknownMajorRejected) {
  Files f;
  EXPECT_NO_THROW(f.read_with("format_version = \"1.0\"", "format_version = \"1.7\""));
  f.expect_error("format_version = \"1.0\"", "format_version = \"2.0\"",
                 {"E.toml: format_version: expected version \"1.x\"", "unknown major version"});
  f.expect_error("format_version = \"1.0\"", "format_version = \"one\"", {"format_version"});
  f.expect_error("\"burrbench.experiment\"", "\"burrbench.params\"", {"E.toml: format: expected \"burrbench.experiment\""});
}

TEST(FormatsManifest, UnknownKeysAreRejectedWithTheirPath) {
  Files f;
  f.expect_error("name = \"demo\"", "name = \"demo\"\ncolour = \"red\"", {"E.toml: colour: expected a known key"});
  f.expect_error("lag_ms = 1.5", "lag_ms = 1.5\nspeed = 3", {"E.toml: recordings[0].speed: expected a known key"});
  f.expect_error("depth_offset = true", "depth_offset = true\nscale = 1", {"fit.nuisance.scale"});
  f.expect_error("upper = 1000.0, fixed = false }", "upper = 1000.0, fixd = false }", {"fit.classes.compact.alpha.fixd"});
  f.expect_error("label = \"plunge\"", "label = \"plunge\"\n  weight = 2", {"recordings[0].segments[0].weight"});
}

TEST(FormatsManifest, RotationsMustBeProper) {
  Files f;
  f.expect_error("rotation = [[1,0,0],[0,1,0],[0,0,1]]", "rotation = [[1,0,0],[0,1,0],[0,0,-1]]",
                 {"E.toml: recordings[0].registration.rotation: expected a proper rotation (orthonormal, det +1)",
                  "det = -1"});
  f.expect_error("rotation = [[1,0,0],[0,1,0],[0,0,1]]", "rotation = [[1,0.1,0],[0,1,0],[0,0,1]]",
                 {"recordings[0].registration.rotation", "proper rotation"});
  f.expect_error("[[0,-1,0],[1,0,0],[0,0,1]]", "[[2,0,0],[0,1,0],[0,0,1]]",
                 {"sensor.rotation_sensor_to_rig", "proper rotation"});
  f.expect_error("rotation = [[1,0,0],[0,1,0],[0,0,1]]", "rotation = [[1,0,0],[0,1,0]]",
                 {"recordings[0].registration.rotation", "3×3"});
}

TEST(FormatsManifest, FiducialsNeedThreeNonCollinearPairs) {
  Files f;
  f.expect_error("fiducials_rig_mm = [[0,0,0],[10,0,0],[0,10,0],[0,0,10]]",
                 "fiducials_rig_mm = [[0,0,0],[10,0,0],[20,0,0],[30,0,1e-6]]",
                 {"E.toml: recordings[1].registration.fiducials_rig_mm: expected at least 3 non-collinear points"});
  f.expect_error("fiducials_vol_mm = [[1,1,1],[11,1,1],[1,11,1],[1,1,11]]",
                 "fiducials_vol_mm = [[1,1,1],[1,1,1],[1,1,1],[1,1,1]]",
                 {"recordings[1].registration.fiducials_vol_mm", "non-collinear"});
  f.expect_error("fiducials_rig_mm = [[0,0,0],[10,0,0],[0,10,0],[0,0,10]]",
                 "fiducials_rig_mm = [[0,0,0],[10,0,0],[0,10,0]]",
                 {"recordings[1].registration.fiducials_vol_mm", "3 points (as many as fiducials_rig_mm)"});
  f.expect_error("fiducials_rig_mm = [[0,0,0],[10,0,0],[0,10,0],[0,0,10]]\n  fiducials_vol_mm = [[1,1,1],[11,1,1],[1,11,1],[1,1,11]]",
                 "fiducials_rig_mm = [[0,0,0],[10,0,0]]\n  fiducials_vol_mm = [[1,1,1],[11,1,1]]",
                 {"recordings[1].registration.fiducials_rig_mm", "at least 3 point pairs"});
}

TEST(FormatsManifest, BoundsAndSegments) {
  Files f;
  f.expect_error("c1    = { initial = 10.0, lower = 0.01, upper = 1000.0 }",
                 "c1    = { initial = 10.0, lower = 1000.0, upper = 0.01 }",
                 {"E.toml: fit.classes.compact.c1: expected lower < initial < upper"});
  f.expect_error("mu    = { initial = 0.3,  lower = 0.01, upper = 2.0 }",
                 "mu    = { initial = 3.0,  lower = 0.01, upper = 2.0 }", {"fit.classes.compact.mu", "lower < initial < upper"});
  f.expect_error("mu    = { initial = 0.3,  lower = 0.01, upper = 2.0 }",
                 "mu    = { initial = 0.3,  lower = -1, upper = 2.0 }", {"fit.classes.compact.mu"});
  f.expect_error("alpha = { initial = 20.0, lower = 0.1, upper = 1000.0, fixed = false }",
                 "alpha = { initial = inf, lower = 0.1, upper = 1000.0, fixed = false }",
                 {"fit.classes.compact.alpha.initial", "inf only when fixed"});
  f.expect_error("end_s = 5.0", "end_s = -1.0", {"E.toml: recordings[0].segments[0]: expected start_s < end_s"});
  f.expect_error("lag_bounds_ms = [-20.0, 20]", "lag_bounds_ms = [20.0, -20]", {"fit.nuisance.lag_bounds_ms"});
  f.expect_error("lag_ms = 1.5", "lag_ms = 25.0", {"recordings[0].lag_ms", "lag_bounds_ms"});
  f.expect_error("multistart = 4", "multistart = 0", {"fit.multistart"});
  f.expect_error("mu = 0.05", "mu = 0", {"E.toml: fit.precision.mu: expected a relative half-width", "got 0"});
  f.expect_error("loss = \"cauchy\"", "loss = \"l1\"", {"fit.loss: expected none | huber | cauchy, got \"l1\""});
}

TEST(FormatsManifest, ReferencesAndFiles) {
  Files f;
  f.expect_error("path = \"../data/plunge.h5\"\nsample = \"S1\"\nrole = \"calibrate\"",
                 "path = \"../data/nope.h5\"\nsample = \"S1\"\nrole = \"calibrate\"",
                 {"E.toml: recordings[0].path: expected an existing file", "nope.h5"});
  f.expect_error("path = \"../data/sample.h5\"", "path = \"sample.h5\"", {"samples[0].path", "existing file"});
  f.expect_error("sample = \"S1\"\nrole = \"validate\"", "sample = \"S9\"\nrole = \"validate\"",
                 {"recordings[1].sample: expected the id of a [[samples]] entry, got \"S9\""});
  f.expect_error("id = \"sweep\"", "id = \"plunge\"", {"recordings[1].id", "unique"});
  f.expect_error("[fit.classes.compact]", "[fit.classes.cortical]", {"fit.classes.cortical", "class table"});
  f.expect_error("shaft_axis_rig = [0.0, 0.0, 2.0]", "shaft_axis_rig = [0.0, 0.0, 0.0]",
                 {"burr.shaft_axis_rig", "non-zero"});
  f.expect_error("spin_sign = -1", "spin_sign = 0", {"burr.spin_sign", "+1 or -1"});
  f.expect_error("radius_mm = 1.0", "radius_mm = nan", {"burr.radius_mm", "finite"});
  f.expect_error("radius_mm = 1.0", "radius_mm = \"1.0\"", {"burr.radius_mm: expected a number, got a string"});
  f.expect_error("[burr]", "[burr\n", {"E.toml: line", "valid TOML"});
  // The manifest bytes are never touched by a failed read.
  const std::string before = burrbench::test::file_bytes(f.manifest);
  expect_input_error([&] { bb::read_manifest(f.manifest); }, {"E.toml"});
  EXPECT_EQ(before, burrbench::test::file_bytes(f.manifest));
}

TEST(FormatsManifest, ParseFromTextNamesTheGivenPath) {
  Files f;
  const auto m = bb::parse_manifest(kBase, f.dir / "exp" / "virtual.toml");
  EXPECT_EQ(m.recordings.size(), 2u);
  expect_input_error([&] { bb::parse_manifest("format = 1", f.dir / "exp" / "virtual.toml"); },
                     {"virtual.toml: format: expected a string, got an integer"});
}

// Seeded corruption (truncation, byte flips, duplicated spans): every outcome is a
// manifest or an InputError — never another exception or a crash.
TEST(FormatsManifest, CorruptedTextOnlyEverRaisesInputError) {
  Files f;
  const std::string base = kBase;
  std::uint64_t state = 12345;
  auto next = [&] { return state = state * 6364136223846793005ull + 1442695040888963407ull, state >> 33; };
  int ok = 0, rejected = 0;
  for (int i = 0; i < 400; ++i) {
    std::string t = base;
    switch (next() % 3) {
      case 0: t.resize(next() % t.size()); break;
      case 1:
        for (int k = 0; k < 4; ++k) t[next() % t.size()] = char(next() % 256);
        break;
      default: {
        const std::size_t a = next() % t.size(), n = next() % 40;
        t.insert(next() % t.size(), t.substr(a, n));
      }
    }
    try {
      bb::parse_manifest(t, f.dir / "exp" / "fuzz.toml");
      ++ok;
    } catch (const burrbench::InputError& e) {
      EXPECT_NE(std::string(e.what()).find("fuzz.toml: "), std::string::npos) << e.what();
      ++rejected;
    }
  }
  EXPECT_GT(rejected, 200);
  EXPECT_GT(ok, 0);  // some corruptions leave a valid manifest: the corruptor is not all-destroying
}

// Issue 59, D14: bounds the wrong way round are the bounds' fault, not a recording's lag;
// N5: bounds of ±1e308 ms passed (Ceres then failed on −inf and calibrate exited 0).
TEST(FormatsManifest, LagBoundsAreCheckedAsBoundsFirst) {
  Files f;
  f.expect_error("lag_bounds_ms = [-20.0, 20]", "lag_bounds_ms = [20.0, -20]",
                 {"E.toml: fit.nuisance.lag_bounds_ms: expected [lower, upper] with lower < upper"});
  f.expect_error("lag_bounds_ms = [-20.0, 20]", "lag_bounds_ms = [-1e308, 1e308]",
                 {"E.toml: fit.nuisance.lag_bounds_ms: expected [lower, upper] within ±10000 ms"});
  f.expect_error("lag_bounds_ms = [-20.0, 20]", "lag_bounds_ms = [-20.0, inf]", {"E.toml: fit.nuisance.lag_bounds_ms: expected"});
  EXPECT_EQ(f.read_with("lag_bounds_ms = [-20.0, 20]", "lag_bounds_ms = [-10000.0, 10000]").fit.nuisance.lag_bounds_ms[1],
            10000.0);
}

// Issue 59, N4: an id with a '/', a newline or a NUL passed `inspect` and failed at the end
// of the run naming a hidden staging file; it is refused when the manifest is read.
TEST(FormatsManifest, IdsThatWouldNameNoFileAreRefusedOnRead) {
  Files f;
  f.expect_error("id = \"plunge\"", "id = \"a/b\"", {"E.toml: recordings[0].id: expected an id without '/'", "\"a/b\""});
  f.expect_error("id = \"plunge\"", "id = \"a\\nb\"", {"E.toml: recordings[0].id: expected", "\"a\\x0ab\""});
  f.expect_error("id = \"plunge\"", "id = \"a\\u0000b\"", {"E.toml: recordings[0].id: expected", "\\x00"});
  f.expect_error("id = \"plunge\"", "id = \"..\"", {"E.toml: recordings[0].id: expected"});
  f.expect_error("id = \"S1\"", "id = \"S/1\"", {"E.toml: samples[0].id: expected an id without '/'"});
}

// Issue 59, N3: burr.radius_mm = 1e308 (with the recordings' radius waived) replayed to NaN
// and blamed the output's staging file.
TEST(FormatsManifest, BurrRadiusIsBounded) {
  Files f;
  f.expect_error("radius_mm = 1.0", "radius_mm = 1e308", {"E.toml: burr.radius_mm: expected a finite radius > 0 and ≤ 100 mm"});
  EXPECT_EQ(f.read_with("radius_mm = 1.0", "radius_mm = 100.0").burr.radius_mm, 100.0);
}
