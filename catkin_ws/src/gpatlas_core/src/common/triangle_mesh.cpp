#include "gpatlas_core/common/triangle_mesh.h"

#include <Eigen/Geometry>

#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

namespace gpatlas_core {

std::string validate(const TriangleMesh& mesh) {
  const int num_vertices = static_cast<int>(mesh.vertices.size());
  for (const Vector3& v : mesh.vertices)
    if (!v.allFinite()) return "mesh has a non-finite vertex";
  for (const Eigen::Vector3i& t : mesh.triangles)
    if ((t.array() < 0).any() || (t.array() >= num_vertices).any()) return "mesh has a vertex index out of range";
  if (!mesh.vertex_variances.empty() && mesh.vertex_variances.size() != mesh.vertices.size())
    return "mesh has a variance count different from its vertex count";
  if (!mesh.vertex_position_sd.empty() && mesh.vertex_position_sd.size() != mesh.vertices.size())
    return "mesh has a position sd count different from its vertex count";
  return {};
}

double triangleArea(const TriangleMesh& mesh, std::size_t triangle) {
  const Eigen::Vector3i& t = mesh.triangles[triangle];
  const Vector3& a = mesh.vertices[static_cast<std::size_t>(t[0])];
  const Vector3& b = mesh.vertices[static_cast<std::size_t>(t[1])];
  const Vector3& c = mesh.vertices[static_cast<std::size_t>(t[2])];
  return 0.5 * (b - a).cross(c - a).norm();
}

double surfaceArea(const TriangleMesh& mesh) {
  double area = 0.0;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) area += triangleArea(mesh, i);
  return area;
}

TriangleMesh makeIcosphere(const Vector3& centre, double radius, int subdivisions) {
  const double phi = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Vector3> unit = {{-1, phi, 0}, {1, phi, 0},  {-1, -phi, 0}, {1, -phi, 0},
                               {0, -1, phi}, {0, 1, phi},  {0, -1, -phi}, {0, 1, -phi},
                               {phi, 0, -1}, {phi, 0, 1},  {-phi, 0, -1}, {-phi, 0, 1}};
  for (Vector3& v : unit) v.normalize();
  std::vector<Eigen::Vector3i> faces = {{0, 11, 5}, {0, 5, 1},  {0, 1, 7},   {0, 7, 10}, {0, 10, 11},
                                        {1, 5, 9},  {5, 11, 4}, {11, 10, 2}, {10, 7, 6}, {7, 1, 8},
                                        {3, 9, 4},  {3, 4, 2},  {3, 2, 6},   {3, 6, 8},  {3, 8, 9},
                                        {4, 9, 5},  {2, 4, 11}, {6, 2, 10},  {8, 6, 7},  {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    // Edge midpoints are shared between the two faces of an edge, so the mesh stays closed.
    std::map<std::pair<int, int>, int> midpoint_of_edge;
    auto midpoint = [&](int a, int b) {
      const std::pair<int, int> key(std::min(a, b), std::max(a, b));
      const auto found = midpoint_of_edge.find(key);
      if (found != midpoint_of_edge.end()) return found->second;
      unit.push_back((unit[static_cast<std::size_t>(a)] + unit[static_cast<std::size_t>(b)]).normalized());
      const int index = static_cast<int>(unit.size()) - 1;
      midpoint_of_edge.emplace(key, index);
      return index;
    };
    std::vector<Eigen::Vector3i> finer;
    finer.reserve(faces.size() * 4);
    for (const Eigen::Vector3i& f : faces) {
      const int ab = midpoint(f[0], f[1]), bc = midpoint(f[1], f[2]), ca = midpoint(f[2], f[0]);
      finer.emplace_back(f[0], ab, ca);
      finer.emplace_back(f[1], bc, ab);
      finer.emplace_back(f[2], ca, bc);
      finer.emplace_back(ab, bc, ca);
    }
    faces.swap(finer);
  }
  TriangleMesh mesh;
  mesh.vertices.reserve(unit.size());
  for (const Vector3& v : unit) mesh.vertices.push_back(centre + radius * v);
  mesh.triangles = std::move(faces);
  return mesh;
}

std::string writePly(const TriangleMesh& mesh, const std::string& path) {
  if (const std::string problem = validate(mesh); !problem.empty()) return problem;
  std::ofstream out(path);
  if (!out) return "cannot open '" + path + "' for writing";
  const bool with_variance = !mesh.vertex_variances.empty();
  const bool with_position_sd = !mesh.vertex_position_sd.empty();
  out << "ply\nformat ascii 1.0\ncomment gpatlas_core predicted surface, metres\n"
      << "element vertex " << mesh.vertices.size() << "\n"
      << "property double x\nproperty double y\nproperty double z\n";
  if (with_variance) out << "property double variance\n";
  if (with_position_sd) out << "property double position_sd_m\n";
  out << "element face " << mesh.triangles.size() << "\nproperty list uchar int vertex_indices\nend_header\n";
  out.precision(std::numeric_limits<double>::max_digits10);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vector3& v = mesh.vertices[i];
    out << v.x() << ' ' << v.y() << ' ' << v.z();
    if (with_variance) out << ' ' << mesh.vertex_variances[i];
    if (with_position_sd) out << ' ' << mesh.vertex_position_sd[i];
    out << '\n';
  }
  for (const Eigen::Vector3i& t : mesh.triangles) out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  out.flush();
  if (!out) return "write to '" + path + "' failed";
  return {};
}

}  // namespace gpatlas_core
