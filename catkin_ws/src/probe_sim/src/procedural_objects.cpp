#include "probe_sim/procedural_objects.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace probe_sim {

namespace {

[[noreturn]] void fail(const std::string& name, const std::string& what) {
  throw std::runtime_error("procedural object '" + name + "': " + what);
}

constexpr double kPi = 3.14159265358979323846;

using Profile = std::vector<Eigen::Vector2d>;  // (radius, height) points

// Surface of revolution of a profile about the z axis. The profile is walked counter-clockwise
// in the (r, z) plane so that the winding gives outward normals; points on the axis (r = 0)
// become a single pole vertex.
TriangleMesh revolve(const Profile& profile, bool closed, int segments) {
  TriangleMesh mesh;
  std::vector<std::vector<int>> rings;
  for (const auto& rz : profile) {
    std::vector<int> ring;
    if (rz.x() <= 1e-12) {
      ring.assign(segments, static_cast<int>(mesh.vertices.size()));
      mesh.vertices.emplace_back(0.0, 0.0, rz.y());
    } else {
      for (int k = 0; k < segments; ++k) {
        const double angle = 2.0 * kPi * k / segments;
        ring.push_back(static_cast<int>(mesh.vertices.size()));
        mesh.vertices.emplace_back(rz.x() * std::cos(angle), rz.x() * std::sin(angle), rz.y());
      }
    }
    rings.push_back(ring);
  }
  const std::size_t edge_count = closed ? profile.size() : profile.size() - 1;
  for (std::size_t i = 0; i < edge_count; ++i) {
    const std::vector<int>& lower = rings[i];
    const std::vector<int>& upper = rings[(i + 1) % profile.size()];
    for (int k = 0; k < segments; ++k) {
      const int next = (k + 1) % segments;
      // Skip the degenerate half of each quad that touches a pole.
      if (lower[k] != lower[next]) mesh.triangles.emplace_back(lower[k], lower[next], upper[next]);
      if (upper[k] != upper[next]) mesh.triangles.emplace_back(lower[k], upper[next], upper[k]);
    }
  }
  return mesh;
}

// Arc of the circle centred at (centre_r, centre_z), from angle a0 to a1 (radians, measured
// from +r towards +z), with n + 1 points including both ends.
void appendArc(Profile& profile, const Eigen::Vector2d& centre, double radius, double a0,
               double a1, int n) {
  for (int i = 0; i <= n; ++i) {
    const double a = a0 + (a1 - a0) * i / n;
    profile.emplace_back(centre.x() + radius * std::cos(a), centre.y() + radius * std::sin(a));
  }
}

// Cube projected onto the sphere with equal-angle spacing: near-uniform facets and no poles
// (a latitude-longitude sphere has sliver triangles at its poles whose normals are far off).
// cells_per_face_side cells span 90 degrees; an even count keeps vertices at the six extremes.
TriangleMesh makeSphereMesh(double radius, int cells_per_face_side) {
  const int n = cells_per_face_side;
  // One table for all faces, exactly symmetric, so that vertices on shared cube edges come out
  // bit-identical from both faces and leave no cracks.
  std::vector<double> tangent(n + 1);
  for (int i = 0; i <= n; ++i) tangent[i] = std::tan(kPi / 4 * (2.0 * i / n - 1.0));
  for (int i = 0; i <= n / 2; ++i) tangent[n - i] = -tangent[i];
  tangent[0] = -1.0;
  tangent[n] = 1.0;
  tangent[n / 2] = 0.0;
  TriangleMesh mesh;
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      const int u = (axis + 1) % 3;
      const int v = (axis + 2) % 3;
      const int first = static_cast<int>(mesh.vertices.size());
      for (int i = 0; i <= n; ++i) {
        for (int j = 0; j <= n; ++j) {
          Eigen::Vector3d p;
          p[axis] = sign;
          p[u] = tangent[i];
          p[v] = tangent[j];
          mesh.vertices.push_back(radius * p.normalized() + Eigen::Vector3d(0, 0, radius));
        }
      }
      auto index = [&](int i, int j) { return first + i * (n + 1) + j; };
      for (int i = 0; i < n; ++i) {
        for (int j = 0; j < n; ++j) {
          // (u, v, axis) is right-handed: this order is counter-clockwise seen from +axis.
          const int a = index(i, j), b = index(i + 1, j), c = index(i + 1, j + 1),
                    d = index(i, j + 1);
          if (sign > 0) {
            mesh.triangles.emplace_back(a, b, c);
            mesh.triangles.emplace_back(a, c, d);
          } else {
            mesh.triangles.emplace_back(a, c, b);
            mesh.triangles.emplace_back(a, d, c);
          }
        }
      }
    }
  }
  return mesh;
}

