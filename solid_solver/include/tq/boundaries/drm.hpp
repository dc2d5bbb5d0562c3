/// @file drm.hpp
/// @brief The domain reduction method (Bielak, Loukakis, Hisada & Yoshimura 2003): a one-element
///        layer of linear elastic elements between an inner boundary (nodes b, on the region's
///        side) and an outer one (nodes e) carries effective nodal forces computed from the free
///        field u0 (docs/theory.md §6.2; docs/solid_solver.md "Domain reduction").
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tq/boundaries/drm_field.hpp"
#include "tq/core/element_block.hpp"
#include "tq/core/mesh.hpp"
#include "tq/core/solver.hpp"

namespace tq {

/// The DRM layer's effective forces. With the lumped mass M_be = 0, and Rayleigh damping
/// C = αM + βK gives C_be = β K_be, so
///   P_b = −K_be (u0_e + β u̇0_e),   P_e = +K_eb (u0_b + β u̇0_b),
/// the free field linear in time between its samples (held outside them). The layer: every element
/// whose eight nodes are all DRM nodes with at least one b and one e node; its block must be linear
/// elastic with a one-point element (InputError otherwise, naming the block). K is each layer
/// element's own stiffness, formed once from ElementBlock::elementForces; only its b–e blocks are kept, one copy per
/// distinct block (equal to 2⁻³⁰ of the largest entry), so a regular layer costs little memory.
class DomainReduction final : public NodalForceContributor {
 public:
  /// @param beta the stiffness-proportional Rayleigh coefficient acting in the layer (s)
  DomainReduction(const Mesh& mesh, const std::vector<std::unique_ptr<ElementBlock>>& blocks, DrmFreeField field,
                  Real beta);
  std::string name() const override { return "domain reduction"; }
  void addForces(Real t, Real dt, NodalState& state) override;

  Index numLayerElements() const { return Index(elemNodes_.size() / 8); }
  Index numInner() const { return nInner_; }
  Index numOuter() const { return nOuter_; }
  /// Distinct element couplings stored (a regular layer needs a handful).
  Index numDistinctCouplings() const { return Index(couplings_.size()); }
  const DrmFreeField& field() const { return field_; }
  /// The free field's displacement and velocity at time t, node slot i (the field's order).
  void sample(Real t, std::vector<Real>& u, std::vector<Real>& v) const;

 private:
  DrmFreeField field_;
  Real beta_ = 0;
  Index nInner_ = 0, nOuter_ = 0;
  /// One element's b–e coupling: its inner and outer corners (local numbers) and the blocks
  /// K_be (3 nb × 3 ne) and K_eb (3 ne × 3 nb), each stored column by column. Elements of the same shape, material and
  /// split share one.
  struct Coupling {
    int nb = 0, ne = 0;
    int b[8] = {}, e[8] = {};
    std::vector<Real> kbe, keb;
  };
  template <int NB>
  void coupleElement(const Coupling& c, const Index* slots, Real* fExt) const;
  std::vector<Coupling> couplings_;  ///< the distinct couplings
  std::vector<Index> elemNodes_;     ///< [8 L] slots into field_.nodes of each layer element's corners
  std::vector<Index> elemCoupling_;  ///< [L] index into couplings_
  std::vector<Real> w_;              ///< [3N] scratch: u0 + β u̇0 at the step
};

}  // namespace tq
