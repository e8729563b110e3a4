#pragma once

#include "probe_sim/object_mesh.h"

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

namespace probe_sim {

// Every procedural object is scaled so that the largest side of its bounding box equals the
// requested size, then placed with the bounding box centred on x = y = 0 and its bottom on z = 0.
// Proportions (before that scaling, as fractions of the size):
//   sphere    diameter 1 (a cube projected onto the sphere: near-uniform facets, no poles)
//   box       cube of side 1
//   cylinder  radius 0.3, height 1, closed by both caps
//   torus     lying flat, tube radius 1/8, centre-line radius 3/8
//   bowl      thick spherical shell (outer radius 0.5, wall 0.05) cut flat at the bottom, open top
//   mug       thick-walled cup with a floor and a half-torus handle on the +x side
//   funnel    thick-walled cone on top of a spout tube, open at both ends, standing on the spout
// The elongated ones (a kitchen utensil's long side is the size; its handle along +x):
//   spoon     ladle-like: a shallow shell bowl (diameter 0.28, depth 0.08, wall 0.02) and a flat
//             handle 0.08 wide and 0.03 thick leaving the rim
//   pan       frying pan: open cylinder (diameter 0.45, height 0.06, wall 0.012) and a handle
//             0.05 wide and 0.025 thick leaving the rim
struct ProceduralConfig {
  int segments = 96;  // around the vertical axis; rounded up to a multiple of 4
  // Subdivisions of a half circle (sphere) or of curved profiles (bowl arcs, half the torus
  // tube, the mug handle); rounded up to a multiple of 4.
  int rings = 48;
};

std::vector<std::string> proceduralObjectNames();
// Throws std::runtime_error "procedural object '<name>': <problem>" for an unknown name or a size
// that is not finite and > 0.
TriangleMesh makeProceduralObject(const std::string& name, double size_m,
                                  const ProceduralConfig& config = ProceduralConfig());

// Signed distance (negative inside, metres) to the exact shape that makeProceduralObject(name,
// size_m) tessellates, for the shapes with a closed form (sphere, box, cylinder); std::nullopt
// for the others (inside a union of overlapping parts, such as a handle entering a wall, the
// minimum of the parts' distances is not the exact distance).
std::optional<double> proceduralSignedDistance(const std::string& name, double size_m,
                                               const Eigen::Vector3d& point);

double sphereSignedDistance(const Eigen::Vector3d& centre, double radius,
                            const Eigen::Vector3d& point);
double boxSignedDistance(const Eigen::Vector3d& centre, const Eigen::Vector3d& half_extents,
                         const Eigen::Vector3d& point);
// Upright cylinder whose bottom cap is centred on base_centre.
double cylinderSignedDistance(const Eigen::Vector3d& base_centre, double radius, double height,
                              const Eigen::Vector3d& point);

}  // namespace probe_sim
