/// @file element_block.hpp
/// @brief A group of hex8 elements of one formulation and one material. Element state is held per
///        block, one contiguous array per stress/strain component and per history variable.
///        The force kernel works in fixed-size chunks, vectorised across the chunk's elements:
///        gather -> strain -> hourglass forces -> material update on the chunk -> stress
///        divergence -> scatter into the nodal forces. Chunks form slabs wider than the mesh's
///        node bandwidth, so even slabs scatter concurrently, then odd ones: no atomics, and every
///        node's sum order is fixed by the mesh alone (bitwise identical for any thread count).
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "tq/core/mesh.hpp"
#include "tq/core/nodal_state.hpp"
#include "tq/core/state_archive.hpp"
#include "tq/materials/material.hpp"

namespace tq {

/// Element formulation of a block (see docs/solid_solver.md, "Element formulation").
enum class Hex8Formulation {
  /// Default. One-point (uniform-gradient) hex8 with assumed-strain physical hourglass
  /// stabilisation: linear hourglass strain field, parasitic in-plane bending shear removed, and
  /// the transverse normal strain of each bending mode set so that σ_nn = 0 across the bending
  /// plane (ν̄ = λ/(λ+2μ)): exact for pure plate/ring bending in plane strain.
  OnePointAssumedStrain,
  /// Same without the transverse Poisson correction (ν̄ = 0): bending modulus λ+2μ in the
  /// hourglass part. Kept for comparison.
  OnePointAssumedStrainNoPoisson,
  /// Fully integrated trilinear hex (2x2x2 Gauss), linear elastic only. Reference: shear-locks.
  FullIntegration,
};

/// Parse "one_point_assumed_strain" | "one_point_assumed_strain_no_poisson" | "full_integration".
Hex8Formulation parseFormulation(const std::string& name);
std::string formulationName(Hex8Formulation f);

/// Energy terms of one block for one force evaluation (J).
struct BlockEnergy {
  Real stressWork = 0;    ///< ∫ ½(σ^n + σ^{n+1}) : Δε dV of this evaluation (accumulated by the solver)
  Real storedEnergy = 0;  ///< current elastic hourglass energy (full integration: all strain energy)
  Real dampingWork = 0;   ///< work of the stiffness-proportional damping forces over this step
};

/// What the force kernel needs besides the nodal state.
struct ElementStepParams {
  Real dt = 0;      ///< step about to be taken (s)
  Real dtLast = 0;  ///< step that produced the current displacement increment (0 at start)
  Real beta = 0;    ///< stiffness-proportional Rayleigh coefficient β (s)
  /// Subcycling (Solver::enableSubcycling): evaluate only the chunks whose level is at most this
  /// (the chunks due at this fine step); 255 = every chunk.
  int activeLevel = 255;
};

class ElementBlock {
 public:
  static constexpr Index kChunk = 64;  ///< elements per chunk (material update unit)
  /// Most history values a material may keep per element (the step passes them on the stack).
  static constexpr size_t kMaxHistory = 32;

  /// @param meshElems mesh element indices that form this block (all of one region).
  ElementBlock(std::string name, std::shared_ptr<const Material> material, Hex8Formulation formulation,
               const Mesh& mesh, std::vector<Index> meshElems, Real hourglassScale = 1.0);

  const std::string& name() const { return name_; }
  const Material& material() const { return *material_; }
  Hex8Formulation formulation() const { return formulation_; }
  Index numElems() const { return nElems_; }
  Index meshElem(Index e) const { return meshElems_[e]; }
  Index node(Index e, int k) const { return conn_[8 * size_t(e) + k]; }
  Real volume(Index e) const { return vol_[e]; }
  Real charLength(Index e) const { return charLen_[e]; }
  /// Stress component (Pa), Voigt order xx, yy, zz, xy, yz, zx, as last evaluated.
  Real stress(Index e, int comp) const { return stress_[comp][e]; }
  /// Set a stress component of the last evaluated state (in-situ stress); the next evaluation
  /// adds C:(ε − ε_last) to it, like any other stress.
  void setStress(Index e, int comp, Real value);
  /// The results of a run on MPI ranks (tq/parallel/): element e's state as this block holds it, in
  /// gatheredSize() values: the active flag, the stress (6), the strain record (6; σ_off in total
  /// form) and the history variables; setGatheredState puts such values into a block of the same
  /// material that only holds the gathered state for the results (the mirror of rank 0).
  int gatheredSize() const { return 13 + numHistory(); }
  void gatheredState(Index e, Real* out) const;
  void setGatheredState(Index e, const Real* in);
  /// Number of history variables of each element.
  int numHistory() const { return int(history_.size()); }
  /// Total small strain of the element (engineering shear), as last evaluated.
  Real strain(Index e, int comp) const;
  /// True when the block evaluates σ = C:ε(u) + σ_off in total form (linear elastic material,
  /// one-point element): no strain record, the stress is written but never read back.
  bool totalForm() const { return total_; }
  /// History variable h of element e.
  Real history(int h, Index e) const { return history_[h][e]; }
  /// Energy dissipated by the material so far (plasticity, damage; J): Σ_e V_e h_diss(e) with the
  /// material's dissipation history (J/m^3); 0 for a material that dissipates nothing.
  Real dissipatedEnergy() const;
  bool active(Index e) const { return active_[e] != 0; }
  /// Activate or deactivate (excavation, lining installation). Reactivated elements restart
  /// stress- and strain-free from the current displacement.
  void setActive(Index e, bool on, const NodalState& state);
  /// Restart the strain record of every element from the current displacement, keeping stresses
  /// and history (used when the displacement record is zeroed before the earthquake).
  void rebaseStrain(const NodalState& state);

