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
/// element's own stiffness, formed once from ElementBlock::elementForces; its b–e blocks (one copy per
/// distinct element, equal to 2⁻³⁰ of the largest entry) are assembled once into node-to-node 3 × 3
/// blocks, a sparse product over the layer's nodes, threaded by rows. The forces are linear in the
/// free field, so they are linear in time between its samples as the field is: the product is formed
/// at the samples a step needs, once each (the last two kept), and a step interpolates them; where
/// the samples are finer than the step, a step forms the product of the interpolated field instead.
/// At most one product a step either way (two at the first), and the forces at (t, Δt) do not
/// depend on what was kept before.
class DomainReduction final : public NodalForceContributor {
 public:
  /// @param beta the stiffness-proportional Rayleigh coefficient acting in the layer (s)
  DomainReduction(const Mesh& mesh, const std::vector<std::unique_ptr<ElementBlock>>& blocks, DrmFreeField field,
                  Real beta);
  std::string name() const override { return "domain reduction"; }
  void addForces(Real t, Real dt, NodalState& state) override;
  /// The layer's forces come from the free field alone.
  bool forceGroups(std::vector<std::vector<Index>>& /*groups*/) const override { return true; }
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }

  Index numLayerElements() const { return nLayerElems_; }
  Index numInner() const { return nInner_; }
  Index numOuter() const { return nOuter_; }
  /// Distinct element couplings found in the layer (a regular layer needs a handful).
  Index numDistinctCouplings() const { return nCouplings_; }
  /// Distinct 3 × 3 node-to-node blocks of the assembled coupling.
  Index numDistinctBlocks() const { return Index(blocks_.size() / 12); }
  const DrmFreeField& field() const { return field_; }
  /// Products over the layer's rows formed so far (at samples, or direct).
  Index numProducts() const { return products_; }
  /// The free field's displacement and velocity at time t, node slot i (the field's order).
  void sample(Real t, std::vector<Real>& u, std::vector<Real>& v) const;

 private:
  DrmFreeField field_;
  Real beta_ = 0;
  Index nInner_ = 0, nOuter_ = 0, nCouplings_ = 0, nLayerElems_ = 0;
  /// The layer elements' b–e couplings assembled node by node: row r (a layer node, the field's
  /// slot) holds the 3 × 3 blocks −K_be (r inner) or +K_eb (r outer) against the slots in rowEntries_
  /// [rowStart_[r], rowStart_[r + 1]); each row is summed by one thread alone, in a fixed order, so
  /// the forces do not depend on the thread count.
  std::vector<Index> rowStart_;    ///< [N + 1]
  std::vector<Index> rowEntries_;  ///< each entry's offsets: 3 × its column slot (into w_), its block's into blocks_
  std::vector<Real> blocks_;       ///< the distinct blocks, column by column, each column padded to 4
  bool avx2_ = false;              ///< the product's AVX2/FMA path (ElementBlock::defaultUseAvx2)
  std::vector<Real> w_;            ///< [3N] scratch: u0 + β u̇0 at the step
  /// The forces at two samples, in the field's order ([3N] each; sample −1: none yet).
  struct SampleForces {
    Index sample = -1;
    std::vector<Real> f;
  };
  SampleForces kept_[2];
  int lastUsed_ = 0;    ///< the slot used last: the other one is replaced first
  Index products_ = 0;  ///< products formed (at samples or direct), for the tests and the bench
  /// The forces of the field w_ (3N, field order) into out: assigned in field order (nodes null) or
  /// added at the mesh nodes.
  void product(Real* out, bool atNodes) const;
  /// The slot holding sample k's forces, formed now if no slot holds them.
  const Real* forcesAt(Index k);
};

}  // namespace tq
