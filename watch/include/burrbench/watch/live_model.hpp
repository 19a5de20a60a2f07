#pragma once
// The model following a recording as it grows: aligns everything recorded so far (as the
// batch replay would: model::align_recording, the fit's lag, depth offset and pose),
// replays the force samples whose burr position the stage has already logged, and gives
// what the page and the alarms need per sample.
#include <cmath>
#include <cstddef>
#include <filesystem>
#include <glm/glm.hpp>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "burrbench/data_schema/fit_result.hpp"
#include "burrbench/data_schema/manifest.hpp"
#include "burrbench/data_schema/parameter_set.hpp"
#include "burrbench/data_schema/recording.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/watch/alarms.hpp"
#include "burrbench/watch/incremental_replay.hpp"

namespace burrbench::watch {

// The experiment manifest, where the recording `recording_id` may not exist yet (it is
// being acquired; read_manifest refuses a listed file that does not exist). Every other
// check is read_manifest's, and every other listed file must exist.
data_schema::ExperimentManifest read_manifest_while_acquiring(const std::filesystem::path& manifest,
                                                              const std::string& recording_id);

struct LiveSettings {
  double step_s = 0;   // 0: half the median interval of the first force samples
  double sigma_N = 0;  // the band's σ per axis; 0: the fit's, else the live tare's
  std::size_t tare_samples =
      50;  // the session's first force samples the live tare takes (burr in air)
  AlarmSettings alarms;
};

struct LivePoint {
  std::size_t index = 0;                     // force sample (aligned recording)
  double t_s = 0;                            // recording clock (0 = first force sample)
  double wall_ms = 0;                        // when it was acquired, ms since the Unix epoch
  glm::dvec3 measured_N{0}, predicted_N{0};  // sensor frame; measured minus the bias
  double depth_b_mm = 0;
  glm::dvec3 centre_vol_mm{0};
  // Where logged (else NaN): the moment at the sensor (N·mm, sensor frame; measured minus
  // its bias) and the spindle's load torque (N·mm, braking; measured minus its idle load).
  glm::dvec3 torque_measured_Nmm{NAN}, torque_predicted_Nmm{NAN};
  double spindle_measured_Nmm = NAN, spindle_predicted_Nmm = NAN;
};

struct LiveStep {
  std::vector<LivePoint> points;  // newly replayed (the first may revise the previous last)
  std::vector<Alarm> alarms;
  double replayed_to_s = 0, recorded_to_s = 0;  // how far the model and the journal are
  std::size_t waiting = 0;  // force samples ready (position logged), not replayed yet
};

class LiveModel {
 public:
  // InputError (naming the manifest) when `recording_id` is not in it, or the parameter
  // set does not cover the sample's classes.
  LiveModel(data_schema::ExperimentManifest manifest, const std::string& recording_id,
            const data_schema::ParameterSet& params, std::optional<data_schema::FitResult> fit,
            const LiveSettings& settings);
  ~LiveModel();
  // `rec`: everything recorded so far. Replays at most `max_samples` new force samples.
  // Until the recording can be aligned (a stream without samples yet) it returns nothing.
  LiveStep advance(const data_schema::Recording& rec, std::size_t max_samples);

  const data_schema::RecordingRef& ref() const { return ref_; }
  const data_schema::SampleVolume& sample() const { return sample_; }
  double sigma_N() const { return sigma_N_; }  // 0 until known
  const glm::dvec3& bias_N() const { return bias_N_; }
  double step_s() const;  // 0 until chosen
  std::size_t replayed() const;
  const std::string& sigma_source() const { return sigma_source_; }
  const std::string& bias_source() const { return bias_source_; }
  // The band is known once σ and the bias are: until then no alarm can fire.
  bool band_known() const { return bias_known_ && sigma_N_ > 0; }

 private:
  void start(const model::AlignedRecording& r);
  void tare(const LivePoint& p, const glm::dvec3& raw_measured_N);
  // The moment's bias and the spindle's idle load: the fit's, else the mean of the
  // session's first tare_samples samples (the burr spinning in air).
  void wrench(const model::AlignedRecording& r, const model::ContactResult& c,
              const model::Trajectory& tr, const model::PoseCorrection* pose, bool fresh,
              LivePoint& p);

  data_schema::ExperimentManifest manifest_;
  data_schema::RecordingRef ref_;
  data_schema::SampleVolume sample_;
  model::ModelParams params_;
  std::optional<data_schema::FitResult> fit_;
  LiveSettings settings_;
  std::unique_ptr<IncrementalReplay> replay_;
  AlarmMonitor alarms_;
  double sigma_N_ = 0;
  std::string sigma_source_, bias_source_;
  glm::dvec3 bias_N_{0};
  bool bias_known_ = false;
  std::size_t judged_ = 0;  // samples the tare and the alarms have seen
  std::optional<glm::dvec3> torque_bias_Nmm_;
  std::optional<double> spindle_idle_Nmm_;
  glm::dvec3 torque_sum_Nmm_{0};
  double spindle_sum_Nmm_ = 0;
  std::size_t offsets_n_ = 0;
  std::vector<glm::dvec3> free_;  // the live tare's measured forces
};

}  // namespace burrbench::watch
