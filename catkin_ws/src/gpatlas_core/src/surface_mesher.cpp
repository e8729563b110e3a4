#include "gpatlas_core/surface_mesher.h"

#include <vtkCellArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

namespace gpatlas_core {

namespace {

// Evaluates the model in batches; `store` receives (column in `points`, prediction, row).
template <typename Store>
void predictInBatches(const SurfaceModel& model, const std::vector<Vector3>& points, int batch_size, bool with_variance,
                      Store store) {
  for (std::size_t first = 0; first < points.size(); first += static_cast<std::size_t>(batch_size)) {
    const std::size_t count = std::min(points.size() - first, static_cast<std::size_t>(batch_size));
    Points3 batch(3, static_cast<Eigen::Index>(count));
    for (std::size_t k = 0; k < count; ++k) batch.col(static_cast<Eigen::Index>(k)) = points[first + k];
    const BatchPrediction prediction = model.predictBatch(batch, false, false, with_variance);
    for (std::size_t k = 0; k < count; ++k) store(first + k, prediction, static_cast<Eigen::Index>(k));
  }
}

// Nodes lower + resolution * (i, j, k) for 0 <= (i, j, k) < size, stored x fastest, then y,
// then z (VTK's image order). NaN marks a node not evaluated yet.
struct Grid {
  Vector3 lower{Vector3::Zero()};
  Eigen::Vector3i size{Eigen::Vector3i::Zero()};
  std::vector<float> values;

