#pragma once

#include "gpatlas_core/gpis_model.h"
#include "gpatlas_core/triangle_mesh.h"

#include <optional>
#include <string>

namespace gpatlas_core {

struct SurfaceMeshResult {
  bool ok{false};
  std::string message;
  TriangleMesh mesh;  // vertex_variances filled (reported units)
  Eigen::Vector3i grid_size{Eigen::Vector3i::Zero()};
};

// The predicted shape: the zero level set of the GP mean, extracted with VTK's flying-edges
// marching cubes over a regular grid (part of the gpatlas_geometry library). Grid nodes
// outside the model's domain are set to +1 (outside) so the mesh closes inside the domain.
class SurfaceMesher {
 public:
  struct Config {
    double resolution_m{0.005};
    // Axis-aligned bounds; without them the cube enclosing the model's domain ball.
    std::optional<Vector3> min_corner;
    std::optional<Vector3> max_corner;
    std::size_t max_nodes{4'000'000};
    int batch_size{2048};
  };

  SurfaceMesher() = default;
  explicit SurfaceMesher(Config config) : config_(std::move(config)) {}
  SurfaceMeshResult mesh(const GpisModel& model) const;

 private:
  Config config_;
};

}  // namespace gpatlas_core
