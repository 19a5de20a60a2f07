// Replaying an aligned recording and writing the prediction (HDF5 "burrbench.prediction"
// and an optional CSV). docs/replay.md documents the file layout.
//
// HDF5: data_schema's RAII layer is private to that library and the model target does
// not get HDF5's include directory, so this file includes the Debian path directly and
// keeps its own tiny writer (the library itself is linked through data_schema).
#include <fmt/format.h>
#include <hdf5/serial/hdf5.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "burrbench/data_schema/error.hpp"
#include "burrbench/model/experiment.hpp"

namespace burrbench::model {

RecordingPrediction predict(const AlignedRecording& r, Volume& volume, const ModelParams& params,
                            const ReplayOptions& options, Progress* progress) {
  const Trajectory tr = r.trajectory();
  const ReplayResult res = replay(volume, r.radius_mm, params, tr, options, true, progress);
  RecordingPrediction p;
  p.recording_id = r.id;
  p.t_s = tr.t_s;
  p.centre_vol_mm = tr.centre_vol_mm;
  p.force_sensor_meas_N = r.force_sensor_N;
  p.use = r.use;
  p.removed_mm3 = res.removed_mm3;
  p.steps = res.steps;
  p.wall_s = res.wall_s;
  const std::size_t n = res.samples.size();
  p.force_burr_vol_N.resize(n);
  p.force_sensor_pred_N.resize(n);
  p.normal_vol.resize(n);
  p.depth_b_mm.resize(n);
  p.class_mask.resize(n);
  p.buried.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const ContactResult& c = res.samples[k].contact;
    p.force_burr_vol_N[k] = c.force_N;
    p.force_sensor_pred_N[k] = r.sensor_force_from_burr_force(c.force_N);
    p.normal_vol[k] = c.normal;
    p.depth_b_mm[k] = c.depth_b_mm;
    p.class_mask[k] = c.class_mask;
    p.buried[k] = c.buried ? 1 : 0;
  }
  return p;
}

