#include "gpatlas_geometry/shape_metrics.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace gpatlas_geometry {

using namespace gpatlas_core;

namespace {

double pointSegmentDistance(const Vector3& p, const Vector3& a, const Vector3& b) {
  const Vector3 ab = b - a;
  const double length_squared = ab.squaredNorm();
  const double t = length_squared > 0.0 ? std::clamp((p - a).dot(ab) / length_squared, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

}  // namespace

double pointTriangleDistance(const Vector3& p, const Vector3& a, const Vector3& b, const Vector3& c) {
  // Ericson, Real-Time Collision Detection, 5.1.5: find the Voronoi region of p.
  const Vector3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return ap.norm();
  const Vector3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return bp.norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return pointSegmentDistance(p, a, b);
  const Vector3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return cp.norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return pointSegmentDistance(p, a, c);
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) return pointSegmentDistance(p, b, c);
  const double denominator = va + vb + vc;
  if (!(std::abs(denominator) > 0.0)) {
    // Degenerate (zero-area) triangle: it is its edges.
    return std::min({pointSegmentDistance(p, a, b), pointSegmentDistance(p, b, c), pointSegmentDistance(p, a, c)});
  }
  const double v = vb / denominator, w = vc / denominator;
  return (p - (a + v * ab + w * ac)).norm();
}

std::vector<Vector3> sampleMeshSurface(const TriangleMesh& mesh, std::size_t count, std::uint64_t seed,
                                       std::vector<std::size_t>* owner_triangles) {
  std::vector<Vector3> samples;
  if (owner_triangles) owner_triangles->clear();
  if (!validate(mesh).empty() || mesh.triangles.empty() || count == 0) return samples;
  std::vector<double> cumulative_area(mesh.triangles.size());
  double total = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    total += triangleArea(mesh, t);
    cumulative_area[t] = total;
  }
  if (!(total > 0.0) || !std::isfinite(total)) return samples;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  samples.reserve(count);
  for (std::size_t s = 0; s < count; ++s) {
    const double target = unit(rng) * total;
    const std::size_t t = std::min(
        static_cast<std::size_t>(std::upper_bound(cumulative_area.begin(), cumulative_area.end(), target) -
                                 cumulative_area.begin()),
        mesh.triangles.size() - 1);
    const Eigen::Vector3i& tri = mesh.triangles[t];
    // sqrt on the first coordinate makes the barycentric draw uniform in area.
    const double r1 = std::sqrt(unit(rng)), r2 = unit(rng);
    samples.push_back((1.0 - r1) * mesh.vertices[static_cast<std::size_t>(tri[0])] +
                      r1 * (1.0 - r2) * mesh.vertices[static_cast<std::size_t>(tri[1])] +
                      r1 * r2 * mesh.vertices[static_cast<std::size_t>(tri[2])]);
    if (owner_triangles) owner_triangles->push_back(t);
  }
  return samples;
}

struct MeshDistanceIndex::Impl {
  bool ok{false};
  std::string message;
  TriangleMesh mesh;
  int k_nearest{1};
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
  std::vector<int> owner_triangle;
  // Triangles sharing a vertex with each triangle (itself included).
  std::vector<std::vector<int>> vertex_neighbours;
  pcl::KdTreeFLANN<pcl::PointXYZ> tree;
};

MeshDistanceIndex::MeshDistanceIndex(const TriangleMesh& mesh, Config config) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (const std::string problem = validate(mesh); !problem.empty()) {
    m.message = problem;
    return;
  }
  if (mesh.triangles.empty()) {
    m.message = "mesh has no triangles";
    return;
  }
  if (config.k_nearest < 1) {
    m.message = "k_nearest must be >= 1";
    return;
  }
  m.mesh = mesh;
  m.k_nearest = config.k_nearest;
  auto add = [&](const Vector3& p, int triangle) {
    m.cloud->push_back(pcl::PointXYZ(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())));
    m.owner_triangle.push_back(triangle);
  };
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    add((mesh.vertices[static_cast<std::size_t>(tri[0])] + mesh.vertices[static_cast<std::size_t>(tri[1])] +
         mesh.vertices[static_cast<std::size_t>(tri[2])]) / 3.0,
        static_cast<int>(t));
  }
  std::vector<std::size_t> owners;
  const std::vector<Vector3> samples = sampleMeshSurface(mesh, config.index_samples, config.seed, &owners);
  for (std::size_t s = 0; s < samples.size(); ++s) add(samples[s], static_cast<int>(owners[s]));
  // A query on one triangle near its edge can have all its nearest samples on the
  // neighbouring triangle; widening each proposal to the triangles around it catches that.
  std::vector<std::vector<int>> triangles_of_vertex(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int corner = 0; corner < 3; ++corner)
      triangles_of_vertex[static_cast<std::size_t>(mesh.triangles[t][corner])].push_back(static_cast<int>(t));
  m.vertex_neighbours.resize(mesh.triangles.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    std::vector<int>& neighbours = m.vertex_neighbours[t];
    for (int corner = 0; corner < 3; ++corner) {
      const auto& around = triangles_of_vertex[static_cast<std::size_t>(mesh.triangles[t][corner])];
      neighbours.insert(neighbours.end(), around.begin(), around.end());
    }
    std::sort(neighbours.begin(), neighbours.end());
    neighbours.erase(std::unique(neighbours.begin(), neighbours.end()), neighbours.end());
  }
  m.tree.setInputCloud(m.cloud);
  m.ok = true;
}

