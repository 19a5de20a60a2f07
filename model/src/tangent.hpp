#pragma once
// Tangent-linear pass of the contact kernel (forward sensitivities, sensitivity.hpp). After
// the kernel has evaluated (and possibly eroded) at a burr position, `differentiate` uses
// the lens voxels and the derived quantities the kernel left in its scratch
// (KernelScratch: KernelState) to compute ∂F/∂θ_j, and, for an erosion step, advances the voxels'
// tangents ∂χ/∂θ_j through χ ← max(0, χ − dt·W/(α l³)).
#include <array>
#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "burrbench/model/contact.hpp"
#include "burrbench/model/sensitivity.hpp"
#include "burrbench/model/volume.hpp"

namespace burrbench::model::detail {

struct KernelState;
struct Scratch;

// Σ c v vᵀ over voxels, symmetric (six sums): the tangent pass sums the geometric part of a
// path direction's terms once and applies it to each direction's ∂p.
struct Sym3 {
  double xx = 0, xy = 0, xz = 0, yy = 0, yz = 0, zz = 0;
  // Inline: called per lens voxel (out of line it was 4 % of a sensitivity fit's CPU).
  void add(double c, const glm::dvec3& v) {
    const glm::dvec3 cv = c * v;
    xx += cv.x * v.x;
    xy += cv.x * v.y;
    xz += cv.x * v.z;
    yy += cv.y * v.y;
    yz += cv.y * v.z;
    zz += cv.z * v.z;
  }
  glm::dvec3 operator*(const glm::dvec3& u) const {
    return {xx * u.x + xy * u.y + xz * u.z, xy * u.x + yy * u.y + yz * u.z, xz * u.x + yz * u.y + zz * u.z};
  }
};

class TangentState {
 public:
  // Lives for one replay of `vol` whose kernel works in `scratch`; while it does, the
  // kernel lists the inside voxels there.
  TangentState(const Volume& vol, KernelScratch& scratch, const std::vector<Direction>& dirs,
               const ModelParams& prm);
  ~TangentState();
  TangentState(const TangentState&) = delete;
  TangentState& operator=(const TangentState&) = delete;
  std::size_t directions() const { return P_; }
  // `c`: the contact just evaluated on `vol` (by evaluate or step); `dp`: ∂p/∂θ_j at this
  // position (P entries; zero for physics directions); `eroded`: the kernel eroded with
  // this step (then the voxel tangents advance). Writes ∂F/∂θ_j to dF (P entries) and,
  // when dT is given, ∂T/∂θ_j of the friction couple to dT (P entries). dF (and dT) null:
  // an erosion step whose force is not reported; only the tangents advance.
  void differentiate(const Volume& vol, const ContactResult& c, const glm::dvec3* dp,
                     bool eroded, glm::dvec3* dF, glm::dvec3* dT = nullptr);
  const std::vector<std::array<double, kMaxClasses>>& dremoved_mm3() const { return drem_; }
  std::size_t tangent_voxels() const { return touched_.size(); }
  // Bit k: class k has come within reach (its directions are carried from then on; before,
  // every derivative in its constants is exactly zero).
  std::uint32_t reached_classes() const { return reached_; }

 private:
  void inside_tangents(const Volume& vol, double v_in);
  void elastic_tangents(const KernelState& st, double R, bool forces, glm::dvec3* dF);
  // The cube quadrature's moments, friction and erosion tangents (tangent_cube.cpp).
  void differentiate_cube(const Volume& vol, const ContactResult& c, bool eroded, glm::dvec3* dF, glm::dvec3* dT);
  double* tangent(std::uint32_t voxel);          // existing or null
  double* tangent_or_new(std::uint32_t voxel);   // allocates a zero tangent
  Scratch& sc_;  // the kernel's, holding what its last evaluation left
  std::size_t P_;
  std::vector<std::int8_t> kind_;   // per direction: 0 ln α, 1 ln C1, 2 ln μ, 3 path
  std::vector<std::uint8_t> label_;
  ModelParams prm_;
  std::size_t nx_, ny_;
  std::vector<std::int32_t> slot_;   // per voxel: tangent slot or −1
  std::vector<std::int32_t> row_lo_, row_hi_;  // per row (y, z): x-range of its tangent voxels (lo > hi: none)
  std::vector<std::size_t> path_;    // directions that move the burr
  std::vector<std::size_t> act_;     // directions carried so far (path ones, and classes that were in reach)
  std::vector<std::uint8_t> active_; // per direction: in act_
  std::size_t dormant_ = 0;          // directions not yet in act_
  std::uint32_t reached_ = 0;        // classes that have come within reach
  std::vector<double> dchi_;         // slot × P
  std::vector<std::uint32_t> touched_;  // voxel of each slot
  // Scratch of differentiate(), kept to avoid zeroing kMaxDirections entries per call.
  std::array<std::array<double, kMaxClasses>, kMaxDirections> dmass_;
  std::array<glm::dvec3, kMaxDirections> dm1_, dn_;
  std::array<double, kMaxDirections> dfe_, da2_, dp0_, tnew_;
  std::array<glm::dvec3, kMaxDirections> dpj_;
  std::array<std::array<double, 8>, kMaxDirections> z_;
  std::array<std::array<glm::dvec3, kMaxClasses>, kMaxDirections> dG_;
  std::array<std::array<glm::dvec3, kMaxClasses>, kMaxDirections> dTG_;  // ∂χ part of the couple
  std::vector<std::array<double, kMaxClasses>> drem_;
};

}  // namespace burrbench::model::detail