  /// Add ρ V / 8 of every active element to its nodes.
  void lumpMassInto(NodalState& state) const;
  /// Largest element frequency estimate ω = 2 c_p / L_e (rad/s); *where receives the element.
  Real maxFrequency(Index* where = nullptr) const;
  /// Frequency estimate ω = 2 c_p / L_e of element e (rad/s).
  Real frequency(Index e) const;

  /// Subcycling: give each chunk the level min over its active elements' nodes of nodeLevel
  /// (a chunk is evaluated at the fine steps where the node of the finest level among its
  /// elements is updated: every 2^level fine steps). An empty array clears the levels.
  /// `given` (on MPI ranks): each chunk's level as it is, [chunk] (the level of the one-process
  /// chunk its elements belong to); nodeLevel then only sizes the slabs.
  void setChunkLevels(const std::vector<std::uint8_t>& nodeLevel, const std::vector<std::uint8_t>* given = nullptr);
  /// Level of chunk c (0 without subcycling).
  int chunkLevel(Index c) const { return chunkLevel_.empty() ? 0 : chunkLevel_[size_t(c)]; }
  Index numChunks() const { return Index(chunkEnergy_.size()); }

  /// Add the internal + stiffness-damping forces of every element to the nodal forces f [3N]
  /// (the caller zeroes f first), and return the block's energy terms.
  BlockEnergy computeForcesForElems(const NodalState& state, const ElementStepParams& p, Real* f);
  /// computeForcesForElems in parts, for a caller that runs the slabs of several blocks in one
  /// parallel loop (Solver, when no node is in two blocks): beginForces (the material's pass over
  /// the block), then for parity 0 and then 1 every slab s of numSlabs(p) with s % 2 == parity by
  /// runSlab, in any order and on any thread, then endForces for the energy terms. The same bits as
  /// computeForcesForElems.
  void beginForces(const ElementStepParams& p);
  Index numSlabs(const ElementStepParams& p) const;
  /// Chunks in slab s at the step p (the work it holds).
  Index slabWidth(const ElementStepParams& p, Index s) const;
  void runSlab(const NodalState& state, const ElementStepParams& p, Index s, Real* f);
  BlockEnergy endForces(const ElementStepParams& p) const;
  /// Internal nodal forces of element e at the displacement u [3N] (one-point formulations): its
  /// stress at u (the stress as last evaluated plus the elastic increment C:(ε(u) − ε) since; in
  /// total form C:ε(u) + σ_off) and the hourglass forces at u, without damping forces; zero for an
  /// inactive element. f[3 k + i]: corner k, component i, the force on the element (they sum to
  /// zero and have no moment).
  void elementForces(Index e, const Real* u, Real f[24]) const;
  /// Slabs of the deterministic parallel scatter: chunk boundaries, size slabs + 1 (slabs of one
  /// parity share no node).
  const std::vector<Index>& slabStarts() const { return slabStart_; }
  /// Subcycling: for a level L below the coarsest, the chunks due at a step of level L, in the
  /// order that gives them the narrowest slabs (index or centres along x, y or z), and the slabs
  /// they are scattered in, as positions in that list (slabs of one parity share no node);
  /// numLevels() = the coarsest level (0 without subcycling; its steps use the block's slabs).
  const std::vector<Index>& levelChunks(int L) const { return levelChunks_[size_t(L)]; }
  const std::vector<Index>& levelSlabStarts(int L) const { return levelSlabStart_[size_t(L)]; }
  int numLevels() const { return int(levelChunks_.size()); }

