#include "direction_plan.hpp"

#include <cmath>

namespace burrbench::model::detail {

namespace {
using Kind = Direction::Kind;
using Source = DirectionPlan::Source;

bool has(const std::vector<Direction>& dirs, Kind kind, std::uint8_t label) {
  for (const auto& d : dirs)
    if (d.kind == kind && d.label == label) return true;
  return false;
}
}  // namespace

DirectionPlan plan_directions(const std::vector<Direction>& requested, const ModelParams& prm,
                              const std::array<double, kMaxClasses>& bone_mm3, bool derive) {
  DirectionPlan plan;
  plan.recipe.resize(requested.size());
  if (!derive) {
    for (std::size_t j = 0; j < requested.size(); ++j) {
      plan.carried.push_back({requested[j].kind, requested[j].label, {}});
      plan.requested_of.push_back(j);
      plan.recipe[j] = {Source::kCarried, j, requested[j].label};
    }
    return plan;
  }
  std::array<bool, kMaxClasses> present{}, erodes{};
  for (int k = 1; k < kMaxClasses; ++k) {
    present[std::size_t(k)] = bone_mm3[std::size_t(k)] > 0;
    // α = ∞: the class never erodes and its ln α tangent is identically zero.
    erodes[std::size_t(k)] = present[std::size_t(k)] && std::isfinite(prm.by_label[std::size_t(k)].alpha_N_per_mm2);
  }
  // ln α_k is carried where ln α_k or ln μ_k is asked for and class k erodes.
  std::array<bool, kMaxClasses> alpha{};
  for (const auto& d : requested)
    if ((d.kind == Kind::kLogAlpha || d.kind == Kind::kLogMu) && erodes[d.label]) alpha[d.label] = true;
  // One C1 follows from the rest when every class with bone has its C1 asked for and its
  // α carried (or not eroding): then the last such class's C1 is not carried.
  std::size_t derived_c1 = 0;
  for (int k = 1; k < kMaxClasses; ++k) {
    const auto kk = std::size_t(k);
    if (!present[kk]) continue;
    if (!has(requested, Kind::kLogC1, std::uint8_t(k)) || (erodes[kk] && !alpha[kk])) {
      derived_c1 = 0;
      break;
    }
    derived_c1 = kk;
  }
  auto carry = [&](Kind kind, std::uint8_t label, std::size_t from) {
    for (std::size_t c = 0; c < plan.carried.size(); ++c)
      if (plan.carried[c].kind == kind && plan.carried[c].label == label && kind != Kind::kPath) return c;
    plan.carried.push_back({kind, label, {}});
    plan.requested_of.push_back(from);
    return plan.carried.size() - 1;
  };
  std::array<std::size_t, kMaxClasses> alpha_slot;
  alpha_slot.fill(DirectionPlan::kNone);
  for (int k = 1; k < kMaxClasses; ++k)
    if (alpha[std::size_t(k)]) {
      std::size_t from = DirectionPlan::kNone;
      for (std::size_t j = 0; j < requested.size(); ++j)
        if (requested[j].kind == Kind::kLogAlpha && requested[j].label == k) from = j;
      alpha_slot[std::size_t(k)] = carry(Kind::kLogAlpha, std::uint8_t(k), from);
    }
  for (std::size_t j = 0; j < requested.size(); ++j) {
    const Direction& d = requested[j];
    auto& r = plan.recipe[j];
    r.label = d.label;
    if (d.kind == Kind::kPath) {
      r.carried = carry(Kind::kPath, 0, j);
    } else if (!present[d.label]) {
      r.source = Source::kZero;
    } else if (d.kind == Kind::kLogAlpha) {
      r.source = erodes[d.label] ? Source::kCarried : Source::kZero;
      r.carried = alpha_slot[d.label];
    } else if (d.kind == Kind::kLogMu) {
      r.source = Source::kMuFromAlpha;
      r.carried = alpha_slot[d.label];
    } else if (d.label == derived_c1) {
      r.source = Source::kC1FromRest;
    } else {
      r.carried = carry(Kind::kLogC1, d.label, j);
    }
  }
  return plan;
}

namespace {
using Column = std::vector<glm::dvec3>;

// Column j of one channel (the force or the couple) from the carried columns `cols`;
// `partial_mu(c, k)`: the kernel's fixed-geometry ∂/∂μ_k of that channel, `total(c)` its value.
template <class PartialMu, class Total>
Column assemble(const DirectionPlan& plan, const DirectionPlan::Recipe& r, const ModelParams& prm,
                const std::vector<Column>& cols, const std::vector<const ContactResult*>& contacts,
                const std::vector<std::uint32_t>& reached, PartialMu partial_mu, Total total) {
  const std::size_t n = contacts.size();
  Column out(n, glm::dvec3(0));
  switch (r.source) {
    case Source::kCarried:
      return cols[r.carried];
    case Source::kZero:
      return out;
    case Source::kMuFromAlpha:  // −∂/∂ln α_k + μ_k ∂/∂μ_k|χ
      for (std::size_t k = 0; k < n; ++k) {
        out[k] = prm.by_label[r.label].mu * partial_mu(*contacts[k], r.label);
        if (r.carried != DirectionPlan::kNone) out[k] -= cols[r.carried][k];
      }
      return out;
    case Source::kC1FromRest:  // F − Σ_k ∂/∂ln α_k − Σ_{k≠m} ∂/∂ln C1_k, zero until in reach
      for (std::size_t k = 0; k < n; ++k) {
        if (!((reached[k] >> r.label) & 1u)) continue;
        out[k] = total(*contacts[k]);
        for (std::size_t c = 0; c < plan.carried.size(); ++c)
          if (plan.carried[c].kind != Direction::Kind::kPath) out[k] -= cols[c][k];
      }
      return out;
  }
  return out;
}

// The removed volume's derivative: no explicit dependence on the constants, only the
// geometric part of the same identities.
std::array<double, kMaxClasses> assemble_removed(const DirectionPlan& plan, const DirectionPlan::Recipe& r,
                                                 const std::vector<std::array<double, kMaxClasses>>& carried) {
  std::array<double, kMaxClasses> out{};
  for (std::size_t k = 0; k < kMaxClasses; ++k) {
    if (r.source == Source::kCarried) out[k] = carried[r.carried][k];
    if (r.source == Source::kMuFromAlpha && r.carried != DirectionPlan::kNone) out[k] = -carried[r.carried][k];
    if (r.source == Source::kC1FromRest)
      for (std::size_t c = 0; c < plan.carried.size(); ++c)
        if (plan.carried[c].kind != Direction::Kind::kPath) out[k] -= carried[c][k];
  }
  return out;
}
}  // namespace

void assemble_directions(const DirectionPlan& plan, const ModelParams& prm, const Sensitivities& carried,
                         const std::vector<const ContactResult*>& contacts,
                         const std::vector<std::uint32_t>& reached, bool moments, Sensitivities& out) {
  const std::size_t P = plan.recipe.size();
  out.tangent_voxels = carried.tangent_voxels;
  out.carried_directions = plan.carried.size();
  out.dforce_N.resize(P);
  out.dmoment_Nmm.resize(moments ? P : 0);
  out.dremoved_mm3.resize(P);
  for (std::size_t j = 0; j < P; ++j) {
    const auto& r = plan.recipe[j];
    out.dforce_N[j] = assemble(
        plan, r, prm, carried.dforce_N, contacts, reached,
        [](const ContactResult& c, std::uint8_t k) { return c.dFmu_dmu[k]; },
        [](const ContactResult& c) { return c.force_N; });
    if (moments)
      out.dmoment_Nmm[j] = assemble(
          plan, r, prm, carried.dmoment_Nmm, contacts, reached,
          [](const ContactResult& c, std::uint8_t k) { return c.dTmu_dmu[k]; },
          [](const ContactResult& c) { return c.moment_Nmm; });
    out.dremoved_mm3[j] = assemble_removed(plan, r, carried.dremoved_mm3);
  }
}

}  // namespace burrbench::model::detail
