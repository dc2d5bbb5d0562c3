/// @file constraints.hpp
/// @brief Kinematic ties as nodal forces: groups of nodes forced to move together (the bonded
///        rock–lining interface where the dynamic contact is not used; periodic columns
///        in tests).
#pragma once

#include <string>
#include <vector>

#include "tq/core/solver.hpp"

namespace tq {

/// Groups of nodes that move as one: each step every group gets the common acceleration
/// a = Σf / Σm (f = f_ext − f_int of its members so far), through exchange forces
/// f_c,i = m_i a − f_i that sum to zero (Newton's third law; they do no net work because the
/// members' increments are equal). This is the mass-weighted merge of the nodes, written as a
/// force so that it sits behind the same interface as the contact model that will replace it.
/// It needs every force of the phases before its own (ForcePhase::Interface for the rock–lining
/// interface, ForcePhase::Ties for periodic faces, which share the water's force too).
///
/// The members keep their own displacement reference: a node tied when its partner already
/// carries a displacement keeps the difference (the lining is installed stress-free into the
/// displaced rock). Valid when the members' Rayleigh mass damping and nodal dashpots are
/// proportional to their masses (true for the interface pairs, which carry no dashpots).
class TiedNodeGroups final : public NodalForceContributor {
 public:
  /// @param groups node lists, each of at least 2 nodes
  TiedNodeGroups(std::string name, std::vector<std::vector<Index>> groups);
  /// Pairs (a, b) as groups of two, e.g. mesh.rockLiningPairs.
  static std::vector<std::vector<Index>> pairs(const std::vector<Index>& flatPairs);
  /// Periodic pairs of two opposite, axis-aligned face groups: each node of `from` with the node
  /// of `to` at the same two in-plane coordinates (within 1e-6 of the block's extent). Throws
  /// InputError naming the faces when they are not opposite, or a node has no partner.
  static std::vector<std::vector<Index>> periodicPairs(const Mesh& mesh, const std::string& from,
                                                       const std::string& to);
  /// Check that every group's members carry the same mass and nodal dashpots (to 1e-9): the tie
  /// then keeps them moving together exactly (see the class note). Throws InputError naming the
  /// first group that differs.
  void checkUniformMembers(const NodalState& state) const;

  std::string name() const override { return name_; }
  /// Check the supports (a direction must be fixed for all members or none; throws InputError
  /// naming the group) and set the members' velocities to their mass-weighted mean.
  void install(Solver& solver);
  void addForces(Real t, Real dt, NodalState& state) override;
  void checkpoint(StateArchive& a) override { a.io(force_); }
  /// Subcycling: the members of a group share its finest level (the common acceleration needs
  /// every member's complete force at the same steps).
  bool constrainLevels(std::vector<std::uint8_t>& level) const override {
    bool lowered = false;
    for (Index g = 0; g < numGroups(); ++g) {
      std::uint8_t lo = 255;
      for (const Index* n = begin(g); n != end(g); ++n) lo = std::min(lo, level[size_t(*n)]);
      for (const Index* n = begin(g); n != end(g); ++n)
        if (level[size_t(*n)] != lo) level[size_t(*n)] = lo, lowered = true;
    }
    return lowered;
  }
  /// A group's members share their forces.
  bool forceGroups(std::vector<std::vector<Index>>& groups) const override {
    for (Index g = 0; g < numGroups(); ++g) groups.emplace_back(begin(g), end(g));
    return true;
  }
  /// Its state reads its groups' motion only.
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }

  Index numGroups() const { return Index(start_.size()) - 1; }
  /// Members of group g: nodes [begin, end).
  const Index* begin(Index g) const { return &node_[size_t(start_[size_t(g)])]; }
  const Index* end(Index g) const { return &node_[size_t(start_[size_t(g) + 1])]; }
  /// Exchange force (N) on member j (flat index into the member list) from the last step.
  const Real* force(Index j) const { return &force_[3 * size_t(j)]; }
  Index memberIndex(Index g, Index k) const { return start_[size_t(g)] + k; }

 private:
  std::string name_;
  std::vector<Index> start_, node_;  // CSR
  std::vector<Real> force_;          // [3 members]
};

}  // namespace tq