MeshDistanceIndex::~MeshDistanceIndex() = default;
bool MeshDistanceIndex::ok() const { return impl_->ok; }
const std::string& MeshDistanceIndex::message() const { return impl_->message; }

double MeshDistanceIndex::distance(const Vector3& query) const {
  const Impl& m = *impl_;
  if (!m.ok || !query.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  std::vector<int> indices;
  std::vector<float> squared_distances;
  const pcl::PointXYZ point(static_cast<float>(query.x()), static_cast<float>(query.y()), static_cast<float>(query.z()));
  if (m.tree.nearestKSearch(point, m.k_nearest, indices, squared_distances) <= 0)
    return std::numeric_limits<double>::quiet_NaN();
  std::vector<int> candidates;
  for (const int sample : indices) {
    const auto& around = m.vertex_neighbours[static_cast<std::size_t>(m.owner_triangle[static_cast<std::size_t>(sample)])];
    candidates.insert(candidates.end(), around.begin(), around.end());
  }
  std::sort(candidates.begin(), candidates.end());
  candidates.erase(std::unique(candidates.begin(), candidates.end()), candidates.end());
  double best = std::numeric_limits<double>::infinity();
  for (const int triangle : candidates) {
    const Eigen::Vector3i& tri = m.mesh.triangles[static_cast<std::size_t>(triangle)];
    best = std::min(best, pointTriangleDistance(query, m.mesh.vertices[static_cast<std::size_t>(tri[0])],
                                                m.mesh.vertices[static_cast<std::size_t>(tri[1])],
                                                m.mesh.vertices[static_cast<std::size_t>(tri[2])]));
  }
  return best;
}

ShapeMetricsResult ShapeMetrics::compare(const TriangleMesh& predicted, const TriangleMesh& truth) const {
  ShapeMetricsResult result;
  if (config_.samples_per_mesh == 0 || !(config_.f_score_threshold_m > 0.0)) {
    result.message = "samples_per_mesh must be >= 1 and f_score_threshold_m > 0";
    return result;
  }
  for (const auto& [mesh, label] : {std::pair<const TriangleMesh*, const char*>{&predicted, "predicted"},
                                    std::pair<const TriangleMesh*, const char*>{&truth, "ground-truth"}}) {
    if (const std::string problem = validate(*mesh); !problem.empty()) {
      result.message = std::string(label) + " " + problem;
      return result;
    }
    if (mesh->triangles.empty() || !(surfaceArea(*mesh) > 0.0)) {
      result.message = std::string(label) + " mesh has no area";
      return result;
    }
  }
  const MeshDistanceIndex to_truth(truth, config_.index);
  const MeshDistanceIndex to_predicted(predicted, config_.index);
  if (!to_truth.ok() || !to_predicted.ok()) {
    result.message = "index: " + (to_truth.ok() ? to_predicted.message() : to_truth.message());
    return result;
  }
  struct Direction {
    double rmse, mean, within;
  };
  auto measure = [&](const TriangleMesh& from, const MeshDistanceIndex& onto, std::uint64_t seed,
                     std::vector<double>* distances) {
    const std::vector<Vector3> samples = sampleMeshSurface(from, config_.samples_per_mesh, seed);
    double sum = 0.0, sum_squared = 0.0, within = 0.0;
    for (const Vector3& s : samples) {
      const double d = onto.distance(s);
      if (distances) distances->push_back(d);
      sum += d;
      sum_squared += d * d;
      within += d <= config_.f_score_threshold_m ? 1.0 : 0.0;
    }
    const double n = static_cast<double>(samples.size());
    return Direction{std::sqrt(sum_squared / n), sum / n, within / n};
  };
  const Direction forward = measure(predicted, to_truth, config_.seed * 2 + 1, nullptr);
  const Direction backward = measure(truth, to_predicted, truthSampleSeed(config_.seed),
                                     config_.keep_truth_distances ? &result.truth_to_predicted_distances : nullptr);
  result.rmse_predicted_to_truth = forward.rmse;
  result.rmse_truth_to_predicted = backward.rmse;
  result.mean_predicted_to_truth = forward.mean;
  result.mean_truth_to_predicted = backward.mean;
  result.chamfer_l1 = 0.5 * (forward.mean + backward.mean);
  result.precision = forward.within;
  result.recall = backward.within;
  result.f_score = (result.precision + result.recall) > 0.0
                       ? 2.0 * result.precision * result.recall / (result.precision + result.recall)
                       : 0.0;
  result.samples_per_mesh = config_.samples_per_mesh;
  if (!std::isfinite(result.rmse_predicted_to_truth) || !std::isfinite(result.rmse_truth_to_predicted)) {
    result.message = "a distance query failed";
    return result;
  }
  result.ok = true;
  return result;
}

}  // namespace gpatlas_geometry
