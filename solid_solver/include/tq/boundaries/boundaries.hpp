/// @file boundaries.hpp
/// @brief Nodal force contributors for the staged analysis: constant nodal forces (support
///        reactions held at the switch to dynamics, static surface pressures), the consistent
///        nodal forces of a surface pressure, and the seismic boundaries — a viscoelastic base
///        with the incident wave as equivalent nodal forces and free-field lateral boundaries
///        driven by 1D free-field columns (docs/solid_solver.md "Seismic boundaries").
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "tq/boundaries/free_field.hpp"
#include "tq/core/face_quadrature.hpp"
#include "tq/core/mesh.hpp"
#include "tq/core/solver.hpp"

namespace tq {

/// Consistent nodal forces f_I = −∫ N_I p(x) n dA of a pressure p (Pa, pushing against the
/// face's outward normal n) over a face group, by 2×2 Gauss points per bilinear quad.
/// Returns [3N] forces (N).
std::vector<Real> pressureNodalForces(const Mesh& mesh, const std::string& group,
                                      const std::function<Real(const Real x[3])>& pressure);

/// Constant forces on nodes (N), e.g. the support reactions that replace the static supports at
/// the start of the earthquake, or a static surface pressure.
class ConstantNodalForces final : public NodalForceContributor {
 public:
  ConstantNodalForces(std::string name, std::vector<Real> forces) : name_(std::move(name)), f_(std::move(forces)) {}
  std::string name() const override { return name_; }
  void addForces(Real t, Real dt, NodalState& state) override;
  const std::vector<Real>* constantForces() const override { return &f_; }
  bool forceGroups(std::vector<std::vector<Index>>& /*groups*/) const override { return true; }  // constant
  bool motionReadNodes(std::vector<Index>& /*nodes*/) const override { return true; }
  const std::vector<Real>& forces() const { return f_; }

 private:
  std::string name_;
  std::vector<Real> f_;  // [3N]
};

/// Parameters of the seismic boundaries (from /boundaries and /motion, resolved by the stage driver).
struct SeismicBoundarySpec {
  bool bottom = false;
  std::string bottomFace = "bottom";
  Real distance = 0;  ///< R (m) of the springs K = αG/R
  Real alphaN = 4.0 / 3, alphaT = 2.0 / 3;
  BaseHalfSpace halfSpace;  ///< ρ, cp, cs below the base (dashpots, springs, input)
  std::vector<std::string> freeFieldFaces;
  /// Vertical faces whose quads are not stacked in horizontal rows (a tunnel's cross-section with
  /// its ends plugged), driven by freeFieldFaces[0]'s column: the ground's layers are horizontal, so
  /// the column is the same; each node takes it at its height, each quad the stress and impedance of
  /// the column's layer at its centroid, whose material the quad's element must have.
  std::vector<std::string> sharedColumnFaces;
  std::string columnFace;   ///< face whose layers define the base column
  RayleighDamping damping;  ///< the model's Rayleigh damping (the columns use the same)
};

/// Viscoelastic base + free-field sides, all driven by the incident motion.
///
/// Base node (tributary area A, normal e_z): spring −A K (u − u_0), dashpot −A C v (as a nodal
/// dashpot, integrated with the mean of the half-step velocities), and the equivalent input
/// force A[K u_ff + C v̄_ff + σ_ff·n] = A[K u_col + 2ρc v_in], where (u_col, v̄_ff, σ_ff) is the
/// base column's motion and its traction from the half-space (σ_ff·n = 2ρc v_in − C v̄_col).
/// K_N = α_N G/R, C_N = ρ cp (z); K_T = α_T G/R, C_T = ρ cs (x, y).
///
/// Side node (free-field face, outward normal n = ±e_a): dashpots C_N (along a), C_T (across)
/// on v − v_ff, i.e. −A C v (nodal dashpot) + A C v̄_ff, plus the free-field traction σ_ff·n
/// integrated over each side quad from the column layer that quad spans.
///
/// The spring's work is booked as boundary energy (boundaryWork), the input forces as external
/// work, the dashpots as boundary dissipation (by the solver).
class SeismicBoundaries final : public NodalForceContributor {
 public:
  SeismicBoundaries(const Mesh& mesh, const std::vector<std::unique_ptr<ElementBlock>>& blocks,
                    const SeismicBoundarySpec& spec, IncidentMotion motion, bool slice);
  /// The same with each mesh element's material given ([E]; on MPI ranks the whole model's mesh,
  /// whose elements a rank's blocks do not all hold).
  SeismicBoundaries(const Mesh& mesh, const std::vector<const Material*>& elementMaterial,
                    const SeismicBoundarySpec& spec, IncidentMotion motion, bool slice);
  /// On MPI ranks (tq/parallel/): built on the whole model's mesh, keep what acts on this rank's
  /// nodes, renumbered (localNode [global node]: its local index, or −1 where the rank does not
  /// hold it). Each node's force is then the sum of the same terms in the same order as in one
  /// process. `owned` [local node]: the base nodes whose spring energy this rank counts.
  void restrictToNodes(const std::vector<Index>& localNode, const std::vector<std::uint8_t>& owned);
  std::string name() const override { return "seismic boundaries"; }
  /// Register the nodal dashpots and the displacement reference u_0 (the state at the switch).
  void install(NodalState& state);
  void addForces(Real t, Real dt, NodalState& state) override;
  Real boundaryEnergy() const override { return -springWork_; }
  /// The base's springs and dashpots and the sides' free field act on each node from its own motion.
  bool forceGroups(std::vector<std::vector<Index>>& /*groups*/) const override { return true; }
  /// The base's springs book their work from the base nodes' motion at every step.
  bool motionReadNodes(std::vector<Index>& nodes) const override {
    nodes.insert(nodes.end(), base_.nodes.begin(), base_.nodes.end());
    return true;
  }
  void checkpoint(StateArchive& a) override {
    for (auto& c : columns_) c.checkpoint(a);
    a.io(uPrev_);
    a.io(fPrev_);
    a.io(first_);
    a.io(springWork_);
  }
  /// The columns (one per free-field face, then the base column if it is not one of them).
  const std::vector<FreeFieldColumn>& columns() const { return columns_; }
  const FreeFieldColumn& baseColumn() const { return columns_[size_t(baseColumn_)]; }
  const IncidentMotion& motion() const { return motion_; }
  /// Nodes of the base (sorted) and the springs' K per area (N/m³) per direction (of the base column's
  /// half-space; each node's are its own column's, assignBaseColumns).
  const std::vector<Index>& baseNodes() const { return base_.nodes; }
  /// Compute the base's nodes on the solver's threads (where they are distinct; the default from
  /// kThreadedBaseNodes nodes, set by install) or in one loop: the same bits either way.
  void computeBaseOnThreads(bool on);
  bool baseOnThreads() const { return !baseTerm_.empty(); }
  static constexpr size_t kThreadedBaseNodes = 512;
  /// Sum the sides' free-field terms on the solver's threads, node by node in the order one loop
  /// adds them (the default from kThreadedSideNodes nodes, set by install), or in one loop: the
  /// same bits either way.
  void computeSidesOnThreads(bool on);
  bool sidesOnThreads() const { return !sideNodes_.empty(); }
  static constexpr size_t kThreadedSideNodes = 512;
  std::array<Real, 3> springPerArea() const { return kArea_; }
  std::array<Real, 3> dashpotPerArea() const { return cArea_; }

