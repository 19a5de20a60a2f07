#pragma once
// The reference experiment (reference_fixture.hpp) seen from a rig whose frame is rotated
// 37° from the CT volume and offset: stage positions, the burr axis and the sensor are
// given in the rig frame, and the registration is fitted from four fiducial beads whose
// rig-side coordinates carry ~5 µm of localisation noise (issue 17).
#include <filesystem>
#include <random>
#include <sstream>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "burrbench/data_schema/recording.hpp"
#include "reference_fixture.hpp"

namespace burrbench::calibration::testing {

struct RegistrationSpec {
  ReferenceSpec reference;
  double fiducial_noise_mm = 0.005;  // RMS (3-D) of each rig-side bead
  std::uint64_t fiducial_seed = 7;
};

struct RegistrationCase {
  std::filesystem::path manifest;
  glm::dmat3 R;  // true vol_from_rig rotation
  glm::dvec3 t;  // true vol_from_rig translation (mm)
  std::vector<glm::dvec3> fiducials_vol, fiducials_rig;
};

inline std::string toml_points(const std::vector<glm::dvec3>& p) {
  std::string s = "[";
  for (std::size_t i = 0; i < p.size(); ++i)
    s += fmt::format("{}[{:.12g}, {:.12g}, {:.12g}]", i ? ", " : "", p[i].x, p[i].y, p[i].z);
  return s + "]";
}

inline std::string toml_rows(const glm::dmat3& m) {  // glm column-major → TOML rows
  return fmt::format("[[{:.15g}, {:.15g}, {:.15g}], [{:.15g}, {:.15g}, {:.15g}], [{:.15g}, {:.15g}, {:.15g}]]",
                     m[0][0], m[1][0], m[2][0], m[0][1], m[1][1], m[2][1], m[0][2], m[1][2], m[2][2]);
}

inline RegistrationCase make_registration_experiment(const std::filesystem::path& dir,
                                                     const RegistrationSpec& s,
                                                     const std::string& burrbench) {
  namespace fs = std::filesystem;
  RegistrationCase c;
  c.manifest = make_reference_experiment(dir, s.reference, burrbench);
  c.R = glm::dmat3(glm::rotate(glm::dmat4(1.0), glm::radians(37.0), glm::normalize(glm::dvec3(0.3, -0.4, 1.0))));
  c.t = glm::dvec3(12.5, -30.0, 8.0);
  const glm::dmat3 Rt = glm::transpose(c.R);
  // Stage positions into the rig frame: x_rig = Rᵀ(x_vol − t).
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".h5" || e.path().filename() == "sample.h5") continue;
    data_schema::Recording rec = data_schema::read_recording(e.path());
    for (auto& st : rec.streams)
      for (auto& ch : st.channels)
        if (ch.name == data_schema::kPosition)
          for (std::size_t i = 0; i + 2 < ch.values.size(); i += 3) {
            const glm::dvec3 v = Rt * (glm::dvec3(ch.values[i], ch.values[i + 1], ch.values[i + 2]) - c.t);
            for (int k = 0; k < 3; ++k) ch.values[i + std::size_t(k)] = v[k];
          }
    rec.meta.burr_axis_rig = Rt * rec.meta.burr_axis_rig;
    fs::remove(e.path());
    data_schema::write_recording(e.path(), rec);
  }
  // Four beads around the sample, known in the volume; the rig side measured with noise.
  c.fiducials_vol = {{-1.0, -1.0, 0.0}, {9.0, -1.0, 0.5}, {4.0, 7.0, 0.0}, {4.0, 2.0, 5.0}};
  std::mt19937_64 gen(s.fiducial_seed);
  std::normal_distribution<double> n(0.0, s.fiducial_noise_mm / std::sqrt(3.0));
  for (const auto& p : c.fiducials_vol) c.fiducials_rig.push_back(Rt * (p - c.t) + glm::dvec3(n(gen), n(gen), n(gen)));
  std::ifstream in(c.manifest);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string m = ss.str();
  const std::string given = "  rotation = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n  translation_mm = [0.0, 0.0, 0.0]\n";
  const std::string fid = fmt::format("  fiducials_rig_mm = {}\n  fiducials_vol_mm = {}\n  fiducial_error_mm = {}\n",
                                      toml_points(c.fiducials_rig), toml_points(c.fiducials_vol), s.fiducial_noise_mm);
  for (auto at = m.find(given); at != std::string::npos; at = m.find(given)) m.replace(at, given.size(), fid);
  auto swap_key = [&](const std::string& from, const std::string& to) {
    const auto at = m.find(from);
    if (at == std::string::npos) throw std::runtime_error("manifest key not found: " + from);
    m.replace(at, from.size(), to);
  };
  const glm::dvec3 axis = Rt * glm::dvec3(0.8, 0.0, 0.6);
  swap_key("shaft_axis_rig = [0.8, 0.0, 0.6]", fmt::format("shaft_axis_rig = [{:.15g}, {:.15g}, {:.15g}]", axis.x, axis.y, axis.z));
  // The sensor is the one the synthesis used (its axes = the volume's): v_rig = Rᵀ v_sensor.
  swap_key("rotation_sensor_to_rig = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]", "rotation_sensor_to_rig = " + toml_rows(Rt));
  write_text(c.manifest, m);
  return c;
}

}  // namespace burrbench::calibration::testing