  /// The solid on MPI ranks (tq/parallel/): the order in which a block of `meshElems` (one
  /// region's elements, ascending) adds its elements' values to their nodes, as mesh element
  /// indices: `lumped`, its element order (lumpMassInto); `scattered`, the force kernel's (its
  /// even slabs, then its odd ones). A function of the mesh (its orderLevel too) and the list alone.
  static void nodeSumOrder(const Mesh& mesh, std::vector<Index> meshElems, std::vector<Index>& lumped,
                           std::vector<Index>& scattered);
  /// Subcycling on MPI ranks: the order in which the force kernel of a block whose element order is
  /// `lumped` (nodeSumOrder) adds its elements' forces to their nodes at a step of each level L =
  /// 0 .. maxLevel (orders[L], mesh element indices), its chunks' levels being `chunkLevel`
  /// (setChunkLevels; 255: no active element): the elements of the chunks due at L only, in the
  /// order of that level's slabs (computeForcesForElems). A function of the mesh and the levels.
  static std::vector<std::vector<Index>> levelSumOrders(const Mesh& mesh, const std::vector<Index>& lumped,
                                                        const std::vector<std::uint8_t>& chunkLevel, int maxLevel);
  /// On MPI ranks: besides adding them to the nodal forces, store the corner forces of each element
  /// e with slot[e] >= 0 at out[24 slot[e] + 3 k + i] (corner k, component i; zero for an inactive
  /// element), from which the exchange sums the nodes that the scatter does not sum in the
  /// one-process order (out nullptr: none; slot: one per element of the block, kept by the caller).
  void setCornerForceOutput(Real* out, const Index* slot) {
    cornerOut_ = out;
    cornerSlot_ = slot;
  }

  /// The kernel's vector paths, narrowest first: SSE2 (2 elements a vector, any x86-64), AVX2 + FMA
  /// (4), AVX-512 (8: AVX-512 F, DQ and VL besides AVX2 + FMA). AVX-512 runs the very operations of
  /// AVX2 on twice the elements, so the two give the same bits; the generic path differs from them in
  /// the last bits (fused multiply-add). No path's results depend on the thread count.
  enum class Simd : std::uint8_t { Generic, Avx2, Avx512 };
  /// The widest path this CPU has.
  static Simd simdAvailable();
  /// True when this CPU has AVX2 and FMA (the node update's and the DRM layer's fast path).
  static bool avx2Available() { return simdAvailable() >= Simd::Avx2; }
  /// The path a new block takes: the widest available, narrowed by the environment variable
  /// TQ_SOLID_SIMD=generic or TQ_SOLID_SIMD=avx2 (any other value: the widest).
  static Simd defaultSimd();
  /// Whether the node update and the DRM layer take their AVX2 path (defaultSimd() is not generic).
  static bool defaultUseAvx2() { return defaultSimd() != Simd::Generic; }
  /// Choose the kernel path (at most the widest available).
  void setSimd(Simd s) { simd_ = std::min(s, simdAvailable()); }
  Simd simd() const { return simd_; }
  static const char* simdName(Simd s) { return s == Simd::Avx512 ? "AVX-512" : s == Simd::Avx2 ? "AVX2" : "generic"; }
  /// Save or restore the state a step changes: stresses, strains, history, energies (not the
  /// geometry or the active set, which no step changes).
  void checkpoint(StateArchive& a);
  /// A coupling window's re-passes (Solver::planRepasses): the chunks (skip[c] = 1) that a re-pass
  /// leaves as the window's first pass left them, neither evaluated nor restored (their stresses,
  /// strains and history); empty: none. setRepass(true) from a window's restore to its acceptance;
  /// setRepassSave(true) for the save at a window's start whose re-passes will be so (the chunks a
  /// re-pass restores are the only ones saved).
  void setRepassSkip(std::vector<std::uint8_t> skip);
  void setRepass(bool on) { repass_ = on && !repassSkip_.empty(); }
  void setRepassSave(bool on) { repassSave_ = on && !repassSkip_.empty(); }
  /// Chunk c's energy terms as its last evaluation left them (a skipped chunk's are the solver's to
  /// record in the first pass and give back in a re-pass, so that the block's sums keep their bits).
  BlockEnergy& chunkEnergy(Index c) { return chunkEnergy_[size_t(c)]; }
  /// Whether the material runs a pass over the whole block before each update (Material::blockPass).
  bool hasBlockPass() const { return material_->hasBlockPass(); }

  struct ChunkView;  // raw view of one chunk for the kernel (element_block.cpp)