 private:
  FreeFieldColumn buildColumn(const Mesh& mesh, const std::vector<const Material*>& elementMaterial,
                              const std::string& face) const;
  /// Each base node takes the nearest free-field face's column (horizontal distance to the face's
  /// extent; the first of equally near ones): its spring follows that column's base, and its dashpot
  /// and input are that column's half-space's, so that under a ground that changes across the block
  /// (a slope, dipping layers, side faces in strips along the axis) the base near each side is that
  /// side's column's; the base column everywhere when fewer than two columns reach the base.
  void assignBaseColumns(const Mesh& mesh);
  const FreeFieldColumn& baseColumnOf(size_t i) const {
    return columns_[size_t(baseColumnOf_.empty() ? baseColumn_ : baseColumnOf_[i])];
  }
  struct SideNode {
    Index node;
    Index column;
    Index level;  // interpolation between level and level + 1 with weight w
    Real w;
    Real c[3];  // dashpot coefficient A·C per direction (N s/m)
  };
  struct SideQuadLoad {
    Index column, layer;
    int axis, sign;
    Index node[4];
    Real share[4];  // ∫N_I dA (m²)
  };
  SeismicBoundarySpec spec_;
  IncidentMotion motion_;
  std::vector<FreeFieldColumn> columns_;
  Index baseColumn_ = 0;
  AxisFace base_;
  std::array<Real, 3> kArea_{}, cArea_{};
  std::vector<SideNode> side_;
  std::vector<SideQuadLoad> sideQuads_;
  std::vector<std::uint8_t> baseCounted_;  // [base nodes] in springWork_ (empty: all)
  std::vector<Real> u0_;                   // [3 base nodes] displacement at the switch
  std::vector<Real> uPrev_, fPrev_;        // spring work by the trapezoid rule, as the solver books work
  bool first_ = true;
  Real springWork_ = 0;
  std::vector<Index> baseColumnOf_;  // [base nodes] the column whose base the node's spring follows
  bool baseDistinct_ = false;        // no node twice in the base's list
  std::vector<Real> baseTerm_;       // [3 base nodes] the step's spring-work terms (threaded; else empty)
  // The sides' terms by node (computeSidesOnThreads; empty: one loop): each distinct node's terms
  // sideTerms_[sideStart_[j] .. sideStart_[j + 1]) in the order one loop adds them, its dashpots'
  // free-field terms first (corner −1, index into side_), then its quads' tractions in quad order
  // (index into sideQuads_, the node's corner).
  struct SideTerm {
    Index index;
    int corner;
  };
  std::vector<Index> sideNodes_;
  std::vector<size_t> sideStart_;
  std::vector<SideTerm> sideTerms_;
  std::vector<Real> quadTraction_;  // [3 side quads] the step's σ_ff · n (threaded)
};

}  // namespace tq
