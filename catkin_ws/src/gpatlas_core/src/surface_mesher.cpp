#include "gpatlas_core/surface_mesher.h"

#include <vtkCellArray.h>
#include <vtkFlyingEdges3D.h>
#include <vtkFloatArray.h>
#include <vtkImageData.h>
#include <vtkNew.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <vector>

namespace gpatlas_core {

namespace {

// Evaluates the model in batches; `store` receives (column in `points`, prediction, row).
template <typename Store>
void predictInBatches(const GpisModel& model, const std::vector<Vector3>& points, int batch_size, bool with_variance,
                      Store store) {
  for (std::size_t first = 0; first < points.size(); first += static_cast<std::size_t>(batch_size)) {
    const std::size_t count = std::min(points.size() - first, static_cast<std::size_t>(batch_size));
    Points3 batch(3, static_cast<Eigen::Index>(count));
    for (std::size_t k = 0; k < count; ++k) batch.col(static_cast<Eigen::Index>(k)) = points[first + k];
    const BatchPrediction prediction = model.predictBatch(batch, false, false, with_variance);
    for (std::size_t k = 0; k < count; ++k) store(first + k, prediction, static_cast<Eigen::Index>(k));
  }
}

}  // namespace

SurfaceMeshResult SurfaceMesher::mesh(const GpisModel& model) const {
  SurfaceMeshResult result;
  if (!model.isFitted()) {
    result.message = "no model: the GP is not fitted";
    return result;
  }
  if (!(config_.resolution_m > 0.0) || !std::isfinite(config_.resolution_m) || config_.batch_size < 1) {
    result.message = "resolution_m must be positive and finite, batch_size >= 1";
    return result;
  }
  const Vector3 half_extent = Vector3::Constant(model.domainRadiusWorld());
  const Vector3 lower = config_.min_corner.value_or(model.centroid() - half_extent);
  const Vector3 upper = config_.max_corner.value_or(model.centroid() + half_extent);
  if (!lower.allFinite() || !upper.allFinite() || (upper.array() <= lower.array()).any()) {
    result.message = "grid bounds must be finite with max_corner > min_corner on every axis";
    return result;
  }
  const Eigen::Array3d cells = ((upper - lower) / config_.resolution_m).array().floor() + 1.0;
  if (cells.prod() > static_cast<double>(config_.max_nodes)) {
    std::ostringstream message;
    message << "grid of " << cells.prod() << " nodes exceeds max_nodes = " << config_.max_nodes
            << "; coarsen resolution_m";
    result.message = message.str();
    return result;
  }
  const Eigen::Vector3i size = cells.cast<int>().matrix();
  result.grid_size = size;
  if ((size.array() < 2).any()) {
    result.message = "the grid needs at least two nodes per axis";
    return result;
  }

  // VTK's image data stores x fastest, then y, then z.
  const std::size_t num_nodes = static_cast<std::size_t>(size.x()) * size.y() * size.z();
  std::vector<float> values(num_nodes, 1.0f);
  std::vector<Vector3> query_points;
  std::vector<std::size_t> query_nodes;
  for (int k = 0; k < size.z(); ++k)
    for (int j = 0; j < size.y(); ++j)
      for (int i = 0; i < size.x(); ++i) {
        const Vector3 x = lower + config_.resolution_m * Vector3(i, j, k);
        if (!model.inDomain(x)) continue;
        query_points.push_back(x);
        query_nodes.push_back(static_cast<std::size_t>(i) + static_cast<std::size_t>(size.x()) *
                              (static_cast<std::size_t>(j) + static_cast<std::size_t>(size.y()) * k));
      }
  bool finite = true;
  predictInBatches(model, query_points, config_.batch_size, /*with_variance=*/false,
                   [&](std::size_t n, const BatchPrediction& prediction, Eigen::Index row) {
                     const double mean = prediction.mean(row);
                     finite = finite && std::isfinite(mean);
                     values[query_nodes[n]] = std::isfinite(mean) ? static_cast<float>(mean) : 1.0f;
                   });
  if (!finite) {
    result.message = "the model returned a non-finite mean";
    return result;
  }

  vtkNew<vtkImageData> image;
  image->SetDimensions(size.x(), size.y(), size.z());
  image->SetOrigin(lower.x(), lower.y(), lower.z());
  image->SetSpacing(config_.resolution_m, config_.resolution_m, config_.resolution_m);
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
