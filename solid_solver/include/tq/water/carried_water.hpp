/// @file carried_water.hpp
/// @brief The water's laws tq-solid carries in its own step (/coupling volume_law, water_ends,
///        water_density; docs/coupler.md "Volume law in the solid", "Open ends"): the volume law, the
///        axial plug flow between the planes of an open tube, the water's rigid translation in the
///        section's plane, and the projections that keep these modes out of the exchange.
///
/// The laws: the pressure p_j of station j acts on its wet nodes as p_j g_i, g the nodes' area vectors
/// out of the water, set implicitly each step from the volume change the step makes,
/// s_j^{n+1} = Σ_{i∈j} g_i·(u_i^{n+1} − u0_i). A closed section is one station: p = −κ s^{n+1} (κ = K/V),
/// or s^{n+1} = 0 (incompressible). With open ends each plane of wet nodes normal to the axis y is a
/// station, the volume W_j that left it flows along the axis as a plug: p_j = −κ_j (s_j + W_j), or
/// s_j + W_j = 0; an end plane at a reservoir holds p = 0, at a valve it has no flow out, at a surge
/// tank its compliance has the tank's A_s/(ρ g) added. With a water density the water's in-plane translation is
/// carried too: its force on the wall is the pressure r·λ_j/V_j with resultant λ_j = −ρ_w V_j ā_j.
///
/// The interface to the step: a contributor of ForcePhase::Water added after the water coupling's
/// (its prediction then holds every other force, the exchanged one included); the coupling asks
/// correct() of the motion it predicts, and sends projectMotion(motion), reads projectForce(force).
/// It needs no coupler: a solid alone may carry it (the cavity test relaxes with it).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "tq/core/solver.hpp"
#include "tq/io/staged_input.hpp"
#include "tq/water/wall_prediction.hpp"
#include "tq/water/wet_part.hpp"

namespace tq {

class CarriedWater final : public NodalForceContributor {
 public:
  /// The laws /coupling asks for on the wetted face in.face, or null when volume_law is none.
  /// Construct right after the switch to the seismic stage (the displacement now is u0).
  /// Throws InputError on a face that encloses no volume or an open-ends face not built in layers.
  static std::shared_ptr<CarriedWater> fromCoupling(const Solver& solver, const CouplingInput& in);
  CarriedWater(const Solver& solver, const CouplingInput& in);
  /// On MPI ranks: the laws on this rank's part of the wetted face (`nodes`: its nodes in `solver`,
  /// in the order of part.places), their geometry from the `whole` mesh's face, every sum over the
  /// wet nodes taken in the one-process order on every part (tq/water/wet_part.hpp): each call
  /// that sums (addForces, correct, projectMotion, projectForce) is collective. `part` outlives it.
  CarriedWater(const Solver& solver, const CouplingInput& in, const Mesh& whole, const WetPart& part,
               std::vector<Index> nodes);
  ~CarriedWater() override;

  // ---- the step -------------------------------------------------------------------------------
  std::string name() const override;
  /// The carried pressure implicit in this step's motion (predicted with every force so far), added
  /// to f_ext, its work booked as the solver books f_ext (trapezoid); the axial flow moves on.
  void addForces(Real t, Real dt, NodalState& st) override;
  /// The step state: the stations' pressures and resultants of the last two steps, the axial
  /// flow's integrators, the work, the force added, the reference u0.
  void checkpoint(StateArchive& archive) override;
  /// On a part: the work terms of the steps not booked yet and the work they go to (flushWetWork(),
  /// before work() is read); in one process none are kept (each step books its own).
  WetWorkBook workBook();
  /// Subcycling: the wet nodes step every fine step.
  bool constrainLevels(std::vector<std::uint8_t>& level) const override;
  /// The carried laws load every wet node from the motion of them all (the enclosed volume).
  bool forceGroups(std::vector<std::vector<Index>>& groups) const override;
  /// Its state reads its groups' motion only.
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }

  // ---- what the exchange asks -----------------------------------------------------------------
  /// A motion predicted with an extra force (m with its response), corrected in place by the
  /// carried pressure it would meet (implicit, as addForces sets it).
  void correct(Real dt, const NodalState& st, WallMotion& m) const;
  /// The motion the water sees: less the carried modes (no volume change, no translation).
  void projectMotion(std::vector<Real>& x) const;
  /// The same for several motions (the fields written), each as projectMotion() projects it alone; on
  /// a part their sums in one gather.
  void projectMotions(const std::vector<std::vector<Real>*>& xs) const;
  /// The water's force kept: less what would work on the carried modes.
  void projectForce(std::vector<Real>& f) const;

  // ---- what it did ----------------------------------------------------------------------------
  /// Its wet nodes (on a part: the part's, in the solver's indices).
  const std::vector<Index>& nodes() const;
  /// The carried pressure's force on each wet node this step ([3n], N; zero on nodes at rest).
  const std::vector<Real>& force() const;
  /// The pressure this step (Pa): a closed section's uniform one; with open ends the stations'
  /// volume-weighted mean.
  Real volumePressure() const;
  /// Each station's pressure (one for a closed section; with open ends one per plane, in order of y).
  std::vector<Real> stationPressures() const;
  /// Station j's pressure this step (Pa; 0 past the last station).
  Real stationPressure(size_t j) const;
  /// The stations' positions along the axis y (m), with open ends; empty for a closed section.
  const std::vector<Real>& stationPositions() const;
  /// Whether end 0 (y_min) or 1 (y_max) is a surge tank.
  bool hasSurgeTank(int end) const;
  /// A surge tank's level above its rest (m) at end 0 (y_min) or 1 (y_max): the volume its compliance
  /// took, A_s p/(ρ g), over its area, p/(ρ g) with p its end station's pressure; 0 without a tank.
  Real surgeLevel(int end) const;
  /// The carried forces' work on the solid so far (J; part of the balance's `external` term).
  Real work() const;
  /// The enclosed volume (m³).
  Real enclosedVolume() const;
  /// One phrase: the law, the volume, the stations, K, the translation's mass.
  std::string describe() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace tq