TriangleMesh makeBoxMesh(const Eigen::Vector3d& size) {
  TriangleMesh mesh;
  const Eigen::Vector3d half = size / 2.0;
  // Each face gets its own four corners so that no vertex is shared across a sharp edge.
  for (int axis = 0; axis < 3; ++axis) {
    for (int sign = -1; sign <= 1; sign += 2) {
      const int u = (axis + 1) % 3;
      const int v = (axis + 2) % 3;
      const int first = static_cast<int>(mesh.vertices.size());
      for (int corner = 0; corner < 4; ++corner) {
        Eigen::Vector3d p;
        p[axis] = sign * half[axis];
        p[u] = (corner == 1 || corner == 2) ? half[u] : -half[u];
        p[v] = (corner >= 2) ? half[v] : -half[v];
        mesh.vertices.push_back(p + Eigen::Vector3d(0, 0, half.z()));
      }
      // (u, v, axis) is right-handed, so corners 0-1-2-3 run counter-clockwise seen from +axis.
      if (sign > 0) {
        mesh.triangles.emplace_back(first, first + 1, first + 2);
        mesh.triangles.emplace_back(first, first + 2, first + 3);
      } else {
        mesh.triangles.emplace_back(first, first + 2, first + 1);
        mesh.triangles.emplace_back(first, first + 3, first + 2);
      }
    }
  }
  return mesh;
}

TriangleMesh makeCylinderMesh(double radius, double height, int segments) {
  const Profile profile = {{0.0, 0.0}, {radius, 0.0}, {radius, height}, {0.0, height}};
  return revolve(profile, false, segments);
}

TriangleMesh makeTorusMesh(double centre_radius, double tube_radius, const ProceduralConfig& c) {
  Profile profile;
  appendArc(profile, Eigen::Vector2d(centre_radius, tube_radius), tube_radius, -kPi, kPi,
            2 * c.rings);
  profile.pop_back();  // the closed revolve joins the last point to the first
  return revolve(profile, true, c.segments);
}

// Spherical shell with its centre at the rim height, cut flat by z = 0 outside and by
// z = wall inside, so that it stands on a foot and has a floor as thick as the wall.
TriangleMesh makeShellBowlMesh(double outer, double wall, double rim_height, const ProceduralConfig& c) {
  const double inner = outer - wall;
  const Eigen::Vector2d centre(0.0, rim_height);
  const double foot_angle = std::asin(-rim_height / outer);  // where the outer sphere meets z=0
  const double floor_angle = std::asin((wall - rim_height) / inner);
  Profile profile = {{0.0, 0.0}};
  appendArc(profile, centre, outer, foot_angle, 0.0, c.rings);
  appendArc(profile, centre, inner, 0.0, floor_angle, c.rings);
  profile.emplace_back(0.0, wall);
  return revolve(profile, false, c.segments);
}

TriangleMesh makeBowlMesh(const ProceduralConfig& c) { return makeShellBowlMesh(0.5, 0.05, 0.4, c); }

// Box of the given size whose face at -x is centred on (start_x, 0, centre_z): a straight
// handle along +x.
TriangleMesh makeHandleMesh(double start_x, double length, double width, double thickness, double centre_z) {
  TriangleMesh handle = makeBoxMesh(Eigen::Vector3d(length, width, thickness));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << start_x + length / 2, 0.0, centre_z - thickness / 2;
  handle.transform(pose);
  return handle;
}