  /// Element index of the first non-finite or exploding stress (|σ| > limit) or -1.
  Index findBadStress(Real limit) const;

 private:
  template <bool kDamp, bool kTotal>
  void onePointChunk(Index c, Index next, const Real* u, const Real* v, const ElementStepParams& p, Real* f,
                     BlockEnergy& en);
  void fullIntegrationChunk(Index c, const Real* u, Real* f, BlockEnergy& en);
  void strainFromDisplacement(Index e, const NodalState& state);
  /// Whether step p is a subcycled step below the coarsest level (its own chunks and slabs).
  bool levelStep(const ElementStepParams& p) const;
  /// Geometry value `comp` (see element_block.cpp, kG*) of element e.
  Real geo(Index e, int comp) const;

  std::string name_;
  std::shared_ptr<const Material> material_;
  Hex8Formulation formulation_;
  Index nElems_ = 0;
  std::vector<Index> meshElems_, conn_;
  std::vector<std::uint8_t> active_;
  // Geometry (fixed: small strain). One-point element: per chunk, per component, one value per
  // lane ([chunk][49][kChunk]: b 24, h_α·x_j 12, rotation 9, inverse half lengths 3, volume 1),
  // so the kernel loads whole vectors of elements.
  std::vector<Real> vol_, charLen_, geo_;
  std::vector<Real> bg_ /*8*24, full integration*/, wdet_ /*8*/;
  // State. Stored form (any material): stress and the strain record, read and written each step.
  // Total form (linear elastic, one-point): σ = C:ε(u) + σ_off; stress_ is written each step for
  // the outputs, strain_ is empty, offset_ holds σ_off (read only when hasOffset_).
  std::vector<Real> stress_[6], strain_[6], offset_[6];
  std::vector<std::vector<Real>> history_;
  std::vector<Real*> historyPtr_;
  std::vector<Real> elemCentre_[3];  ///< element centres (x, y, z), kept for a material's initHistory
  void initElementHistory(const Mesh& mesh);
  // Constants.
  ElasticModuli mod_;
  Real nuBar_ = 0, hgScale_ = 1;
  int hgHistory_ = -1;  ///< the material's hourglass factor (history index), -1: elastic hourglass stiffness
  bool total_ = false, hasOffset_ = false;
  // Total form: the internal energy is the complementary energy ½ σ:C⁻¹:σ V of the current
  // stress (equal to the stress work for a linear material); energyShift_ keeps it continuous when
  // setStress/setActive change a stress without work (as the stored form's stress work does).
  Real energyShift_ = 0;
  std::vector<BlockEnergy> chunkEnergy_;
  std::vector<std::uint8_t> chunkLevel_;  // subcycling: [chunk] level (empty: every chunk every step)
  // subcycling: [level L below the coarsest] the chunks due at a step of level L, and their slabs
  // (positions in that list; slabs of one parity share no node)
  std::vector<std::vector<Index>> levelChunks_, levelSlabStart_;
  std::vector<Real> chunkCentre_;         // [3 chunk + d] centre of a chunk's elements
  std::vector<Index> slabStart_{0, 0};    // chunk boundaries of the slabs of the parallel scatter
  Simd simd_ = Simd::Generic;             // kernel path
  std::vector<std::uint8_t> repassSkip_;  // setRepassSkip: [chunk] 1 skipped
  std::vector<std::pair<std::size_t, std::size_t>> repassKeep_;  // the element ranges a re-pass restores
  bool repass_ = false;                                          // setRepass
  bool repassSave_ = false;                                      // setRepassSave
  Real* cornerOut_ = nullptr;          // on ranks: the corner forces' destination (setCornerForceOutput)
  const Index* cornerSlot_ = nullptr;  // on ranks: [element] its slot there, or -1
};

/// Fills mesh.orderLevel, the estimate of each node's subcycling level that the element blocks'
/// order follows (ElementBlock's constructor, nodeSumOrder): every element allows
/// ⌊log₂(ω_max / ω_e)⌋ up to maxLevel (ω_e = 2 c_p / L_e, c_p = regionWaveSpeed[its region]; a region
/// at 0 has no material and is left out), a node takes its elements' smallest, the nodes of the
/// tunnel's faces 0 (the water's and the interface's nodes step at the finest level), and the nodes of
/// an element are graded to differ by at most one level, as Solver::enableSubcycling does. Only the
/// order depends on it: a wrong estimate costs element evaluations, never accuracy.
void setOrderLevels(Mesh& mesh, const std::vector<Real>& regionWaveSpeed, int maxLevel);

}  // namespace tq