  std::size_t index(const Eigen::Vector3i& node) const {
    return static_cast<std::size_t>(node.x()) +
           static_cast<std::size_t>(size.x()) *
               (static_cast<std::size_t>(node.y()) + static_cast<std::size_t>(size.y()) * static_cast<std::size_t>(node.z()));
  }
};

double nodeCount(const Eigen::Vector3i& size) { return static_cast<double>(size.x()) * size.y() * size.z(); }

// Fills every NaN node of `grid`: +1 outside the domain, else the GP mean. False if the model
// returned a non-finite mean.
bool evaluateMissingNodes(const SurfaceModel& model, double resolution, int batch_size, Grid& grid) {
  std::vector<Vector3> query_points;
  std::vector<std::size_t> query_nodes;
  for (int k = 0; k < grid.size.z(); ++k)
    for (int j = 0; j < grid.size.y(); ++j)
      for (int i = 0; i < grid.size.x(); ++i) {
        const std::size_t n = grid.index({i, j, k});
        if (!std::isnan(grid.values[n])) continue;
        const Vector3 x = grid.lower + resolution * Vector3(i, j, k);
        if (!model.inDomain(x)) {
          grid.values[n] = 1.0f;
          continue;
        }
        query_points.push_back(x);
        query_nodes.push_back(n);
      }
  bool finite = true;
  predictInBatches(model, query_points, batch_size, /*with_variance=*/false,
                   [&](std::size_t q, const BatchPrediction& prediction, Eigen::Index row) {
                     const double mean = prediction.mean(row);
                     finite = finite && std::isfinite(mean);
                     grid.values[query_nodes[q]] = std::isfinite(mean) ? static_cast<float>(mean) : 1.0f;
                   });
  return finite;
}

// Whether the predicted solid (mean <= 0) touches the grid's face on `axis`, at its low or high
// side: then the surface may continue beyond it.
bool solidTouchesFace(const Grid& grid, int axis, bool high_side) {
  const int u = (axis + 1) % 3, v = (axis + 2) % 3;
  Eigen::Vector3i node;
  node[axis] = high_side ? grid.size[axis] - 1 : 0;
  for (node[u] = 0; node[u] < grid.size[u]; ++node[u])
    for (node[v] = 0; node[v] < grid.size[v]; ++node[v])
      if (grid.values[grid.index(node)] <= 0.0f) return true;
  return false;
}

std::string tooManyNodes(double nodes, std::size_t max_nodes, const std::string& what) {
  std::ostringstream message;
  message << "grid of " << nodes << " nodes (" << what << ") exceeds max_nodes = " << max_nodes
          << "; coarsen resolution_m or raise max_nodes";
  return message.str();
}

}  // namespace

SurfaceMeshResult SurfaceMesher::mesh(const SurfaceModel& model) const {
  SurfaceMeshResult result;
  if (!model.isFitted()) {
    result.message = "no model: the GP is not fitted";
    return result;
  }
  const double resolution = config_.resolution_m;
  if (!(resolution > 0.0) || !std::isfinite(resolution) || config_.batch_size < 1) {
    result.message = "resolution_m must be positive and finite, batch_size >= 1";
    return result;
  }
  if (!(config_.margin_fraction_of_data_radius >= 0.0) || !std::isfinite(config_.margin_fraction_of_data_radius)) {
    result.message = "margin_fraction_of_data_radius must be finite and >= 0";
    return result;
  }

  // The domain cube's grid, in whose lattice the automatic bounds lie: [first, last] nodes.
  const Vector3 domain_lower = model.centroid() - Vector3::Constant(model.domainRadiusWorld());
  const double domain_nodes_per_axis = std::floor(2.0 * model.domainRadiusWorld() / resolution) + 1.0;
  if (!(domain_nodes_per_axis < 1e9)) {
    result.message = "resolution_m is too fine for the model's domain";
    return result;
  }
  const int domain_nodes = static_cast<int>(domain_nodes_per_axis);
  Eigen::Vector3i first = Eigen::Vector3i::Zero();
  Eigen::Vector3i last = Eigen::Vector3i::Constant(domain_nodes - 1);
  Eigen::AlignedBox<double, 3> surface_box;
  for (const TrainingPoint& point : model.observations())
    if (isSurfaceValue(point)) surface_box.extend(point.position);
  if (!surface_box.isEmpty()) {
    const double margin = config_.margin_fraction_of_data_radius * model.dataRadiusWorld();
    const Eigen::Array3d low = ((surface_box.min().array() - margin) - domain_lower.array()) / resolution;
    const Eigen::Array3d high = ((surface_box.max().array() + margin) - domain_lower.array()) / resolution;
    for (int axis = 0; axis < 3; ++axis) {
      first[axis] = static_cast<int>(std::clamp(std::floor(low[axis]), 0.0, domain_nodes - 1.0));
      last[axis] = static_cast<int>(std::clamp(std::ceil(high[axis]), 0.0, domain_nodes - 1.0));
    }
  }
  const bool automatic = !config_.min_corner && !config_.max_corner;
  const Vector3 lower = config_.min_corner.value_or(domain_lower + resolution * first.cast<double>());
  const Vector3 upper = config_.max_corner.value_or(domain_lower + resolution * last.cast<double>());
  if (!lower.allFinite() || !upper.allFinite() || (upper.array() <= lower.array()).any()) {
    result.message = "grid bounds must be finite with max_corner > min_corner on every axis";
    return result;
  }
  // Automatic bounds count their lattice nodes exactly, not from the corners' rounded difference.
  const Eigen::Array3d nodes_per_axis =
      automatic ? Eigen::Array3d((last - first + Eigen::Vector3i::Ones()).cast<double>().array())
                : Eigen::Array3d(((upper - lower) / resolution).array().floor() + 1.0);
  if (nodes_per_axis.prod() > static_cast<double>(config_.max_nodes)) {
    result.message = tooManyNodes(nodes_per_axis.prod(), config_.max_nodes,
                                  automatic ? "the surface observations' box grown by the margin" : "the given bounds");
    return result;
  }
  Grid grid;
  grid.lower = lower;
  grid.size = nodes_per_axis.cast<int>().matrix();
  result.grid_size = grid.size;
  if ((grid.size.array() < 2).any()) {
    result.message = "the grid needs at least two nodes per axis";
    return result;
  }
  grid.values.assign(static_cast<std::size_t>(nodeCount(grid.size)), std::numeric_limits<float>::quiet_NaN());
  if (!evaluateMissingNodes(model, resolution, config_.batch_size, grid)) {
    result.message = "the model returned a non-finite mean";
    return result;
  }

  // Automatic bounds: move each side that the predicted solid reaches out to the domain cube,
  // keeping the nodes already evaluated, until the solid reaches no movable side.
  while (automatic) {
    Eigen::Vector3i grown_first = first, grown_last = last;
    for (int axis = 0; axis < 3; ++axis) {
      if (first[axis] > 0 && solidTouchesFace(grid, axis, false)) grown_first[axis] = 0;
      if (last[axis] < domain_nodes - 1 && solidTouchesFace(grid, axis, true)) grown_last[axis] = domain_nodes - 1;
    }
    if (grown_first == first && grown_last == last) break;
    Grid grown;
    grown.lower = domain_lower + resolution * grown_first.cast<double>();
    grown.size = grown_last - grown_first + Eigen::Vector3i::Ones();
    if (nodeCount(grown.size) > static_cast<double>(config_.max_nodes)) {
      result.message = tooManyNodes(nodeCount(grown.size), config_.max_nodes,
                                    "grown to the domain where the predicted solid reaches the margin's box");
      return result;
    }
    grown.values.assign(static_cast<std::size_t>(nodeCount(grown.size)), std::numeric_limits<float>::quiet_NaN());
    const Eigen::Vector3i offset = first - grown_first;
    for (int k = 0; k < grid.size.z(); ++k)
      for (int j = 0; j < grid.size.y(); ++j)
        for (int i = 0; i < grid.size.x(); ++i)
          grown.values[grown.index(Eigen::Vector3i(i, j, k) + offset)] = grid.values[grid.index({i, j, k})];
    if (!evaluateMissingNodes(model, resolution, config_.batch_size, grown)) {
      result.message = "the model returned a non-finite mean";
      return result;
    }
    grid = std::move(grown);
    first = grown_first;
    last = grown_last;
    result.grid_size = grid.size;
  }
  const Eigen::Vector3i size = grid.size;
  const std::size_t num_nodes = grid.values.size();
  const std::vector<float>& values = grid.values;

  vtkNew<vtkImageData> image;
  image->SetDimensions(size.x(), size.y(), size.z());
  image->SetOrigin(grid.lower.x(), grid.lower.y(), grid.lower.z());
  image->SetSpacing(resolution, resolution, resolution);
  vtkNew<vtkFloatArray> scalars;
  scalars->SetName("gp_mean");
  scalars->SetNumberOfComponents(1);
  scalars->SetNumberOfTuples(static_cast<vtkIdType>(num_nodes));
  for (std::size_t n = 0; n < num_nodes; ++n) scalars->SetValue(static_cast<vtkIdType>(n), values[n]);
  image->GetPointData()->SetScalars(scalars);

  vtkNew<vtkFlyingEdges3D> contour;
  contour->SetInputData(image);
  contour->SetValue(0, 0.0);
  contour->ComputeNormalsOff();
  contour->ComputeGradientsOff();
  contour->ComputeScalarsOff();
  contour->InterpolateAttributesOff();
  contour->Update();
  vtkPolyData* surface = contour->GetOutput();

  TriangleMesh& mesh = result.mesh;
  vtkPoints* points = surface->GetPoints();
  const vtkIdType num_points = points ? points->GetNumberOfPoints() : 0;
  mesh.vertices.reserve(static_cast<std::size_t>(num_points));
  for (vtkIdType p = 0; p < num_points; ++p) {
    double xyz[3];
    points->GetPoint(p, xyz);
    mesh.vertices.emplace_back(xyz[0], xyz[1], xyz[2]);
  }
  vtkCellArray* polygons = surface->GetPolys();
  if (polygons) {
    polygons->InitTraversal();
    vtkIdType count = 0;
    const vtkIdType* ids = nullptr;
    while (polygons->GetNextCell(count, ids))
      if (count == 3) mesh.triangles.emplace_back(static_cast<int>(ids[0]), static_cast<int>(ids[1]), static_cast<int>(ids[2]));
  }
  if (mesh.triangles.empty()) {
    result.message = "the GP mean has no zero crossing inside the grid";
    return result;
  }
  mesh.vertex_variances.assign(mesh.vertices.size(), 0.0);
  predictInBatches(model, mesh.vertices, config_.batch_size, /*with_variance=*/true,
                   [&](std::size_t n, const BatchPrediction& prediction, Eigen::Index row) {
                     mesh.vertex_variances[n] = prediction.variance(row);
                   });
  result.ok = true;
  return result;
}

}  // namespace gpatlas_core
