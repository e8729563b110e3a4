#pragma once

#include "gpatlas_core/model/surface_model.h"
#include "gpatlas_core/common/triangle_mesh.h"

#include <optional>
#include <string>

namespace gpatlas_geometry {

using gpatlas_core::Vector3;
using gpatlas_core::TriangleMesh;
using gpatlas_core::SurfaceModel;

struct SurfaceMeshResult {
  bool ok{false};
  std::string message;
  // vertex_variances filled (reported units) when Config::vertex_variances, vertex_position_sd
  // (metres) when Config::vertex_position_sd.
  TriangleMesh mesh;
  Eigen::Vector3i grid_size{Eigen::Vector3i::Zero()};
};

// The predicted shape: the zero level set of the GP mean, extracted with VTK's flying-edges
// marching cubes over a regular grid (part of the gpatlas_geometry library). Grid nodes
// outside the model's domain are set to +1 (outside) so the mesh closes inside the domain.
//
// The grid covers where the model has a surface: the axis-aligned box of its surface-value
// observations grown by a margin, within the cube enclosing the domain ball. That cube alone is
// four data radii wide: 4.4 million nodes at 5 mm for the bench's 30 cm pan seen from one side.
// The grid's nodes are those of the domain cube's grid, so a bound that clips nothing gives the
// very mesh of the whole cube. Should the predicted solid still reach a side of the box (a back
// deeper than the margin), that side is moved out to the domain cube and only the new nodes are
// evaluated: the bound never clips the surface and never costs more than the whole cube.
class SurfaceMesher {
 public:
  struct Config {
    double resolution_m{0.003};
    // Margin around the box of the surface observations, as a fraction of the radius of the
    // model's surface data (GpisModelConfig::data_radius in metres: data_radius * scale). One
    // radius: the unseen back of a partial view can lie about one visible width beyond the data,
    // which is also why the domain is twice the data's radius (GpisModelConfig). A compact object
    // thus keeps the whole domain cube; an elongated one loses what lies more than its half length
    // beyond its thin sides.
    double margin_fraction_of_data_radius{1.0};
    // Explicit axis-aligned bounds override the automatic ones (and are never moved).
    std::optional<Vector3> min_corner;
    std::optional<Vector3> max_corner;
    // Safety bound on the grid's nodes: 4 bytes each; the model is evaluated at a fraction of
    // them (coarse_stride).
    std::size_t max_nodes{32'000'000};
    // The model is evaluated on every coarse_stride-th node first, and node by node only in the
    // blocks between them that the surface can enter (1: every node). The mesh is the same.
    int coarse_stride{4};
    // The variance at every vertex (the displays colour the mesh by it): one variance per vertex
    // costs more than the whole mesh for a GP of a thousand points.
    bool vertex_variances{true};
    // The position sd at every vertex (gpatlas_core::positionSd, calibrated): what a saved mesh
    // shows, in metres. Needs the gradient as well as the variance.
    bool vertex_position_sd{false};
    int batch_size{2048};
  };

  SurfaceMesher() = default;
  explicit SurfaceMesher(Config config) : config_(std::move(config)) {}
  SurfaceMeshResult mesh(const SurfaceModel& model) const;

 private:
  Config config_;
};

}  // namespace gpatlas_geometry
