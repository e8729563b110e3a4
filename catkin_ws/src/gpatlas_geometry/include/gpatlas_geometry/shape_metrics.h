#pragma once

#include "gpatlas_core/common/triangle_mesh.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_geometry {

using gpatlas_core::Vector3;
using gpatlas_core::TriangleMesh;

// Area-weighted random points on a mesh (seeded): each point picks a triangle with probability
// proportional to its area, then a uniform point inside it. `owner_triangles`, if given,
// receives each point's triangle index.
std::vector<Vector3> sampleMeshSurface(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed,
                                       std::vector<std::size_t>* owner_triangles = nullptr);
// The truth samples ShapeMetrics::compare draws (for measuring on a subset of the same points).
inline std::uint64_t truthSampleSeed(std::uint64_t metrics_seed) { return metrics_seed * 2 + 2; }

// Exact distance from a point to a triangle (closest point by Voronoi regions).
double pointTriangleDistance(const Vector3& p, const Vector3& a, const Vector3& b, const Vector3& c);

// Nearest-surface distance queries against one mesh. A PCL kd-tree over dense area-weighted
// samples of the mesh (plus every triangle's centroid, so small triangles are never missed)
// proposes the triangles owning the k nearest samples and every triangle sharing a vertex
// with them; the exact point-to-triangle distance over those is returned. It is exact
// whenever the closest triangle is among them, which dense samples make the normal case;
// otherwise it errs by at most the sample spacing.
class MeshDistanceIndex {
 public:
  struct Config {
    std::size_t index_samples{60000};
    int k_nearest{8};
    std::uint64_t seed{11};
  };
  MeshDistanceIndex(const TriangleMesh& mesh, Config config);
  explicit MeshDistanceIndex(const TriangleMesh& mesh) : MeshDistanceIndex(mesh, Config()) {}
  ~MeshDistanceIndex();
  MeshDistanceIndex(const MeshDistanceIndex&) = delete;
  MeshDistanceIndex& operator=(const MeshDistanceIndex&) = delete;

  bool ok() const;
  const std::string& message() const;
  // NaN when the index is not ok or the query is not finite.
  double distance(const Vector3& query) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct ShapeMetricsResult {
  bool ok{false};
  std::string message;
  double rmse_predicted_to_truth{0.0};  // metres
  double rmse_truth_to_predicted{0.0};
  double mean_predicted_to_truth{0.0};
  double mean_truth_to_predicted{0.0};
  double chamfer_l1{0.0};  // mean of the two mean distances
  double precision{0.0};   // fraction of predicted samples within the F-score threshold
  double recall{0.0};      // fraction of truth samples within the threshold
  double f_score{0.0};
  std::size_t samples_per_mesh{0};
  // With Config::keep_truth_distances: each truth sample's distance to the predicted mesh, in
  // the order of sampleMeshSurface(truth, samples_per_mesh, truthSampleSeed(seed)).
  std::vector<double> truth_to_predicted_distances;
};

// Compares a predicted mesh with a ground-truth mesh in both directions.
class ShapeMetrics {
 public:
  struct Config {
    std::size_t samples_per_mesh{20000};
    double f_score_threshold_m{0.005};
    MeshDistanceIndex::Config index;
    std::uint64_t seed{3};
    bool keep_truth_distances{false};
  };
  ShapeMetrics() = default;
  explicit ShapeMetrics(Config config) : config_(std::move(config)) {}
  ShapeMetricsResult compare(const TriangleMesh& predicted, const TriangleMesh& truth) const;

 private:
  Config config_;
};

}  // namespace gpatlas_geometry
