#pragma once
// How the fit obtains the Jacobian of the replayed force: a public option of `calibrate`
// (CalibrateOptions::derivatives, the CLI's and Python's `derivatives`), and what each
// internal RecordingModel is asked to use (docs/calibration.md "Derivatives").
namespace burrbench::calibration {

enum class Derivatives {
  kSensitivities,      // forward sensitivities carried through the replay (exact, one replay)
  kFiniteDifferences,  // central differences of whole replays (steps from cost sweeps)
};
const char* to_string(Derivatives d);  // "sensitivities" | "fd"

}  // namespace burrbench::calibration