namespace {

struct H5 {  // owns one hid_t
  hid_t id;
  herr_t (*close)(hid_t);
  ~H5() {
    if (id >= 0) close(id);
  }
};

class Writer {
 public:
  explicit Writer(std::string file) : file_(std::move(file)) {}
  [[noreturn]] void fail(const std::string& what) const {
    throw InputError(file_, what, "a writable HDF5 output");
  }
  void attr(hid_t obj, const char* name, const std::string& value) const {
    // variable-length UTF-8, as data_schema writes its string attributes
    H5 type{H5Tcopy(H5T_C_S1), H5Tclose};
    H5Tset_size(type.id, H5T_VARIABLE);
    H5Tset_cset(type.id, H5T_CSET_UTF8);
    H5 space{H5Screate(H5S_SCALAR), H5Sclose};
    H5 a{H5Acreate2(obj, name, type.id, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
    const char* text = value.c_str();
    if (a.id < 0 || H5Awrite(a.id, type.id, &text) < 0) fail(name);
  }
  void attr(hid_t obj, const char* name, const std::vector<double>& v) const {
    const hsize_t dims[1] = {v.size()};
    H5 space{H5Screate_simple(1, dims, nullptr), H5Sclose};
    H5 a{H5Acreate2(obj, name, H5T_IEEE_F64LE, space.id, H5P_DEFAULT, H5P_DEFAULT), H5Aclose};
    if (a.id < 0 || H5Awrite(a.id, H5T_NATIVE_DOUBLE, v.data()) < 0) fail(name);
  }
  template <class T>
  void dataset(hid_t group, const char* name, const T* data, hsize_t rows, hsize_t cols,
               hid_t file_type, hid_t mem_type, const char* unit) const {
    const hsize_t dims[2] = {rows, cols};
    H5 space{H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr), H5Sclose};
    H5 ds{H5Dcreate2(group, name, file_type, space.id, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
          H5Dclose};
    if (ds.id < 0 ||
        (rows > 0 && H5Dwrite(ds.id, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0))
      fail(name);
    attr(ds.id, "unit", unit);
  }
  void vec3(hid_t g, const char* name, const std::vector<glm::dvec3>& v, const char* unit) const {
    std::vector<double> flat;
    flat.reserve(3 * v.size());
    for (const auto& x : v) flat.insert(flat.end(), {x.x, x.y, x.z});
    dataset(g, name, flat.data(), v.size(), 3, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, unit);
  }
  void scalars(hid_t g, const char* name, const std::vector<double>& v, const char* unit) const {
    dataset(g, name, v.data(), v.size(), 1, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, unit);
  }
  void bytes(hid_t g, const char* name, const std::vector<std::uint8_t>& v,
             const char* unit) const {
    dataset(g, name, v.data(), v.size(), 1, H5T_STD_U8LE, H5T_NATIVE_UINT8, unit);
  }

 private:
  std::string file_;
};

}  // namespace

void write_prediction(const std::filesystem::path& path,
                      const std::vector<RecordingPrediction>& preds, const Provenance& prov) {
  const std::string file = path.string();
  // Written beside the target and renamed after a clean close: never a half file.
  const std::string tmp = fmt::format("{}.tmp-{}", file, ::getpid());
  {
    H5E_auto2_t old_func = nullptr;
    void* old_data = nullptr;
    H5Eget_auto2(H5E_DEFAULT, &old_func, &old_data);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
    struct Restore {
      H5E_auto2_t f;
      void* d;
      ~Restore() { H5Eset_auto2(H5E_DEFAULT, f, d); }
    } restore{old_func, old_data};
    const Writer w(file);
    H5 f{H5Fcreate(tmp.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT), H5Fclose};
    if (f.id < 0) throw InputError(file, "<file>", "a writable output path");
    w.attr(f.id, "format", kPredictionFormat);
    w.attr(f.id, "format_version", kPredictionVersion);
    nlohmann::json pj = {{"software_version", prov.software_version},
                         {"command_line", prov.command_line},
                         {"created_utc", prov.created_utc},
                         {"inputs", nlohmann::json::array()}};
    for (const auto& in : prov.inputs)
      pj["inputs"].push_back({{"path", in.path}, {"sha256", in.sha256}});
    w.attr(f.id, "provenance", pj.dump());
    H5 recs{H5Gcreate2(f.id, "recordings", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose};
    if (recs.id < 0) w.fail("/recordings");
    for (const auto& p : preds) {
      H5 g{H5Gcreate2(recs.id, p.recording_id.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT),
           H5Gclose};
      if (g.id < 0) w.fail("/recordings/" + p.recording_id);
      w.scalars(g.id, "t_s", p.t_s, "s");
      w.vec3(g.id, "force_burr_vol_N", p.force_burr_vol_N, "N");
      w.vec3(g.id, "force_sensor_pred_N", p.force_sensor_pred_N, "N");
      w.vec3(g.id, "force_sensor_meas_N", p.force_sensor_meas_N, "N");
      w.vec3(g.id, "centre_vol_mm", p.centre_vol_mm, "mm");
      w.vec3(g.id, "normal_vol", p.normal_vol, "1");
      w.scalars(g.id, "depth_b_mm", p.depth_b_mm, "mm");
      w.bytes(g.id, "class_mask", p.class_mask, "bit k = class label k in contact");
      w.bytes(g.id, "buried", p.buried, "1 = contact normal ill-defined");
      w.bytes(g.id, "use", p.use, "1 = inside a used segment");
      w.attr(g.id, "removed_mm3", std::vector<double>(p.removed_mm3.begin(), p.removed_mm3.end()));
      w.attr(g.id, "steps", std::vector<double>{double(p.steps)});
    }
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw InputError(file, "<file>", "a writable output path", "rename failed");
  }
}

void write_prediction_csv(const std::filesystem::path& path,
                          const std::vector<RecordingPrediction>& preds) {
  std::ofstream out(path);
  if (!out) throw InputError(path.string(), "<file>", "a writable output path");
  out << "recording,t_s,Fburr_x_N,Fburr_y_N,Fburr_z_N,Fpred_x_N,Fpred_y_N,Fpred_z_N,"
         "Fmeas_x_N,Fmeas_y_N,Fmeas_z_N,b_mm,n_x,n_y,n_z,class_mask,buried,use\n";
  for (const auto& p : preds)
    for (std::size_t k = 0; k < p.t_s.size(); ++k) {
      const auto &fb = p.force_burr_vol_N[k], &fp = p.force_sensor_pred_N[k],
                 &fm = p.force_sensor_meas_N[k], &n = p.normal_vol[k];
      out << fmt::format(
          "{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},"
          "{:.9g},{:.9g},{:.9g},{},{},{}\n",
          p.recording_id, p.t_s[k], fb.x, fb.y, fb.z, fp.x, fp.y, fp.z, fm.x, fm.y, fm.z,
          p.depth_b_mm[k], n.x, n.y, n.z, int(p.class_mask[k]), int(p.buried[k]), int(p.use[k]));
    }
  if (!out) throw InputError(path.string(), "<file>", "a writable output path", "write failed");
}

}  // namespace burrbench::model
