#pragma once

#include "gpatlas_core/common/types.h"

#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace gpatlas_core {

// What a probe reports after executing a touch. A failed touch (unreachable, collision,
// nothing touched when contact was required) has success == false and a reason; it may still
// carry free-space points it observed on the way.
// Where a tactile pad pressed (a patch probe): its square's centre and orientation at the
// deepest press (z out of the object, against the press; x along a side), and its side. The
// patch's points and normals are the result's contacts.
struct PadPress {
  Vector3 centre{Vector3::Zero()};
  Eigen::Quaterniond orientation{Eigen::Quaterniond::Identity()};
  double size_m{0.0};
};

struct ProbeResult {
  bool success{false};
  std::string reason;
  std::vector<Contact> contacts;
  std::vector<PadPress> pads;  // one per press that touched the object; empty for point probes
  std::vector<Vector3> free_space;  // points observed to be outside the object, world frame
  // Unexpected contacts of the probe or the arm on the way to the touch (before the probing
  // segment starts) and on the way back: what the robot felt, or what the simulation saw
  // against the true scene. Each contact counts once, however long it lasts.
  int approach_collisions{0};
  int retreat_collisions{0};
};

// Executes touches: the simulated probe, a real robot driver, or an analytic shape in tests.
class Prober {
 public:
  virtual ~Prober() = default;
  virtual ProbeResult probe(const Touch& touch) = 0;
};

}  // namespace gpatlas_core