// Tube of radius tube_radius around an arc of radius arc_radius in the x-z plane centred at
// centre, from angle a0 to a1 (measured from +x towards +z), with both ends capped.
TriangleMesh makeTorusSegment(const Eigen::Vector3d& centre, double arc_radius,
                              double tube_radius, double a0, double a1, int arc_steps,
                              int tube_steps) {
  TriangleMesh mesh;
  for (int i = 0; i <= arc_steps; ++i) {
    const double a = a0 + (a1 - a0) * i / arc_steps;
    const Eigen::Vector3d radial(std::cos(a), 0.0, std::sin(a));
    const Eigen::Vector3d axis_point = centre + arc_radius * radial;
    for (int k = 0; k < tube_steps; ++k) {
      const double b = 2.0 * kPi * k / tube_steps;
      mesh.vertices.push_back(axis_point + tube_radius * (std::cos(b) * radial +
                                                          std::sin(b) * Eigen::Vector3d::UnitY()));
    }
  }
  for (int i = 0; i < arc_steps; ++i) {
    for (int k = 0; k < tube_steps; ++k) {
      const int next = (k + 1) % tube_steps;
      const int a = i * tube_steps + k, b = i * tube_steps + next;
      const int c = (i + 1) * tube_steps + k, d = (i + 1) * tube_steps + next;
      mesh.triangles.emplace_back(a, b, d);
      mesh.triangles.emplace_back(a, d, c);
    }
  }
  for (int end = 0; end < 2; ++end) {
    const int ring_start = end == 0 ? 0 : arc_steps * tube_steps;
    const double a = end == 0 ? a0 : a1;
    const int cap_centre = static_cast<int>(mesh.vertices.size());
    mesh.vertices.push_back(centre + arc_radius * Eigen::Vector3d(std::cos(a), 0.0, std::sin(a)));
    for (int k = 0; k < tube_steps; ++k) {
      const int next = (k + 1) % tube_steps;
      if (end == 0) {
        mesh.triangles.emplace_back(cap_centre, ring_start + next, ring_start + k);
      } else {
        mesh.triangles.emplace_back(cap_centre, ring_start + k, ring_start + next);
      }
    }
  }
  return mesh;
}

// The profile of an open cup: up the outside, across the rim, down the inside to the floor.
Profile openCupProfile(double radius, double height, double wall, double floor_thickness) {
  return {{0.0, 0.0},
          {radius, 0.0},
          {radius, height},
          {radius - wall, height},
          {radius - wall, floor_thickness},
          {0.0, floor_thickness}};
}

TriangleMesh makeMugMesh(const ProceduralConfig& c) {
  const double radius = 0.35, height = 0.85, wall = 0.05, floor_thickness = 0.06;
  TriangleMesh mesh = revolve(openCupProfile(radius, height, wall, floor_thickness), false, c.segments);
  // The handle's capped ends sit inside the wall, so from outside it looks attached.
  const double handle_arc = 0.24, handle_tube = 0.03;
  mesh.append(makeTorusSegment(Eigen::Vector3d(radius - wall / 2, 0.0, height / 2), handle_arc,
                               handle_tube, -kPi / 2, kPi / 2, c.rings, std::max(8, c.rings / 2)));
  return mesh;
}

TriangleMesh makeFunnelMesh(int segments) {
  const double top_radius = 0.5, height = 1.0, spout_height = 0.35, spout_radius = 0.08;
  const double wall = 0.03;
  // Closed loop: up the outside of the spout and cone, across the rim, down the inside and
  // back across the annular bottom of the spout.
  const Profile profile = {{spout_radius, 0.0},
                           {spout_radius, spout_height},
                           {top_radius, height},
                           {top_radius - wall, height},
                           {spout_radius - wall, spout_height},
                           {spout_radius - wall, 0.0}};
  return revolve(profile, true, segments);
}

// A ladle-like spoon lying on its bowl: a shallow shell bowl (as the bowl's, diameter 0.28,
// depth 0.08) and a flat straight handle along +x that leaves the rim 5 mm below its top
// (unscaled units: the whole spoon is 1 long). The handle's end face lies inside the bowl's
// wall, between the inner and the outer sphere at every corner, so from outside the handle looks
// attached and nothing of it shows in the cavity.
TriangleMesh makeSpoonMesh(const ProceduralConfig& c) {
  const double outer = 0.14, wall = 0.02, rim_height = 0.08;
  const double handle_start = 0.125, handle_width = 0.08, handle_thickness = 0.03;
  TriangleMesh mesh = makeShellBowlMesh(outer, wall, rim_height, c);
  const double handle_end = 1.0 - outer;  // the spoon's length, from the far side of the bowl, is 1
  mesh.append(makeHandleMesh(handle_start, handle_end - handle_start, handle_width, handle_thickness,
                             rim_height - 0.005 - handle_thickness / 2));
  return mesh;
}

