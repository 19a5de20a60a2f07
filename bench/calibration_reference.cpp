// Writes the synthetic calibration experiments the calibration benchmarks run on (see
// bench/calibration.sh): `bench_calibration_reference DIR BURRBENCH SEED TIME_SCALE`.
// Not a Google Benchmark timing loop: the figures (wall time, replays/s, iterations,
// interval coverage) come from running `burrbench calibrate` on what this writes.
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "../tests/calibration/reference_fixture.hpp"

int main(int argc, char** argv) {
  if (argc != 5) {
    std::fprintf(stderr, "usage: %s DIR BURRBENCH SEED TIME_SCALE\n", argv[0]);
    return 2;
  }
  try {
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
