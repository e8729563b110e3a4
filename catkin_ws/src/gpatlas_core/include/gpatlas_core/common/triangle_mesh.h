#pragma once

#include "gpatlas_core/common/types.h"

#include <Eigen/Core>

#include <string>
#include <vector>

namespace gpatlas_core {

// An indexed triangle mesh in metres, shared by the surface mesher, the shape metrics and the
// ground-truth shapes. vertex_variances (reported units) and vertex_position_sd (metres, the
// position sd along the normal: positionSd) are each either empty or one value per vertex.
struct TriangleMesh {
  std::vector<Vector3> vertices;
  std::vector<Eigen::Vector3i> triangles;
  std::vector<double> vertex_variances;
  std::vector<double> vertex_position_sd;

  bool empty() const { return triangles.empty(); }
};

// An empty string when every index is in range and every coordinate finite, else the problem.
std::string validate(const TriangleMesh& mesh);
double triangleArea(const TriangleMesh& mesh, std::size_t triangle);
double surfaceArea(const TriangleMesh& mesh);

// An icosphere: the icosahedron subdivided `subdivisions` times with vertices pushed onto the
// sphere, so every vertex is exactly on it and faces lie inside by at most the sag
// radius * (1 - cos(half the angle a face spans)).
TriangleMesh makeIcosphere(const Vector3& centre, double radius, int subdivisions);

// Writes an ASCII PLY with x y z per vertex, plus a `variance` property when the mesh carries
// vertex variances and a `position_sd_m` property when it carries position sds (after the
// variance: readers that take the first columns keep working). Returns an empty string on
// success, else the reason.
std::string writePly(const TriangleMesh& mesh, const std::string& path);

}  // namespace gpatlas_core