// A frying pan: an open cylinder (diameter 0.45, height 0.06, wall 0.012, floor 0.015) and a
// straight handle along +x just below the rim, its end face inside the wall (unscaled units: the
// pan and its handle are 1 long).
TriangleMesh makePanMesh(const ProceduralConfig& c) {
  const double radius = 0.225, height = 0.06, wall = 0.012, floor_thickness = 0.015;
  TriangleMesh mesh = revolve(openCupProfile(radius, height, wall, floor_thickness), false, c.segments);
  const double handle_start = radius - wall / 2, handle_width = 0.05, handle_thickness = 0.025;
  mesh.append(makeHandleMesh(handle_start, 1.0 - radius - handle_start, handle_width, handle_thickness,
                             height - 0.01 - handle_thickness / 2));
  return mesh;
}

// Uniform scale so that the largest bounding-box side is size_m, then bounding box centred on
// x = y = 0 with its bottom on z = 0.
void normalisePlacement(TriangleMesh& mesh, double size_m) {
  mesh.scale(size_m / mesh.boundingBox().sizes().maxCoeff());
  placeOnTable(mesh);
}

constexpr double kCylinderRadiusFraction = 0.3;

}  // namespace

std::vector<std::string> proceduralObjectNames() {
  return {"sphere", "box", "cylinder", "torus", "bowl", "mug", "funnel", "spoon", "pan"};
}

TriangleMesh makeProceduralObject(const std::string& name, double size_m,
                                  const ProceduralConfig& config) {
  if (!std::isfinite(size_m) || size_m <= 0.0) fail(name, "size must be finite and > 0, got " + std::to_string(size_m));
  ProceduralConfig c = config;
  // Multiples of 4 put vertices on the +-x and +-y axes, so round shapes have exact extents.
  c.segments = std::max(8, (c.segments + 3) / 4 * 4);
  c.rings = std::max(4, (c.rings + 3) / 4 * 4);  // the sphere needs an even count per 90 degrees
  TriangleMesh mesh;
  if (name == "sphere") {
    mesh = makeSphereMesh(0.5, c.rings / 2);
  } else if (name == "box") {
    mesh = makeBoxMesh(Eigen::Vector3d::Ones());
  } else if (name == "cylinder") {
    mesh = makeCylinderMesh(kCylinderRadiusFraction, 1.0, c.segments);
  } else if (name == "torus") {
    mesh = makeTorusMesh(3.0 / 8.0, 1.0 / 8.0, c);
  } else if (name == "bowl") {
    mesh = makeBowlMesh(c);
  } else if (name == "mug") {
    mesh = makeMugMesh(c);
  } else if (name == "funnel") {
    mesh = makeFunnelMesh(c.segments);
  } else if (name == "spoon") {
    mesh = makeSpoonMesh(c);
  } else if (name == "pan") {
    mesh = makePanMesh(c);
  } else {
    std::string known;
    for (const auto& n : proceduralObjectNames()) known += (known.empty() ? "" : ", ") + n;
    fail(name, "unknown (known: " + known + ")");
  }
  normalisePlacement(mesh, size_m);
  return mesh;
}

double sphereSignedDistance(const Eigen::Vector3d& centre, double radius,
                            const Eigen::Vector3d& point) {
  return (point - centre).norm() - radius;
}

double boxSignedDistance(const Eigen::Vector3d& centre, const Eigen::Vector3d& half_extents,
                         const Eigen::Vector3d& point) {
  const Eigen::Vector3d q = (point - centre).cwiseAbs() - half_extents;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double cylinderSignedDistance(const Eigen::Vector3d& base_centre, double radius, double height,
                              const Eigen::Vector3d& point) {
  const Eigen::Vector3d p = point - base_centre;
  const Eigen::Vector2d q(p.head<2>().norm() - radius, std::abs(p.z() - height / 2) - height / 2);
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

std::optional<double> proceduralSignedDistance(const std::string& name, double size_m,
                                               const Eigen::Vector3d& point) {
  if (name == "sphere") {
    return sphereSignedDistance(Eigen::Vector3d(0, 0, size_m / 2), size_m / 2, point);
  }
  if (name == "box") {
    return boxSignedDistance(Eigen::Vector3d(0, 0, size_m / 2),
                             Eigen::Vector3d::Constant(size_m / 2), point);
  }
  if (name == "cylinder") {
    return cylinderSignedDistance(Eigen::Vector3d::Zero(), kCylinderRadiusFraction * size_m,
                                  size_m, point);
  }
  return std::nullopt;
}

}  // namespace probe_sim
