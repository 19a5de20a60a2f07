// Writes the synthetic calibration experiments the calibration benchmarks run on (see
// bench/calibration.sh): `bench_calibration_reference DIR BURRBENCH SEED TIME_SCALE [layered]`
// (layered: the held-out case of tests/calibration/layered_fixture.hpp; TIME_SCALE unused).
// Not a Google Benchmark timing loop: the figures (wall time, replays/s, iterations,
// interval coverage) come from running `burrbench calibrate` on what this writes.
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "../tests/calibration/layered_fixture.hpp"

int main(int argc, char** argv) {
  if (argc != 5 && !(argc == 6 && std::string(argv[5]) == "layered")) {
    std::fprintf(stderr, "usage: %s DIR BURRBENCH SEED TIME_SCALE [layered]\n", argv[0]);
    return 2;
  }
  try {
    if (argc == 6) {
      burrbench::calibration::testing::LayeredSpec s;
      s.seed = std::strtoull(argv[3], nullptr, 10);
      const auto m = burrbench::calibration::testing::make_layered_experiment(argv[1], s, argv[2]);
      std::printf("%s\n", m.c_str());
      return 0;
    }
    burrbench::calibration::testing::ReferenceSpec s;
    s.seed = std::strtoull(argv[3], nullptr, 10);
    s.time_scale = std::atof(argv[4]);
    const auto m = burrbench::calibration::testing::make_reference_experiment(argv[1], s, argv[2]);
    std::printf("%s\n", m.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  return 0;
}
