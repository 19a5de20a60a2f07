// Replaying an aligned recording and writing the prediction: the HDF5 file through
// data_schema (format "burrbench.prediction", docs/formats.md) and an optional CSV.
#include <fmt/format.h>

#include <fstream>
#include <map>

#include "burrbench/data_schema/atomic_file.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/experiment.hpp"

namespace burrbench::model {

std::vector<RecordingPrediction> predict_experiment(
    const Experiment& e, const ModelParams& params, const ReplayOptions& options,
    const std::function<std::unique_ptr<Progress>(const AlignedRecording&)>& progress_for) {
  std::map<std::string, Volume> volumes;
  std::vector<RecordingPrediction> out;
  for (const auto& r : e.recordings) {
    auto it = volumes.find(r.sample_id);
    if (it == volumes.end()) it = volumes.emplace(r.sample_id, Volume::from_sample(e.samples.at(r.sample_id))).first;
    const auto progress = progress_for ? progress_for(r) : nullptr;
    out.push_back(predict(r, it->second, params, options, progress.get()));
  }
  return out;
}

RecordingPrediction predict(const AlignedRecording& r, Volume& volume, const ModelParams& params,
                            const ReplayOptions& options, Progress* progress) {
  const Trajectory tr = r.trajectory();
  const ReplayResult res = replay(volume, r.radius_mm, params, tr, options, true, progress);
  RecordingPrediction p;
  p.recording_id = r.id;
  p.registration_method = r.registration.method;
  p.registration_rms_mm = r.registration.rms_mm;
  p.registration_max_mm = r.registration.max_mm;
  p.fiducial_error_mm = r.registration.method == "fiducials" ? r.registration.fle_mm : NAN;
  p.tre_path_rms_mm = r.registration.tre_path_rms_mm;
  p.tre_path_max_mm = r.registration.tre_path_max_mm;
  p.t_s = tr.t_s;
  p.centre_vol_mm = tr.centre_vol_mm;
  p.force_sensor_meas_N = r.force_sensor_N;
  p.use = r.use;
  p.removed_mm3 = res.removed_mm3;
  p.steps = static_cast<std::int64_t>(res.steps);
  p.wall_s = res.wall_s;
  const std::size_t n = res.samples.size();
  p.force_burr_vol_N.resize(n);
  p.force_sensor_pred_N.resize(n);
  p.normal_vol.resize(n);
  p.depth_b_mm.resize(n);
  p.class_mask.resize(n);
  p.buried.resize(n);
  p.moment_burr_vol_Nmm.resize(n);
  p.torque_sensor_pred_Nmm.resize(n);
  p.spindle_torque_pred_Nmm.resize(n);
  p.torque_sensor_meas_Nmm = r.torque_sensor_Nmm;
  if (!r.spindle_torque_Nmm.t_s.empty())
    for (double t : tr.t_s) p.spindle_torque_meas_Nmm.push_back(r.spindle_torque_Nmm.at(t));
  for (std::size_t k = 0; k < n; ++k) {
    const ContactResult& c = res.samples[k].contact;
    p.force_burr_vol_N[k] = c.force_N;
    p.force_sensor_pred_N[k] = r.sensor_force_from_burr_force(c.force_N);
    p.normal_vol[k] = c.normal;
    p.depth_b_mm[k] = c.depth_b_mm;
    p.class_mask[k] = c.class_mask;
    p.buried[k] = c.buried ? 1 : 0;
    p.moment_burr_vol_Nmm[k] = c.moment_Nmm;
    p.torque_sensor_pred_Nmm[k] = r.sensor_torque_from_burr_wrench(c.force_N, c.moment_Nmm, tr.centre_vol_mm[k]);
    p.spindle_torque_pred_Nmm[k] = spindle_torque_Nmm(c.moment_Nmm, tr.omega_vol_rad_s[k]);
  }
  return p;
}

static_assert(std::size_t(kMaxClasses) == data_schema::kPredictionClasses,
              "the prediction file records removed volume for every model class label");

void write_prediction(const std::filesystem::path& path,
                      const std::vector<RecordingPrediction>& preds, const Provenance& prov) {
  data_schema::Prediction file;
  file.provenance = prov;
  file.recordings.assign(preds.begin(), preds.end());  // the records without wall_s
  data_schema::write_prediction(path, file);
}

void write_prediction_csv(const std::filesystem::path& path,
                          const std::vector<RecordingPrediction>& preds) {
  data_schema::AtomicFile out(path);
  out << "recording,t_s,Fburr_x_N,Fburr_y_N,Fburr_z_N,Fpred_x_N,Fpred_y_N,Fpred_z_N,"
         "Fmeas_x_N,Fmeas_y_N,Fmeas_z_N,b_mm,n_x,n_y,n_z,class_mask,buried,use,"
         "Tburr_x_Nmm,Tburr_y_Nmm,Tburr_z_Nmm,Mpred_x_Nmm,Mpred_y_Nmm,Mpred_z_Nmm,"
         "Mmeas_x_Nmm,Mmeas_y_Nmm,Mmeas_z_Nmm,spindle_pred_Nmm,spindle_meas_Nmm\n";
  // The wrench columns are empty where the prediction has none (nothing measured).
  auto v3 = [](const std::vector<glm::dvec3>& v, std::size_t k) {
    return k < v.size() ? fmt::format("{:.9g},{:.9g},{:.9g}", v[k].x, v[k].y, v[k].z) : std::string(",,");
  };
  auto v1 = [](const std::vector<double>& v, std::size_t k) {
    return k < v.size() ? fmt::format("{:.9g}", v[k]) : std::string();
  };
  for (const auto& p : preds)
    for (std::size_t k = 0; k < p.t_s.size(); ++k) {
      const auto &fb = p.force_burr_vol_N[k], &fp = p.force_sensor_pred_N[k],
                 &fm = p.force_sensor_meas_N[k], &n = p.normal_vol[k];
      out << fmt::format(
          "{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},"
          "{:.9g},{:.9g},{:.9g},{},{},{},{},{},{},{},{}\n",
          p.recording_id, p.t_s[k], fb.x, fb.y, fb.z, fp.x, fp.y, fp.z, fm.x, fm.y, fm.z,
          p.depth_b_mm[k], n.x, n.y, n.z, int(p.class_mask[k]), int(p.buried[k]), int(p.use[k]),
          v3(p.moment_burr_vol_Nmm, k), v3(p.torque_sensor_pred_Nmm, k), v3(p.torque_sensor_meas_Nmm, k),
          v1(p.spindle_torque_pred_Nmm, k), v1(p.spindle_torque_meas_Nmm, k));
    }
  out.commit();
}

}  // namespace burrbench::model
