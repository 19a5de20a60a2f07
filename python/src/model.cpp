// The model from Python: a Volume (from a sample file or numpy arrays), the contact
// kernel at one burr position, and the replay of an experiment (what `burrbench replay`
// computes, bit for bit, through model::predict_experiment). No GIL while C++ works.
#include <cmath>
#include <filesystem>
#include <memory>
#include <string>

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include "arguments.hpp"
#include "bindings.hpp"
#include "burrbench/data_schema/error.hpp"
#include "burrbench/data_schema/sample_volume.hpp"
#include "burrbench/model/contact.hpp"
#include "burrbench/model/experiment.hpp"
#include "burrbench/model/model_params.hpp"
#include "burrbench/model/volume.hpp"
#include "convert.hpp"
#include "interruptible.hpp"
#include "overlap_warnings.hpp"

namespace burrbench::python {
namespace fs = std::filesystem;

namespace {

// The sample (for its class names) and the model's volume built from it.
struct PyVolume {
  data_schema::SampleVolume sample;
  model::Volume volume;
};

py::dict prediction_dict(const model::RecordingPrediction& p) {
  py::dict d;
  d["t_s"] = array(p.t_s);
  d["force_burr_vol_N"] = vec3_array(p.force_burr_vol_N);
  d["force_sensor_pred_N"] = vec3_array(p.force_sensor_pred_N);
  d["force_sensor_meas_N"] = vec3_array(p.force_sensor_meas_N);
  d["centre_vol_mm"] = vec3_array(p.centre_vol_mm);
  d["normal_vol"] = vec3_array(p.normal_vol);
  d["depth_b_mm"] = array(p.depth_b_mm);
  d["class_mask"] = array(p.class_mask);
  d["buried"] = array(p.buried);
  d["use"] = array(p.use);
  d["moment_burr_vol_Nmm"] = vec3_array(p.moment_burr_vol_Nmm);
  d["torque_sensor_pred_Nmm"] = vec3_array(p.torque_sensor_pred_Nmm);
  d["torque_sensor_meas_Nmm"] = vec3_array(p.torque_sensor_meas_Nmm);
  d["spindle_torque_pred_Nmm"] = array(p.spindle_torque_pred_Nmm);
  d["spindle_torque_meas_Nmm"] = array(p.spindle_torque_meas_Nmm);
  d["removed_mm3"] = array(std::vector<double>(p.removed_mm3.begin(), p.removed_mm3.end()));
  d["friction_energy_mJ"] = array(std::vector<double>(p.friction_energy_mJ.begin(), p.friction_energy_mJ.end()));
  d["steps"] = p.steps;
  d["registration_method"] = p.registration_method;
  d["role"] = p.role;
  d["used_calibrate"] = array(p.used_calibrate);
  d["used_validate"] = array(p.used_validate);
  d["lag_ms"] = p.lag_ms;
  d["depth_offset_mm"] = p.depth_offset_mm;
  d["force_bias_N"] = array(std::vector<double>{p.force_bias_N.x, p.force_bias_N.y, p.force_bias_N.z});
  d["force_bias_source"] = p.force_bias_source;
  return d;
}

py::array_t<double> per_class(const std::array<glm::dvec3, model::kMaxClasses>& v) {
  return vec3_array(std::vector<glm::dvec3>(v.begin(), v.end()));
}

void bind_volume(py::module_& m) {
  py::class_<PyVolume, std::shared_ptr<PyVolume>>(m, "Volume",
                                                  "A CT voxel volume: class label and bone fraction per voxel.")
      .def_static(
          "from_sample",
          [](const fs::path& path) {
            auto v = std::make_shared<PyVolume>();
            py::gil_scoped_release nogil;
            v->sample = data_schema::read_sample(path);
            v->volume = model::Volume::from_sample(v->sample);
            return v;
          },
          py::arg("path"), "From a sample file (format burrbench.sample).")
      .def_static(
          "from_arrays",
          [](const py::array& labels_in, py::array_t<float, py::array::c_style | py::array::forcecast> chi,
             double voxel_mm, const py::object& origin_mm, std::map<int, std::string> classes) {
            // Labels must be integers 0..255 as given: a cast to uint8 would turn 1.7 into 1
            // and 300 into 44 without a word.
            const char kind = labels_in.dtype().kind();
            if (kind != 'u' && kind != 'i')
              throw InputError("Volume.from_arrays", "labels", "an integer array (uint8: 0 = empty, 1..255 a class)",
                               py::str(labels_in.dtype()).cast<std::string>());
            const auto wide = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>::ensure(labels_in);
            for (py::ssize_t i = 0; i < wide.size(); ++i)
              if (wide.data()[i] < 0 || wide.data()[i] > 255)
                throw InputError("Volume.from_arrays", fmt::format("labels (flat index {})", i), "a label 0..255",
                                 std::to_string(wide.data()[i]));
            const auto labels = py::array_t<std::uint8_t, py::array::c_style | py::array::forcecast>::ensure(labels_in);
            if (labels.ndim() != 3 || chi.ndim() != 3)
              throw InputError("Volume.from_arrays", "labels, chi", "3-D arrays indexed [z, y, x]");
            for (int k = 0; k < 3; ++k)
              if (labels.shape(k) != chi.shape(k))
                throw InputError("Volume.from_arrays", "chi", "the shape of labels");
            auto v = std::make_shared<PyVolume>();
            auto& s = v->sample;
            s.dims = {std::size_t(labels.shape(2)), std::size_t(labels.shape(1)), std::size_t(labels.shape(0))};
            s.voxel_mm = voxel_mm;
            s.origin_mm = to_vec3(origin_mm, "Volume.from_arrays", "origin_mm");
            s.labels.assign(labels.data(), labels.data() + labels.size());
            s.fraction.assign(chi.data(), chi.data() + chi.size());
            s.classes.clear();
            for (const auto& [label, name] : classes) {
              if (label < 1 || label > 255) throw InputError("Volume.from_arrays", "classes", "labels 1..255");
              s.classes[std::uint8_t(label)] = name;
            }
            data_schema::validate(s, "Volume.from_arrays");
            v->volume = model::Volume::from_sample(s);
            return v;
          },
          py::arg("labels"), py::arg("chi"), py::arg("voxel_mm"), py::arg("origin_mm"),
          py::arg("classes") = std::map<int, std::string>{{1, "compact"}, {2, "trabecular"}},
          "From numpy arrays indexed [z, y, x]: labels (uint8, 0 = empty), chi (bone fraction 0..1), "
          "the voxel side (mm) and the centre of voxel (0, 0, 0) in the volume frame (mm).")
      .def_property_readonly("shape_zyx", [](const PyVolume& v) {
        const auto& d = v.volume.dims();
        return py::make_tuple(d[2], d[1], d[0]);
      })
      .def_property_readonly("voxel_mm", [](const PyVolume& v) { return v.volume.voxel_mm(); })
      .def_property_readonly("origin_mm", [](const PyVolume& v) { return vec3_array({v.volume.origin_mm()}).attr("reshape")(3); })
      .def_property_readonly("classes", [](const PyVolume& v) {
        std::map<int, std::string> c;
        for (const auto& [k, n] : v.sample.classes) c[k] = n;
        return c;
      })
      .def(
          "chi",
          [](const PyVolume& v) {
            const auto& d = v.volume.dims();
            py::array_t<double> a({py::ssize_t(d[2]), py::ssize_t(d[1]), py::ssize_t(d[0])});
            double* out = a.mutable_data();
            for (std::size_t i = 0; i < v.volume.dims()[0] * d[1] * d[2]; ++i) out[i] = v.volume.chi(i);
            return a;
          },
          "The bone fraction per voxel now, [z, y, x].");

}

void bind_contact(py::module_& m) {
  m.def(
      "contact",
      [](const PyVolume& v, const py::object& params, const py::object& p_mm, const py::object& omega_rad_s,
         const py::object& radius_arg) {
        const model::ModelParams mp = model::ModelParams::from(to_parameter_set(params));
        const glm::dvec3 p = to_vec3(p_mm, "contact()", "p_mm"), w = to_vec3(omega_rad_s, "contact()", "omega_rad_s");
        const double radius_mm = as_float("contact()", "radius_mm", radius_arg);
        if (!(radius_mm > 0) || !std::isfinite(radius_mm))
          throw InputError("contact()", "radius_mm", "a burr radius > 0 (mm)", shown(radius_arg));
        model::ContactResult c;
        {
          py::gil_scoped_release nogil;
          c = model::evaluate(v.volume, p, w, radius_mm, mp);
        }
        py::dict d;
        d["force_N"] = vec3_array({c.force_N}).attr("reshape")(3);
        d["elastic_N"] = vec3_array({c.elastic_N}).attr("reshape")(3);
        d["friction_N"] = vec3_array({c.friction_N}).attr("reshape")(3);
        d["moment_Nmm"] = vec3_array({c.moment_Nmm}).attr("reshape")(3);
        d["normal"] = vec3_array({c.normal}).attr("reshape")(3);
        d["depth_b_mm"] = c.depth_b_mm;
        d["bone_volume_mm3"] = c.bone_volume_mm3;
        d["contact_radius_mm"] = c.contact_radius_mm;
        d["power_Nmm_per_s"] = c.power_W_mJ_per_s;
        d["class_mask"] = int(c.class_mask);
        d["buried"] = c.buried;
        d["dF_dC1"] = per_class(c.dF_dC1);
        d["dFmu_dmu"] = per_class(c.dFmu_dmu);
        d["dTmu_dmu"] = per_class(c.dTmu_dmu);
        return d;
      },
      py::arg("volume"), py::arg("params"), py::arg("p_mm"), py::arg("omega_rad_s"), py::arg("radius_mm"),
      "The contact of a burr of radius R (mm) centred at p (mm, volume frame) spinning at omega (rad/s): "
      "force (N) and moment (N*mm) on the burr, normal, depth b (mm), and the partials per class label "
      "(rows 0..7): F_e = sum C1_k dF_dC1[k], F_mu = sum mu_k dFmu_dmu[k], T = sum mu_k dTmu_dmu[k].");
}

void bind_replay(py::module_& m) {
  m.def(
      "replay",
      [](const fs::path& experiment, const py::object& params, const py::object& step_us_arg,
         const py::object& erosion_arg, const py::object& threads_arg, const py::object& progress) {
        const double step_us = as_float("replay()", "step_us", step_us_arg);
        const bool erosion = as_bool("replay()", "erosion", erosion_arg);
        const int threads = as_int("replay()", "threads", threads_arg);
        if (threads < 1 || threads > model::kMaxThreads)
          throw InputError("replay()", "threads", fmt::format("1..{} recordings at once", model::kMaxThreads),
                           std::to_string(threads));
        if (!std::isfinite(step_us) || step_us < 0)
          throw InputError("replay()", "step_us", "a step ≥ 0 (µs; 0 = half the sample period)",
                           shown(step_us_arg));
        const auto ps = to_parameter_set(params);
        const std::string params_name = py::isinstance<py::dict>(params)
                                            ? std::string("params (Python)")
                                            : py::str(py::module_::import("os").attr("fspath")(params)).cast<std::string>();
        model::ExperimentPrediction pred;
        std::vector<std::string> gaps;
        CancelToken cancel;
        const auto pp = PyProgress::from("replay()", progress, cancel);
        run_interruptible(cancel, pp.get(), [&] {
          const model::Experiment e = model::load_experiment(experiment);
          const model::ModelParams mp = model::ModelParams::from(ps);
          model::check_covers(ps, e.samples, params_name);
          model::PredictOptions opt;  // as `burrbench replay`: the manifest's lag, nothing added
          opt.replay.step_s = step_us * 1e-6;
          opt.replay.erosion = erosion;
          opt.exclude_buried = e.manifest.fit.buried == data_schema::BuriedPolicy::kExclude;
          opt.threads = threads;
          opt.replay.cancel = &cancel;
          opt.progress = pp.get();
          pred = model::predict_experiment(e, mp, opt);
          gaps = model::alignment_warnings(e);
        });
        warn_overlaps(pred.overlaps);  // as `burrbench replay` warns on stderr
        for (const std::string& w : gaps) warn(w);
        py::dict out;
        for (const auto& p : pred.recordings) out[py::str(p.recording_id)] = prediction_dict(p);
        return out;
      },
      py::arg("experiment"), py::arg("params"), py::arg("step_us") = 0.0, py::arg("erosion") = true, py::arg("threads") = 2,
      py::arg("progress") = py::none(),
      "Replays every recording of an experiment manifest, as `burrbench replay` does: {recording id: "
      "{t_s, force_sensor_pred_N, ... (the prediction file's datasets), removed_mm3, steps}}; "
      "progress(fraction, line) receives the progress lines. Two recordings of one sample that removed the "
      "same bone give a UserWarning naming them, as do the alignment's warnings (force samples without a measured position, a recording that begins in bone).");
}

}  // namespace

void bind_model(py::module_& m) {
  bind_volume(m);
  bind_contact(m);
  bind_replay(m);
}

}  // namespace burrbench::python
