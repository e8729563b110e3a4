#pragma once

#include "probe_sim/object_mesh.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <memory>
#include <optional>
#include <vector>

class btCollisionObject;
class btCollisionShape;
class btCollisionWorld;

namespace probe_sim {

// What a query hit. The values are bit flags so that queries can select several kinds.
enum class SurfaceKind : unsigned { kNone = 0, kObject = 1u << 0, kTable = 1u << 1, kObstacle = 1u << 2 };
constexpr unsigned kAllSurfaces = 0x7u;
const char* toString(SurfaceKind kind);

struct RayHit {
  bool hit = false;
  SurfaceKind kind = SurfaceKind::kNone;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  // Unit normal of the hit triangle / shape, turned to face the ray origin.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double distance = 0.0;  // from the ray origin, metres
};

struct SweepHit {
  bool hit = false;
  SurfaceKind kind = SurfaceKind::kNone;
  // On the touched surface: the point nearest to the sphere centre at contact.
  Eigen::Vector3d witness_point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();         // unit, from the surface to the sphere
  double fraction = 1.0;  // of the sweep travelled before contact
  Eigen::Vector3d sphere_centre = Eigen::Vector3d::Zero();  // at contact (or the end when missed)
};

struct SurfacePoint {
  SurfaceKind kind = SurfaceKind::kNone;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double distance = 0.0;  // from the query centre
};

// Capsule along the segment a-b, for link collision checks.
struct Capsule {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  double radius = 0.0;
};

struct SceneConfig {
  bool add_table = true;
  Eigen::Vector2d table_size_xy{1.5, 1.5};  // metres, centred on table_centre_xy
  Eigen::Vector2d table_centre_xy{0.0, 0.0};
  double table_thickness = 0.05;
};

// The static world the probe and the camera see: the object mesh, a table box whose top is the
// plane z = 0, and optional obstacles. One Scene can serve the camera, the probe and the arm,
// but not from several threads at once: Bullet's broadphase and dispatcher keep scratch state
// even in queries that do not change the world. Use one Scene per thread.
class Scene {
 public:
  using Config = SceneConfig;

  explicit Scene(const TriangleMesh& object, const Config& config = Config());
  ~Scene();
  Scene(const Scene&) = delete;
  Scene& operator=(const Scene&) = delete;

  void addObstacleBox(const Eigen::Vector3d& half_extents, const Eigen::Isometry3d& pose);
  void addObstacleMesh(const TriangleMesh& mesh);

  const TriangleMesh& objectMesh() const { return object_mesh_; }
  const Config& config() const { return config_; }

  // Closest hit on the segment from -> to among the selected kinds (SurfaceKind bits).
  RayHit castRay(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                 unsigned kinds = kAllSurfaces) const;
  // One ray per column pair; same order as the inputs.
  std::vector<RayHit> castRays(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                               unsigned kinds = kAllSurfaces) const;

  // Sweeps a sphere from -> to and reports the first contact among the selected kinds.
  SweepHit sweepSphere(double radius, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                       unsigned kinds = kAllSurfaces) const;

  // Nearest surface point within search_radius of centre, or nullopt when there is none.
  std::optional<SurfacePoint> closestSurfacePoint(const Eigen::Vector3d& centre,
                                                  double search_radius,
                                                  unsigned kinds = kAllSurfaces) const;

  // Kinds (bit set) of surfaces that a sphere placed at centre penetrates.
  unsigned sphereOverlaps(double radius, const Eigen::Vector3d& centre,
                          unsigned kinds = kAllSurfaces) const;
  // For every capsule, the kinds (bit set) of surfaces it penetrates by more than tolerance.
  std::vector<unsigned> capsuleOverlaps(const std::vector<Capsule>& capsules,
                                        unsigned kinds = kAllSurfaces,
                                        double tolerance = 1e-4) const;

 private:
  struct BulletState;
  void addStatic(std::unique_ptr<btCollisionShape> shape, const Eigen::Isometry3d& pose,
                 SurfaceKind kind);
  void addTriangleMesh(const TriangleMesh& mesh, SurfaceKind kind);
  unsigned overlapsOf(btCollisionObject& query, unsigned kinds, double tolerance) const;

  Config config_;
  TriangleMesh object_mesh_;
  std::unique_ptr<BulletState> bullet_;
};

}  // namespace probe_sim
