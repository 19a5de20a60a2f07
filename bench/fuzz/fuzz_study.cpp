// libFuzzer target: read_study (a study manifest TOML: criteria, fit options, specimens,
// each specimen's experiment manifest read and validated too). The scratch folder holds
// what the seeds name: criteria.toml, S1/experiment.toml and the files that manifest names.
#include <filesystem>
#include <fstream>

#include "burrbench/study/study_manifest.hpp"
#include "fuzz_file.hpp"

namespace {
constexpr const char* kExperiment = R"(format = "burrbench.experiment"
format_version = "1.0"
name = "specimen"
[[samples]]
id = "S1"
path = "sample.h5"
[burr]
radius_mm = 1.0
[sensor]
rotation_sensor_to_rig = [[1,0,0],[0,1,0],[0,0,1]]
[[recordings]]
id = "plunge"
path = "plunge.h5"
sample = "S1"
role = "calibrate"
  [recordings.registration]
  rotation = [[1,0,0],[0,1,0],[0,0,1]]
  translation_mm = [0.0, 0.0, 0.0]
)";

const std::filesystem::path& folder() {
  static const std::filesystem::path d = [] {
    using burrbench::fuzz::scratch;
    std::filesystem::create_directories(scratch() / "S1");
    std::ofstream(scratch() / "S1" / "experiment.toml") << kExperiment;
    for (const char* f : {"S1/sample.h5", "S1/plunge.h5", "criteria.toml"}) std::ofstream(scratch() / f) << "x";
    return scratch();
  }();
  return d;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace burrbench::fuzz;
  folder();
  const auto path = put("study.toml", as_text(data, size));
  return expect_input_errors_only([&] { burrbench::study::read_study(path); });
}
