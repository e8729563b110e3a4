#include "gpatlas_geometry/surface_mesher.h"

#include "gpatlas_core/model/position_uncertainty.h"

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

namespace gpatlas_geometry {

using namespace gpatlas_core;

namespace {

// Evaluates the model in batches; `store` receives (column in `points`, prediction, row).
template <typename Store>
void predictInBatches(const SurfaceModel& model, const std::vector<Vector3>& points, int batch_size, bool with_variance,
                      Store store, bool with_gradient = false) {
  for (std::size_t first = 0; first < points.size(); first += static_cast<std::size_t>(batch_size)) {
    const std::size_t count = std::min(points.size() - first, static_cast<std::size_t>(batch_size));
    Points3 batch(3, static_cast<Eigen::Index>(count));
    for (std::size_t k = 0; k < count; ++k) batch.col(static_cast<Eigen::Index>(k)) = points[first + k];
    const BatchPrediction prediction = model.predictBatch(batch, with_gradient, false, with_variance);
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

// Evaluates the listed nodes: +1 outside the domain, else the model's mean. False if the model
// returned a non-finite mean.
bool evaluateNodes(const SurfaceModel& model, double resolution, int batch_size, const std::vector<Eigen::Vector3i>& nodes,
                   Grid& grid) {
  std::vector<Vector3> query_points;
  std::vector<std::size_t> query_nodes;
  for (const Eigen::Vector3i& node : nodes) {
    const std::size_t n = grid.index(node);
    if (!std::isnan(grid.values[n])) continue;
    const Vector3 x = grid.lower + resolution * node.cast<double>();
    if (!model.inDomain(x)) {
      grid.values[n] = 1.0f;
      continue;
    }
    grid.values[n] = 0.0f;  // claimed: a node listed twice is evaluated once
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

// Fills every NaN node of `grid`. With a stride above 1, the nodes of a coarse lattice (every
// stride-th node, and the last of each axis) are evaluated first; a block between them is
// evaluated node by node only where the surface can pass: its corners differ in sign, or one lies
// closer to the zero level than `band` (in f). Elsewhere the block's nodes take the trilinear
// interpolation of its corners, which keeps their common sign, so marching cubes finds there
// exactly what it would find on the full grid: no crossing. Near the data f grows like the
// normalised distance to the surface, so a band of one block diagonal (over the model's scale)
// keeps every block a surface can enter; where f grows more slowly (far from the data) the band
// only takes in more blocks.
bool evaluateMissingNodes(const SurfaceModel& model, double resolution, int batch_size, int stride, Grid& grid) {
  const auto coarse_index = [&](int axis, int c) { return std::min(c * stride, grid.size[axis] - 1); };
  Eigen::Vector3i blocks;
  for (int axis = 0; axis < 3; ++axis) blocks[axis] = std::max(1, (grid.size[axis] - 1 + stride - 1) / stride);
  std::vector<Eigen::Vector3i> nodes;
  for (int c = 0; c <= blocks.z(); ++c)
    for (int b = 0; b <= blocks.y(); ++b)
      for (int a = 0; a <= blocks.x(); ++a) nodes.emplace_back(coarse_index(0, a), coarse_index(1, b), coarse_index(2, c));
  if (!evaluateNodes(model, resolution, batch_size, nodes, grid)) return false;
  if (stride <= 1) return true;

  const double band = std::sqrt(3.0) * stride * resolution / model.scale();
  std::vector<Eigen::Vector3i> refined, smooth;  // block origins (coarse indices)
  for (int c = 0; c < blocks.z(); ++c)
    for (int b = 0; b < blocks.y(); ++b)
      for (int a = 0; a < blocks.x(); ++a) {
        float low = std::numeric_limits<float>::infinity(), high = -low, nearest = low;
        for (int corner = 0; corner < 8; ++corner) {
          const Eigen::Vector3i node(coarse_index(0, a + (corner & 1)), coarse_index(1, b + ((corner >> 1) & 1)),
                                     coarse_index(2, c + ((corner >> 2) & 1)));
          const float v = grid.values[grid.index(node)];
          low = std::min(low, v);
          high = std::max(high, v);
          nearest = std::min(nearest, std::abs(v));
        }
        const bool surface_can_pass = (low <= 0.0f && high >= 0.0f) || nearest < band;
        (surface_can_pass ? refined : smooth).emplace_back(a, b, c);
      }
  nodes.clear();
  for (const Eigen::Vector3i& block : refined)
    for (int k = coarse_index(2, block.z()); k <= coarse_index(2, block.z() + 1); ++k)
      for (int j = coarse_index(1, block.y()); j <= coarse_index(1, block.y() + 1); ++j)
        for (int i = coarse_index(0, block.x()); i <= coarse_index(0, block.x() + 1); ++i) nodes.emplace_back(i, j, k);
  if (!evaluateNodes(model, resolution, batch_size, nodes, grid)) return false;
  for (const Eigen::Vector3i& block : smooth) {
    const Eigen::Vector3i lo(coarse_index(0, block.x()), coarse_index(1, block.y()), coarse_index(2, block.z()));
    const Eigen::Vector3i hi(coarse_index(0, block.x() + 1), coarse_index(1, block.y() + 1), coarse_index(2, block.z() + 1));
    float corner[8];
    for (int n = 0; n < 8; ++n)
      corner[n] = grid.values[grid.index({(n & 1) ? hi.x() : lo.x(), (n & 2) ? hi.y() : lo.y(), (n & 4) ? hi.z() : lo.z()})];
    const Eigen::Array3f extent = (hi - lo).cast<float>().array().max(1.0f);
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) {
          float& value = grid.values[grid.index({i, j, k})];
          if (!std::isnan(value)) continue;
          const float u = (i - lo.x()) / extent[0], v = (j - lo.y()) / extent[1], w = (k - lo.z()) / extent[2];
          const float x00 = corner[0] + u * (corner[1] - corner[0]), x10 = corner[2] + u * (corner[3] - corner[2]);
          const float x01 = corner[4] + u * (corner[5] - corner[4]), x11 = corner[6] + u * (corner[7] - corner[6]);
          const float y0 = x00 + v * (x10 - x00), y1 = x01 + v * (x11 - x01);
          value = y0 + w * (y1 - y0);
        }
  }
  return true;
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

// Empty when the config is usable, else what is wrong with it.
std::string configProblem(const SurfaceMesher::Config& config) {
  const double resolution = config.resolution_m;
  if (!(resolution > 0.0) || !std::isfinite(resolution) || config.batch_size < 1 || config.coarse_stride < 1)
    return "resolution_m must be positive and finite, batch_size and coarse_stride >= 1";
  if (!(config.margin_fraction_of_data_radius >= 0.0) || !std::isfinite(config.margin_fraction_of_data_radius))
    return "margin_fraction_of_data_radius must be finite and >= 0";
  return {};
}

// The domain cube's grid, in whose lattice the automatic bounds lie, and the automatic bounds'
// first and last nodes in it: the surface observations' box grown by the margin, on the coarse
// lattice of the domain cube so that a grid grown later keeps its blocks (the whole cube
// without surface observations).
struct DomainLattice {
  Vector3 lower{Vector3::Zero()};
  int nodes_per_axis{0};
  Eigen::Vector3i first{Eigen::Vector3i::Zero()}, last{Eigen::Vector3i::Zero()};
};

DomainLattice domainLattice(const SurfaceModel& model, const SurfaceMesher::Config& config, int domain_nodes) {
  const double resolution = config.resolution_m;
  DomainLattice lattice;
  lattice.lower = model.centroid() - Vector3::Constant(model.domainRadiusWorld());
  lattice.nodes_per_axis = domain_nodes;
  lattice.last = Eigen::Vector3i::Constant(domain_nodes - 1);
  Eigen::AlignedBox<double, 3> surface_box;
  for (const TrainingPoint& point : model.observations())
    if (isSurfaceValue(point)) surface_box.extend(point.position);
  if (surface_box.isEmpty()) return lattice;
  const double margin = config.margin_fraction_of_data_radius * model.dataRadiusWorld();
  const Eigen::Array3d low = ((surface_box.min().array() - margin) - lattice.lower.array()) / resolution;
  const Eigen::Array3d high = ((surface_box.max().array() + margin) - lattice.lower.array()) / resolution;
  for (int axis = 0; axis < 3; ++axis) {
    lattice.first[axis] = static_cast<int>(std::clamp(std::floor(low[axis]), 0.0, domain_nodes - 1.0));
    lattice.last[axis] = static_cast<int>(std::clamp(std::ceil(high[axis]), 0.0, domain_nodes - 1.0));
    const int stride = std::max(1, config.coarse_stride);
    lattice.first[axis] = lattice.first[axis] / stride * stride;
    lattice.last[axis] = std::min(domain_nodes - 1, (lattice.last[axis] + stride - 1) / stride * stride);
  }
  return lattice;
}

// Automatic bounds: moves each side that the predicted solid reaches out to the domain cube,
// keeping the nodes already evaluated, until the solid reaches no movable side. Empty when done,
// else why the grid could not grow.
std::string growToSolid(const SurfaceModel& model, const SurfaceMesher::Config& config, DomainLattice& lattice,
                        Grid& grid) {
  const double resolution = config.resolution_m;
  const int domain_nodes = lattice.nodes_per_axis;
  Eigen::Vector3i &first = lattice.first, &last = lattice.last;
  for (;;) {
    Eigen::Vector3i grown_first = first, grown_last = last;
    for (int axis = 0; axis < 3; ++axis) {
      if (first[axis] > 0 && solidTouchesFace(grid, axis, false)) grown_first[axis] = 0;
      if (last[axis] < domain_nodes - 1 && solidTouchesFace(grid, axis, true)) grown_last[axis] = domain_nodes - 1;
    }
    if (grown_first == first && grown_last == last) return {};
    Grid grown;
    grown.lower = lattice.lower + resolution * grown_first.cast<double>();
    grown.size = grown_last - grown_first + Eigen::Vector3i::Ones();
    if (nodeCount(grown.size) > static_cast<double>(config.max_nodes))
      return tooManyNodes(nodeCount(grown.size), config.max_nodes,
                          "grown to the domain where the predicted solid reaches the margin's box");
    grown.values.assign(static_cast<std::size_t>(nodeCount(grown.size)), std::numeric_limits<float>::quiet_NaN());
    const Eigen::Vector3i offset = first - grown_first;
    for (int k = 0; k < grid.size.z(); ++k)
      for (int j = 0; j < grid.size.y(); ++j)
        for (int i = 0; i < grid.size.x(); ++i)
          grown.values[grown.index(Eigen::Vector3i(i, j, k) + offset)] = grid.values[grid.index({i, j, k})];
    if (!evaluateMissingNodes(model, resolution, config.batch_size, config.coarse_stride, grown))
      return "the model returned a non-finite mean";
    grid = std::move(grown);
    first = grown_first;
    last = grown_last;
  }
}

// The zero level set of the grid's values (VTK's flying edges): vertices and triangles.
TriangleMesh zeroLevelSet(const Grid& grid, double resolution) {
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

  TriangleMesh mesh;
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
  return mesh;
}

// The variance and the position sd at each vertex, as asked: one pass over the vertices, with
// the gradient only when the position sd needs it.
void fillVertexUncertainty(const SurfaceModel& model, const SurfaceMesher::Config& config, TriangleMesh& mesh) {
  const bool variances = config.vertex_variances, position_sd = config.vertex_position_sd;
  if (!variances && !position_sd) return;
  if (variances) mesh.vertex_variances.assign(mesh.vertices.size(), 0.0);
  if (position_sd) mesh.vertex_position_sd.assign(mesh.vertices.size(), 0.0);
  predictInBatches(
      model, mesh.vertices, config.batch_size, /*with_variance=*/true,
      [&](std::size_t n, const BatchPrediction& prediction, Eigen::Index row) {
        if (variances) mesh.vertex_variances[n] = prediction.variance(row);
        if (position_sd) mesh.vertex_position_sd[n] = gpatlas_core::positionSd(model, prediction, row);
      },
      /*with_gradient=*/position_sd);
}

}  // namespace

SurfaceMeshResult SurfaceMesher::mesh(const SurfaceModel& model) const {
  SurfaceMeshResult result;
  if (!model.isFitted()) {
    result.message = "no model: the GP is not fitted";
    return result;
  }
  result.message = configProblem(config_);
  if (!result.message.empty()) return result;
  const double resolution = config_.resolution_m;
  const double domain_nodes_per_axis = std::floor(2.0 * model.domainRadiusWorld() / resolution) + 1.0;
  if (!(domain_nodes_per_axis < 1e9)) {
    result.message = "resolution_m is too fine for the model's domain";
    return result;
  }
  DomainLattice lattice = domainLattice(model, config_, static_cast<int>(domain_nodes_per_axis));
  const bool automatic = !config_.min_corner && !config_.max_corner;
  const Vector3 lower = config_.min_corner.value_or(lattice.lower + resolution * lattice.first.cast<double>());
  const Vector3 upper = config_.max_corner.value_or(lattice.lower + resolution * lattice.last.cast<double>());
  if (!lower.allFinite() || !upper.allFinite() || (upper.array() <= lower.array()).any()) {
    result.message = "grid bounds must be finite with max_corner > min_corner on every axis";
    return result;
  }
  // Automatic bounds count their lattice nodes exactly, not from the corners' rounded difference.
  const Eigen::Array3d nodes_per_axis =
      automatic ? Eigen::Array3d((lattice.last - lattice.first + Eigen::Vector3i::Ones()).cast<double>().array())
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
  if (!evaluateMissingNodes(model, resolution, config_.batch_size, config_.coarse_stride, grid)) {
    result.message = "the model returned a non-finite mean";
    return result;
  }
  if (automatic) {
    result.message = growToSolid(model, config_, lattice, grid);
    result.grid_size = grid.size;
    if (!result.message.empty()) return result;
  }
  result.mesh = zeroLevelSet(grid, resolution);
  TriangleMesh& mesh = result.mesh;
  if (mesh.triangles.empty()) {
    result.message = "the GP mean has no zero crossing inside the grid";
    return result;
  }
  result.ok = true;
  fillVertexUncertainty(model, config_, mesh);
  return result;
}

}  // namespace gpatlas_geometry
