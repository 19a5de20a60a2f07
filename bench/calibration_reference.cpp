// Writes the synthetic calibration experiments the calibration benchmarks run on (see
// bench/calibration.sh): `bench_calibration_reference DIR BURRBENCH SEED TIME_SCALE [MODE]`.
// MODE layered: the held-out case of tests/calibration/layered_fixture.hpp (TIME_SCALE
// unused); MODE fine: also writes the same sample at 0.05 mm voxels (sample_fine.h5, the
// same geometry: every 0.1 mm voxel split into 8) and experiment_fine.toml using it;
// MODE wrench: the recordings also carry the model's moments and spindle load, and
// experiment_wrench.toml fits them (printed instead of experiment.toml);
// MODE registration: the reference case seen from a rig frame rotated 37° and offset,
// registered from four fiducials with 5 µm of noise drawn from SEED
// (tests/calibration/registration_fixture.hpp).
// Not a Google Benchmark timing loop: the figures (wall time, replays/s, iterations,
// interval coverage) come from running `burrbench calibrate` on what this writes.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <sstream>
#include <string>

#include "../tests/calibration/layered_fixture.hpp"
#include "../tests/calibration/registration_fixture.hpp"

int main(int argc, char** argv) {
  const std::string mode = argc == 6 ? argv[5] : "";
  if (argc != 5 && !(argc == 6 && (mode == "layered" || mode == "fine" || mode == "registration" || mode == "wrench"))) {
    std::fprintf(stderr, "usage: %s DIR BURRBENCH SEED TIME_SCALE [layered|fine|registration|wrench]\n", argv[0]);
    return 2;
  }
  try {
    if (mode == "layered") {
      burrbench::calibration::testing::LayeredSpec s;
      s.seed = std::strtoull(argv[3], nullptr, 10);
      const auto m = burrbench::calibration::testing::make_layered_experiment(argv[1], s, argv[2]);
      std::printf("%s\n", m.c_str());
      return 0;
    }
    burrbench::calibration::testing::ReferenceSpec s;
    s.seed = std::strtoull(argv[3], nullptr, 10);
    s.time_scale = std::atof(argv[4]);
    if (mode == "registration") {
      burrbench::calibration::testing::RegistrationSpec r;
      r.reference = s;
      r.fiducial_seed = s.seed;
      const auto c = burrbench::calibration::testing::make_registration_experiment(argv[1], r, argv[2]);
      std::printf("%s\n", c.manifest.c_str());
      return 0;
    }
    s.wrench = mode == "wrench";
    const auto m = burrbench::calibration::testing::make_reference_experiment(argv[1], s, argv[2]);
    if (mode == "wrench") {
      std::printf("%s\n", (std::filesystem::path(argv[1]) / "experiment_wrench.toml").c_str());
      return 0;
    }
    if (mode == "fine") {
      namespace fs = std::filesystem;
      auto fine = s;
      fine.voxel_mm = 0.05;
      burrbench::data_schema::write_sample(fs::path(argv[1]) / "sample_fine.h5",
                                           burrbench::calibration::testing::reference_sample(fine));
      std::ifstream in(m);
      std::stringstream ss;
      ss << in.rdbuf();
      std::string t = ss.str();
      t.replace(t.find("path = \"sample.h5\""), 18, "path = \"sample_fine.h5\"");
      const fs::path mf = fs::path(argv[1]) / "experiment_fine.toml";
      burrbench::calibration::testing::write_text(mf, t);
      std::printf("%s\n", mf.c_str());
      return 0;
    }
    std::printf("%s\n", m.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
