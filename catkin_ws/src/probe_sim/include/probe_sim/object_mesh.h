#pragma once

#include <gpatlas_core/common/triangle_mesh.h>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace probe_sim {

// An object's triangle mesh and its files (STL, PLY, OBJ); procedural_objects.h makes meshes of
// simple objects.

// A triangle soup with shared vertices. Nothing here assumes the mesh is closed or consistently
// wound: scanned objects have holes and loose fragments, and every consumer (ray casts, convex
// sweeps) works on individual triangles. It is gpatlas_core's mesh (vertices in metres,
// triangles as vertex indices), so the ground truth goes straight into the shape metrics, plus
// the geometry the simulation needs.
struct TriangleMesh : gpatlas_core::TriangleMesh {
  // Axis-aligned bounds of the vertices referenced or not; empty box when there are none.
  Eigen::AlignedBox3d boundingBox() const;
  // Unit normal by the right-hand rule of the triangle's winding; zero for a degenerate one.
  Eigen::Vector3d triangleNormal(std::size_t triangle_index) const;
  void transform(const Eigen::Isometry3d& pose);
  void scale(double factor);
  void append(const TriangleMesh& other);
};

// Moves the mesh so that its bounding box is centred on (x, y) and its bottom is on z = 0,
// i.e. standing on the table. Scanned meshes come in their scanner's coordinates.
void placeOnTable(TriangleMesh& mesh, const Eigen::Vector2d& xy = Eigen::Vector2d::Zero());

// The mesh files. Every function below reports a problem by throwing std::runtime_error with a
// message "mesh file '<path>': <problem>".

// Loaders: the problems are a missing, empty, truncated or unparsable file, no triangles,
// non-finite coordinates. The returned mesh is in the file's own units; use loadMesh() to scale
// and place it.
TriangleMesh loadStl(const std::string& path);  // binary or ASCII, detected from the content
TriangleMesh loadPly(const std::string& path);  // ascii or binary_little_endian
TriangleMesh loadObj(const std::string& path);  // v / f records, polygons fan-triangulated

// Loads by extension (.stl, .ply, .obj, case-insensitive), multiplies coordinates by scale
// (which must be finite and > 0: meshes in millimetres need 0.001) and then applies pose.
TriangleMesh loadMesh(const std::string& path, double scale = 1.0,
                      const Eigen::Isometry3d& pose = Eigen::Isometry3d::Identity());

// Writes a binary STL with per-facet normals from the winding.
void saveStl(const TriangleMesh& mesh, const std::string& path);

}  // namespace probe_sim
