/// @file ring_forces.hpp
/// @brief Lining section forces around the ring: thrust N, moment M and shear V per unit length of
///        tunnel at the mid-plane of every element column (a "section"), from the stresses of its
///        elements (the design forces) or from their nodal forces (the discrete ring's free-body
///        forces, in equilibrium to round-off), and the change of the inner diameters (ovaling).
///        Conventions and method: docs/theory.md §7 "Lining section forces and ovaling".
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "tq/core/element_block.hpp"
#include "tq/io/mesh.hpp"

namespace tq {

class Solver;

/// One ring: the lining elements of one axial element layer, each between two radial lines of
/// nodes. A section is the mid-plane of an element column (the elements between two neighbouring
/// lines, one per layer through the thickness), where the one-point element samples its stress.
struct LiningRing {
  Real yMin = 0, yMax = 0;          ///< axial extent of the layer (m)
  Real xc = 0, zc = 0;              ///< ring centre in the x–z plane (m)
  Real rInner = 0, rOuter = 0;      ///< mean inner and outer radius (m)
  Real rMid = 0;                    ///< mid-surface radius ½(rInner + rOuter): the moments' reference
  bool closed = false;              ///< a whole ring (otherwise a sector)
  std::vector<Real> angle;          ///< section angles θ (rad, from +x towards +z, in (−π, π]), ascending
  std::vector<Real> lineAngle;      ///< angles of the radial node lines, ascending
  std::vector<Real> diameterAngle;  ///< direction of each diameter, in [0, π) (closed rings)
  /// Per section, its elements through the thickness, inner to outer: block element, middle of
  /// its radial extent and that extent (m).
  struct Layer {
    Index elem;
    Real r, h;
    std::uint8_t upper;  ///< bit k: corner k lies on the column's θ+ node line
  };
  std::vector<std::vector<Layer>> column;
  std::vector<std::array<Real, 2>> ref;       ///< per section: the moment reference point (x, z)
  std::vector<std::vector<Index>> inner;      ///< per node line: its inner-face nodes (smallest radius)
  std::vector<std::array<int, 2>> diameters;  ///< node lines at either end of each diameter
};

/// Finds the rings and evaluates their section forces. The lining block's mesh must be a polar
/// grid in the ring's plane (each element between two radial node lines); otherwise there is no
/// ring and note() says why.
class RingForces {
 public:
  /// @param axial y of the rings wanted: one ring per axial element layer that contains one of
  ///        them (a slice has one layer); none given: the middle layer.
  RingForces(const Mesh& mesh, const ElementBlock& lining, const std::vector<Real>& axial);
  const std::vector<LiningRing>& rings() const { return rings_; }
  const std::string& note() const { return note_; }
  const ElementBlock& block() const { return *lining_; }

  /// Section forces of ring r per unit length of tunnel from the lining's stresses as last
  /// evaluated: N = ∫σθθ dr (N/m, tension positive), M = ∫σθθ (r_mid − r) dr (N·m/m, positive with
  /// tension at the inner face), V = ∫σrθ dr (N/m, positive when the θ+ side pushes the θ− side
  /// outwards), σ in the polar axes of the section. N and V: each element's stress over its radial
  /// extent; M: σθθ(r) fitted by a straight line through the elements' values at the middles of
  /// their radial extents (least squares, weights the extents): exact for a stress linear through the thickness. A
  /// section of one element through the thickness has no such line: M is NaN.
  void sectionForces(size_t r, Real* N, Real* M, Real* V) const;
  /// The section forces of the discrete ring (same sections, conventions and units): the force and
  /// moment that each element column transmits, from its elements' internal nodal forces at the
  /// displacement u [3N] (ElementBlock::elementForces) on its θ+ node line, i.e. of the θ+ side on
  /// the θ− side; M about the middle of the section's radial segment between the column's straight
  /// inner and outer faces (½(r_inner + r_outer) cos(Δθ/2) from the centre). A column is in
  /// equilibrium under its corner forces, so between two sections these change by exactly the
  /// nodal forces of the lining nodes between them (in a slice: the interface, water and inertia
  /// forces, or a relaxation's out-of-balance force), to round-off. They differ from sectionForces
  /// by O(Δθ²): the one-point element's constant Cartesian stress on the column's node lines, which
  /// lie ±Δθ/2 from the section, adds sin²(Δθ/2) ∫σrr r dr to M (docs/theory.md §7).
  void freeBodyForces(size_t r, const Real* u, Real* N, Real* M, Real* V) const;
  /// Change of each inner diameter of ring r (m, elongation positive) for the displacements
  /// rel(node, d) (e.g. relative to the seismic start).
  template <class Rel>
  void diameterChanges(size_t r, const Rel& rel, Real* dd) const {
    const LiningRing& R = rings_[r];
    for (size_t k = 0; k < R.diameters.size(); ++k) {
      Real ua[3] = {0, 0, 0}, xa[3] = {0, 0, 0};
      for (int side = 0; side < 2; ++side) {
        const auto& nodes = R.inner[size_t(R.diameters[k][side])];
        const Real sgn = side == 0 ? 1.0 : -1.0, w = sgn / Real(nodes.size());
        for (Index n : nodes)
          for (int d = 0; d < 3; ++d) {
            ua[d] += w * rel(n, d);
            xa[d] += w * mesh_.coords[dofIndex(n, d)];
          }
      }
      const Real len = std::sqrt(xa[0] * xa[0] + xa[2] * xa[2]);
      dd[k] = (ua[0] * xa[0] + ua[2] * xa[2]) / len;
    }
  }

 private:
  const Mesh& mesh_;
  const ElementBlock* lining_;
  std::vector<LiningRing> rings_;
  std::string note_;
};

}  // namespace tq
