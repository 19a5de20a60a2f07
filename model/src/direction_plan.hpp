#pragma once
// Which sensitivity directions the tangent pass carries, and how the others follow from
// them exactly (docs/model.md "Directions that follow from others"). Two identities of
// the model:
//  - μ_k enters the erosion of class k only as μ_k/α_k (W ∝ μ_k, dt/(α_k l³)), so
//    ∂χ/∂ln μ_k = −∂χ/∂ln α_k in every voxel, and at fixed χ the force is linear in μ_k:
//    ∂F/∂ln μ_k = −∂F/∂ln α_k + μ_k·dFmu_dmu[k] (the kernel's exact partial).
//  - The force is homogeneous of degree 1 in the C1's, and erosion goes with C1/α: every
//    C1 scaled by λ is every α scaled by 1/λ and F by λ, so
//    Σ_k (∂F/∂ln C1_k + ∂F/∂ln α_k) = F over all classes, and one C1 follows from the rest.
// Each derived direction saves a direction's share of a sensitivity replay.
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "burrbench/model/contact.hpp"
#include "burrbench/model/model_params.hpp"
#include "burrbench/model/sensitivity.hpp"

namespace burrbench::model::detail {

struct DirectionPlan {
  enum class Source {
    kCarried,     // carried by the tangent pass itself (`carried` below)
    kZero,        // a class absent from the sample: exactly zero
    kMuFromAlpha, // ln μ_k from ln α_k (`carried` = its α, or none when α_k = ∞)
    kC1FromRest,  // ln C1_k from F and every other C1 and α
  };
  static constexpr std::size_t kNone = static_cast<std::size_t>(-1);
  struct Recipe {
    Source source = Source::kCarried;
    std::size_t carried = kNone;  // index into `carried`
    std::uint8_t label = 0;
  };
  // The directions handed to the tangent pass (kind and label; a path direction's ∂p is
  // that of requested direction `requested_of`).
  std::vector<Direction> carried;
  std::vector<std::size_t> requested_of;  // per carried direction: requested index or kNone
  std::vector<Recipe> recipe;             // per requested direction
};

// `bone_mm3`: the sample's bone volume per class before the replay (a class without bone
// never comes within reach). `derive` false: every requested direction is carried.
DirectionPlan plan_directions(const std::vector<Direction>& requested, const ModelParams& prm,
                              const std::array<double, kMaxClasses>& bone_mm3, bool derive = true);

// Fills `out` (one entry per requested direction) from the carried directions' results
// `carried`, the reported contacts (`contacts[k]`: the contact whose derivatives sample k
// holds) and `reached[k]`, the classes within reach by sample k (TangentState).
void assemble_directions(const DirectionPlan& plan, const ModelParams& prm, const Sensitivities& carried,
                         const std::vector<const ContactResult*>& contacts,
                         const std::vector<std::uint32_t>& reached, bool moments, Sensitivities& out);

}  // namespace burrbench::model::detail
