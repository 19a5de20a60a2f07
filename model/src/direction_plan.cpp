#include "direction_plan.hpp"

#include <cmath>
#include <utility>

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

void assemble_directions(const DirectionPlan& plan, const ModelParams& prm, Sensitivities&& carried,
                         const std::vector<const ContactResult*>& contacts,
                         const std::vector<std::uint32_t>& reached, bool moments, Sensitivities& out) {
  const std::size_t P = plan.recipe.size(), n = contacts.size();
  out.tangent_voxels = carried.tangent_voxels;
  out.carried_directions = plan.carried.size();
  out.dforce_N.assign(P, {});
  out.dmoment_Nmm.assign(moments ? P : 0, {});
  out.dremoved_mm3.assign(P, std::array<double, kMaxClasses>{});
  // The C1 that follows from the rest: F − Σ_k ∂F/∂ln α_k − Σ_{k≠m} ∂F/∂ln C1_k (the
  // non-eroding classes' α columns are zero), exactly zero until its class is in reach.
  auto rest = [&](std::uint8_t label, auto column, auto total, std::vector<glm::dvec3>& to) {
    to.assign(n, glm::dvec3(0));
    for (std::size_t k = 0; k < n; ++k) {
      if (!((reached[k] >> label) & 1u)) continue;
      glm::dvec3 v = total(*contacts[k]);
      for (std::size_t c = 0; c < plan.carried.size(); ++c)
        if (plan.carried[c].kind != Direction::Kind::kPath) v -= column(c)[k];
      to[k] = v;
    }
  };
  for (std::size_t j = 0; j < P; ++j) {
    const auto& r = plan.recipe[j];
    switch (r.source) {
      case Source::kCarried:
        break;  // moved in below, once the derived ones have read it
      case Source::kZero:
        out.dforce_N[j].assign(n, glm::dvec3(0));
        if (moments) out.dmoment_Nmm[j].assign(n, glm::dvec3(0));
        break;
      case Source::kMuFromAlpha: {
        const double mu = prm.by_label[r.label].mu;
        auto from = [&](const std::vector<std::vector<glm::dvec3>>& a, auto partial, std::vector<glm::dvec3>& to) {
          to.assign(n, glm::dvec3(0));
          for (std::size_t k = 0; k < n; ++k) {
            const glm::dvec3 explicit_part = mu * partial(*contacts[k]);
            to[k] = r.carried == DirectionPlan::kNone ? explicit_part : explicit_part - a[r.carried][k];
          }
        };
        from(carried.dforce_N, [&](const ContactResult& c) { return c.dFmu_dmu[r.label]; }, out.dforce_N[j]);
        if (moments)
          from(carried.dmoment_Nmm, [&](const ContactResult& c) { return c.dTmu_dmu[r.label]; }, out.dmoment_Nmm[j]);
        if (r.carried != DirectionPlan::kNone)
          for (int k = 0; k < kMaxClasses; ++k) out.dremoved_mm3[j][std::size_t(k)] = -carried.dremoved_mm3[r.carried][std::size_t(k)];
        break;
      }
      case Source::kC1FromRest: {
        rest(r.label, [&](std::size_t c) -> const std::vector<glm::dvec3>& { return carried.dforce_N[c]; },
             [](const ContactResult& c) { return c.force_N; }, out.dforce_N[j]);
        if (moments)
          rest(r.label, [&](std::size_t c) -> const std::vector<glm::dvec3>& { return carried.dmoment_Nmm[c]; },
               [](const ContactResult& c) { return c.moment_Nmm; }, out.dmoment_Nmm[j]);
        // The removed volume has no explicit dependence on C1: only the geometric part.
        for (std::size_t c = 0; c < plan.carried.size(); ++c)
          if (plan.carried[c].kind != Direction::Kind::kPath)
            for (int k = 0; k < kMaxClasses; ++k)
              out.dremoved_mm3[j][std::size_t(k)] -= carried.dremoved_mm3[c][std::size_t(k)];
        break;
      }
    }
  }
  // A carried direction asked for twice (or α asked for and also needed by μ) is copied;
  // the last use takes it over.
  for (std::size_t j = 0; j < P; ++j) {
    const auto& r = plan.recipe[j];
    if (r.source != Source::kCarried) continue;
    bool last = true;
    for (std::size_t i = j + 1; i < P; ++i)
      last &= !(plan.recipe[i].source == Source::kCarried && plan.recipe[i].carried == r.carried);
    out.dremoved_mm3[j] = carried.dremoved_mm3[r.carried];
    if (last) {
      out.dforce_N[j] = std::move(carried.dforce_N[r.carried]);
      if (moments) out.dmoment_Nmm[j] = std::move(carried.dmoment_Nmm[r.carried]);
    } else {
      out.dforce_N[j] = carried.dforce_N[r.carried];
      if (moments) out.dmoment_Nmm[j] = carried.dmoment_Nmm[r.carried];
    }
  }
}

}  // namespace burrbench::model::detail
