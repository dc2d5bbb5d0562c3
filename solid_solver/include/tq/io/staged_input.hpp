/// @file staged_input.hpp
/// @brief The solid_input.h5 version 2 groups (docs/formats.md "## solid_input.h5"): stages,
///        in-situ stress, hydrostatic pressure, the rock-lining interface, seismic boundaries and
///        the incident motion. Plain data, read and checked apart from the time loop
///        (src/input_staged.cpp); the stage driver (tq/stages.hpp) uses it.
#pragma once

#include <limits>
#include <string>
#include <vector>

#include "tq/boundaries/drm_field.hpp"
#include "tq/core/types.hpp"

namespace tq {

/// The stage names in their only allowed order (paper §3.2; ARCHITECTURE.md §2).
inline const std::vector<std::string> kStageOrder = {"in_situ",     "excavation",   "lining",
                                                     "hydrostatic", "fault_offset", "seismic"};

/// /stages: which stages run and how static equilibrium is reached.
struct StagesInput {
  std::vector<std::string> sequence;    ///< subset of kStageOrder, in that order
  Real tolerance = 1e-4;                ///< dynamic relaxation stops when the unbalanced-force ratio is below
  Index maxSteps = 50000;               ///< per static stage
  bool massScaling = true;              ///< relax with element masses scaled to one common step (statics only)
  bool equilibriumCorrection = true;    ///< at the switch, hold the residual out-of-balance force constant
  std::string liningRegion = "lining";  ///< region activated by the `lining` stage
  /// Fraction λ ∈ [0, 1] of the excavation load (the out-of-balance force the in-situ stress leaves
  /// on the hole: the released core tractions) relaxed by the excavation stage with the rock alone;
  /// the rest, (1 − λ), is held as constant forces and released in the lining stage with rock and
  /// lining together (β-method, convergence–confinement). 1: full release before the lining.
  Real releaseFraction = 1;
  bool has(const std::string& s) const {
    for (const auto& x : sequence)
      if (x == s) return true;
    return false;
  }
};

/// /in_situ: σv(z) = −(q + ρ g (z_top − z)) (tension positive), σzz = kz σv, σxx = kx σv,
/// σyy = ky σv, set at the element centroids of every region except the lining.
struct InSituInput {
  bool present = false;
  Real kx = 1, ky = 1, kz = 1;
  Real gravity = 0;  ///< g (m/s², ≥ 0); also the body force −g ẑ of the whole run
  Real density = 0;  ///< overburden density ρ (kg/m³); 0 = each element's own material density
  Real zTop = std::numeric_limits<Real>::quiet_NaN();  ///< ground surface (m); NaN = the mesh's top
  Real surcharge = 0;  ///< q: compressive vertical stress at z_top (Pa, ≥ 0); e.g. a far-field stress with g = 0
};

/// /hydrostatic: p(z) = p_axis − γw (z − z_axis), clipped at 0, on the face group `face`
/// (pressure pushes on the solid against the face's outward normal).
struct HydrostaticInput {
  bool present = false;
  std::string face = "lining_inner";
  Real pressureAtAxis = 0;  ///< p_axis = ρw g H (Pa)
  Real unitWeight = 0;      ///< γw = ρw g (N/m³)
  Real zAxis = 0;           ///< elevation of the tunnel axis (m)
};

/// /fault_offset: a prescribed displacement of given nodes (a fault's slip at the block's
/// boundaries, docs/solid_solver.md "Fault offset"). Static (rise_time 0): imposed by the
/// fault_offset stage on top of the state before it, in `increments` equal steps, each relaxed to
/// equilibrium; the nodes are held there (all three directions) until the seismic stage, which
/// holds their reactions. Dynamic (rise_time > 0): from the seismic stage's switch the nodes are
/// held in x, y, z and moved by the displacement times the ramp ½(1 − cos(π (t − t0)/T)) over
/// [t0, t0 + T], t0 = start_time, T = rise_time (PrescribedSlip).
struct FaultOffsetInput {
  bool present = false;
  std::vector<Index> nodes;        ///< [N] mesh node indices
  std::vector<Real> displacement;  ///< [3N] the displacement each node is given (m)
  Index increments = 1;
  Real riseTime = 0;   ///< T (s); 0: the static offset of the fault_offset stage
  Real startTime = 0;  ///< t0 (s) from the seismic stage's start
  bool dynamic() const { return present && riseTime > 0; }
};

/// /interfaces/rock_lining: the rock-lining node pairs of mesh.h5 and how they interact.
struct InterfaceInput {
  bool present = false;
  std::string model = "bonded";  ///< "bonded" (tied); "dynamic_contact" is the dynamic contact force
  Real staticFriction = 0.6, dynamicFriction = 0.6;  ///< μs, μd (contact only)
  Real cohesion = 0;                                 ///< f_c (Pa) (contact only)
  std::string afterFailure = "cohesion_lost";        ///< contact only
};

struct ContactParams;  // tq/contact/contact.hpp
/// The contact parameters of /interfaces/rock_lining (model, static_friction, dynamic_friction,
/// cohesion, after_failure); throws InputError on unknown names or bad values.
ContactParams contactParamsFrom(const InterfaceInput& in);

/// /interfaces/lining_joints: the law of the lining's joints (their node pairs are mesh.h5's
/// /interfaces/lining_joints, read by readJointPairs).
struct JointsInput {
  bool present = false;
  Real normalStiffness = 0, shearStiffness = 0;  ///< k_n, k_s (Pa/m)
  Real tensileStrength = 0;                      ///< f_t (Pa)
  Real friction = -1;                            ///< μ; < 0: no cap on the shear
};

struct JointParams;  // tq/contact/joints.hpp
struct JointPairs;
/// The joint law of /interfaces/lining_joints; throws InputError on bad values.
JointParams jointParamsFrom(const JointsInput& in);
/// mesh.h5's joints: /interfaces/lining_joints [P, 2] (node on the −y side, its copy on the +y
/// side), lining_joint_area [P] (m²), lining_joint_index [P] and lining_joint_y [J]; throws
/// InputError when the mesh has none or they are inconsistent.
JointPairs readJointPairs(const std::string& meshPath);

/// /boundaries/bottom: viscoelastic base (Deeks & Randolph 1994; Liu Jingbo et al. 2006).
struct BottomBoundaryInput {
  bool present = false;
  std::string face = "bottom";
  Real distance = 0;             ///< R (m) in K = αG/R; 0 = default (tunnel axis to base, else model height)
  Real alphaN = 0, alphaT = 0;   ///< 0 = 4/3, 2/3 (3D) or 1, 1/2 (slice)
  Real rho = 0, cp = 0, cs = 0;  ///< half-space below the base; 0 = from the elements on the face
  std::string
      columnFace;  ///< face whose layering defines the base free-field column ("" = first free-field face, else xmin)
};

/// /boundaries/free_field: lateral boundaries driven by 1D free-field columns.
struct FreeFieldInput {
  bool present = false;
  std::vector<std::string> faces;  ///< e.g. xmin, xmax (and ymin, ymax in 3D)
  /// Faces not horizontally layered (a tunnel's cross-section), driven by faces[0]'s column.
  std::vector<std::string> sharedColumnFaces;
};

/// /boundaries/periodic: two opposite faces whose nodes move alike (u on `faces[1]` equals u on
/// `faces[0]`, all three directions) from the seismic stage on: a model that repeats along the
/// axis normal to them. Needed by a motion along the tunnel axis (y): an SH wave polarised along
/// y shears the slice antiplane, which rollers on the y faces (u_y = 0) would forbid.
struct PeriodicInput {
  bool present = false;
  std::vector<std::string> faces;  ///< two face groups, e.g. ymin, ymax
};

/// /motion: incident (up-going) accelerations at the base, vertically incident
/// (x, y: SH waves, z: P wave); piecewise linear in time, integrated exactly.
struct MotionInput {
  bool present = false;
  std::vector<Real> time, ax, ay, az;  ///< s, m/s² (an empty component is zero)
  Real cutoffFrequency = 0;            ///< Hz, for the λ_min/8 element-size warning (0: no check)
  std::string convention;              ///< informational ("outcrop" or "incident" record)
};

/// /coupling: the water coupling of condition dynamic_water (docs/formats.md, docs/coupler.md
/// "Solid adapter"); read by input_staged.cpp, used by tq/fluid_coupling.hpp.
struct CouplingInput {
  bool present = false;
  std::string scheme = "implicit";  ///< explicit | paper | implicit
  Index windowSteps = 1;            ///< solid steps per coupling window (k > 1: explicit only)
  Real windowSize = 0;              ///< s; 0 = windowSteps × the solid step
  Index windows = 0;                ///< coupling windows to run (required, ≥ 1: fluid_case.coupling_windows)
  Real tolerance = 1e-4;            ///< implicit: relative residual
  /// implicit: absolute convergence floors on the RMS residual of each exchanged field, in its
  /// units (0 = none; `tunnelquake run` derives them from the problem scale, docs/coupler.md)
  Real absoluteTolVelocity = 0, absoluteTolDisplacement = 0, absoluteTolForce = 0;
  Index maxIterations = 20;  ///< implicit: passes per window at most
  /// Stop when the energy the coupling created (couplingEnergy() > 0) exceeds this fraction of the
  /// largest interface work so far (0 = no stop; docs/coupler.md "Energy guard").
  Real energyLimit = 0;
  /// J: the least reference work of that ratio (0 = from the absolute tolerances, see the guard).
  Real energyFloor = 0;
  /// With restart checkpoints: one at the end of every K-th accepted window (K = this, 0 = every
  /// window; `tunnelquake run` decides it from /output checkpoint_interval: fluid_case.checkpoint_windows).
  Index checkpointWindows = 0;
  /// Implicit windows of k > 1 steps: weight β of the window-end force in the force the solid's steps
  /// apply (step j: F_w + w_j (F̃ − F_w), w_j = 1 − (1 − j/k)·2(1 − β)); 0.5 = the linear ramp,
  /// 1 = the end force held over the window (docs/coupler.md "Window force weight").
  Real windowForceWeight = 0.5;
  /// Implicit windows of k > 1 steps: the share α (0 … 1) of the defect not yet repaid (the sum of the
  /// accepted windows' residuals, the water's last answer less the window-end force the solid stepped
  /// with) that is added to the force of every step of the next window; 0 = off (docs/coupler.md
  /// "Defect correction").
  Real defectCorrection = 0;
  std::string acceleration = "iqn-ils";  ///< none | constant | aitken | iqn-ils
  Real initialRelaxation = 0.5;
  Index reuse = 0;                        ///< IQN-ILS: windows whose secant columns are kept
  std::string predictor = "constant";     ///< implicit: first force of a window, constant | linear | damped
  std::string residualScale = "current";  ///< implicit: a field's relative residual against current | largest ‖a‖
  std::string transport = "tcp";          ///< tcp | mpi
  std::string addressFile;                ///< tcp: where the listener publishes its port
  std::string token;                      ///< per-run secret both sides were given
  Real timeout = 120;                     ///< s: a silent partner for longer stops the run
  Real connectTimeout = 0;                ///< s: waiting for the partner to appear (0 = timeout)
  std::string face = "lining_inner";      ///< mesh.h5 face group of the wetted interface
  std::string mesh = "wall";              ///< interface mesh name on the wire
  std::string map = "coincident";         ///< coincident | projection (the solid maps)
  Real mapTolerance = 1e-6;               ///< m
  std::vector<std::string> writeFields = {"velocity", "displacement"};  ///< solid → fluid, in order
  std::string participant = "solid", partner = "fluid";
  /// The water's volume law, carried by the solid (docs/coupler.md "Volume law in the solid"):
  /// "none" (the water side sends its whole pressure), "compressible" (uniform pressure
  /// p = −K ΔV/V of the enclosed water, implicit in the solid's step) or "incompressible" (the
  /// enclosed volume held: the uniform pressure is the constraint's multiplier). The tunnel's axis is
  /// y (mesh.h5's frame).
  std::string volumeLaw = "none";
  Real bulkModulus = 0;  ///< Pa: the law's K (compressible)
  /// kg/m³: with a volume law, the water's in-plane rigid translation is carried by the solid too (its
  /// mass ρ_w V, implicit; the exchange carries neither mode); 0 = the exchange carries it.
  Real waterDensity = 0;
  /// The water section's ends along the axis y: "closed" (the law holds the whole enclosed volume:
  /// one uniform pressure) or "open" (p = 0 at both ends: the law holds the volume of each plane of
  /// wet nodes, joined by the water's axial plug flow of density axialDensity; docs/coupler.md
  /// "Open ends").
  std::string waterEnds = "closed";
  Real axialDensity = 0;  ///< kg/m³: the axial flow's density (open ends)
  /// Open ends: what closes each end of the water column (end_ymin, end_ymax): "reservoir" (p = 0 at
  /// the end plane), "valve" (no flow through it: the end plane is a station of its own) or
  /// "surge_tank" (a free surface of area surgeTankArea*: the end station's pressure is ρ g times the
  /// level the water that flowed into the tank raised, a compliance A_s/(ρ g) in parallel with the
  /// station's water; docs/theory.md "The water column along the tunnel").
  std::string endYmin = "reservoir", endYmax = "reservoir";
  Real surgeTankAreaYmin = 0, surgeTankAreaYmax = 0;  ///< m²
  /// The water sends its wall pressure less its area mean (the water case's tqInterface
  /// `subtractMeanPressure` is written from the same setting): that uniform part is the closed
  /// section's volume law here, which it therefore needs.
  bool subtractMeanPressure = false;
  /// The wetted face's nodes at its largest y lie on a plane of symmetry (a half block): the
  /// projection of the carried modes counts their area vectors as the whole face's (twice the half's),
  /// so that the motion and force the exchange keeps are the whole face's restricted to the half.
  bool symmetryYmax = false;
};

/// Everything the v2 groups hold; `present` is false for a version 1 input.
struct StagedInput {
  bool present = false;
  StagesInput stages;
  InSituInput inSitu;
  HydrostaticInput hydrostatic;
  FaultOffsetInput faultOffset;
  InterfaceInput rockLining;
  JointsInput liningJoints;
  BottomBoundaryInput bottom;
  FreeFieldInput freeField;
  PeriodicInput periodic;
  MotionInput motion;
  DrmFreeField drm;       ///< /drm: the free field on a domain-reduction layer (absent: no nodes)
  std::string condition;  ///< informational root attribute (no_water, static_water, dynamic_water)
  /// root attribute input_fingerprint: the case keys that shaped this condition (written by
  /// `tunnelquake run`), copied into the results file; its digest goes into each checkpoint manifest
  std::string inputFingerprint;
  CouplingInput coupling;  ///< /coupling (dynamic_water)
};

}  // namespace tq
