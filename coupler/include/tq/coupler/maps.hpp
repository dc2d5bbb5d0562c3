#pragma once
/// @file maps.hpp
/// Interface maps between the lining's wetted nodes and the water's interface points.
///
/// Terms: a *source* mesh carries known nodal values (and, for projection, its surface
/// triangles); *target* points are where values are wanted.
///
/// - ConsistentMap (motion: displacement, velocity): target = W · source with every row of W
///   summing to one, so a constant field is reproduced exactly; projection with barycentric
///   weights also reproduces a linear field exactly at the projected point.
/// - ConservativeMap (forces): source = Wᵀ · target, the transpose of a consistent map. Because
///   the rows of W sum to one, Σ source = Σ target: total force is preserved to round-off, and
///   the work of the forces on the mapped motion is the same on both sides
///   (F_tᵀ (W u_s) = (Wᵀ F_t)ᵀ u_s).
///
/// The constraint is part of the type: a ConservativeMap can only be made as the transpose of a
/// ConsistentMap, and neither converts to the other silently.

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

namespace tq::coupler {

enum class MapConstraint : std::uint8_t { Consistent = 0, Conservative = 1 };
enum class MapKind : std::uint8_t {
  Coincident = 0,  ///< 1:1 node pairs found by position within a tolerance
  Projection = 1,  ///< closest point on the source triangles, barycentric weights
};

/// Non-owning view of a point set with optional surface triangles and ids.
struct SurfaceView {
  const double* coordinates = nullptr;  ///< 3 per node, m
  std::size_t nodes = 0;
  const std::int32_t* triangles = nullptr;  ///< 3 node indices per triangle
  std::size_t numTriangles = 0;
  const std::int64_t* ids = nullptr;  ///< optional, only used in error messages
};

/// Compressed-row sparse matrix of map weights: rows = targets, columns = sources.
struct SparseWeights {
  std::size_t rows = 0, cols = 0;
  std::vector<std::size_t> rowStart{0};
  std::vector<std::uint32_t> col;
  std::vector<double> value;
};

/// Static 3-D k-d tree over a point set (the points must outlive the tree).
class KdTree {
 public:
  KdTree(const double* points, std::size_t n);
  /// Index of the nearest point and its squared distance.
  std::size_t nearest(const double q[3], double* distance2 = nullptr) const;
  /// All points within distance r of q (appended to out).
  void within(const double q[3], double r, std::vector<std::size_t>& out) const;
  std::size_t size() const { return n_; }

 private:
  struct Node {
    std::uint32_t lo, hi;  ///< range in order_
    int axis;              ///< -1 for a leaf
    double split;
    std::int32_t left, right;
  };
  std::int32_t build(std::uint32_t lo, std::uint32_t hi, int depth);
  void nearestRec(std::int32_t node, const double q[3], std::size_t& best, double& bestD2) const;
  void withinRec(std::int32_t node, const double q[3], double r2, std::vector<std::size_t>& out) const;
  const double* p_;
  std::size_t n_;
  std::vector<std::uint32_t> order_;
  std::vector<Node> nodes_;
};

class ConservativeMap;

/// target = W · source, rows of W sum to one.
class ConsistentMap {
 public:
  static constexpr MapConstraint kConstraint = MapConstraint::Consistent;
  /// Takes the weights; throws MapError when a row does not sum to one (to 1e-12).
  explicit ConsistentMap(SparseWeights w);
  std::size_t sourceSize() const { return w_.cols; }
  std::size_t targetSize() const { return w_.rows; }
  /// values[sourceSize × components] → out[targetSize × components], node-major.
  void apply(const double* source, int components, double* target) const;
  std::vector<double> apply(const std::vector<double>& source, int components) const;
  /// The conservative map of the opposite direction: quantities at this map's targets to
  /// its sources, by Wᵀ.
  ConservativeMap transpose() const;
  const SparseWeights& weights() const { return w_; }
  /// True when W is a permutation (coincident 1:1 pairs).
  bool isPermutation() const;

 private:
  SparseWeights w_;
};

/// out = Wᵀ · in where W is a consistent map's weights: Σ out = Σ in.
class ConservativeMap {
 public:
  static constexpr MapConstraint kConstraint = MapConstraint::Conservative;
  /// Number of input nodes (the consistent map's targets).
  std::size_t inputSize() const { return w_.rows; }
  /// Number of output nodes (the consistent map's sources).
  std::size_t outputSize() const { return w_.cols; }
  void apply(const double* in, int components, double* out) const;
  std::vector<double> apply(const std::vector<double>& in, int components) const;

 private:
  friend class ConsistentMap;
  explicit ConservativeMap(const SparseWeights& w) : w_(w) {}
  SparseWeights w_;
};

/// Builds the consistent map from a source surface to target points. Abstract base of the map
/// variants; make one with makeMapBuilder.
class MapBuilder {
 public:
  virtual ~MapBuilder() = default;
  virtual MapKind kind() const = 0;
  /// Throws MapError listing the target (or source) nodes that cannot be mapped.
  virtual ConsistentMap build(const SurfaceView& source, const SurfaceView& target) const = 0;
  /// True when build() needs the source's triangles.
  virtual bool needsSourceTriangles() const = 0;
};

/// 1:1 pairs: every target node has exactly one source node within `tolerance` and vice versa
/// (the paper's coupling node pairs). Equal node counts required.
class CoincidentNodes final : public MapBuilder {
 public:
  explicit CoincidentNodes(double tolerance) : tol_(tolerance) {}
  MapKind kind() const override { return MapKind::Coincident; }
  ConsistentMap build(const SurfaceView& source, const SurfaceView& target) const override;
  bool needsSourceTriangles() const override { return false; }

 private:
  double tol_;
};

/// Each target point takes the barycentric interpolation at its closest point on the source
/// triangles; points farther than `maxDistance` from the surface are an error.
class NearestProjection final : public MapBuilder {
 public:
  explicit NearestProjection(double maxDistance) : maxDist_(maxDistance) {}
  MapKind kind() const override { return MapKind::Projection; }
  ConsistentMap build(const SurfaceView& source, const SurfaceView& target) const override;
  bool needsSourceTriangles() const override { return true; }

 private:
  double maxDist_;
};

std::unique_ptr<MapBuilder> makeMapBuilder(MapKind kind, double tolerance);

/// Splits quadrilaterals (4 node indices each) into triangles along the 0–2 diagonal.
std::vector<std::int32_t> trianglesFromQuads(const std::int32_t* quads, std::size_t numQuads);

}  // namespace tq::coupler
