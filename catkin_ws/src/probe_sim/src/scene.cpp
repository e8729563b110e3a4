#include "probe_sim/scene.h"

#include <btBulletCollisionCommon.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace probe_sim {

const char* toString(SurfaceKind kind) {
  switch (kind) {
    case SurfaceKind::kNone:
      return "none";
    case SurfaceKind::kObject:
      return "object";
    case SurfaceKind::kTable:
      return "table";
    case SurfaceKind::kObstacle:
      return "obstacle";
  }
  return "unknown";
}

namespace {

btVector3 toBullet(const Eigen::Vector3d& v) {
  return btVector3(static_cast<btScalar>(v.x()), static_cast<btScalar>(v.y()),
                   static_cast<btScalar>(v.z()));
}

Eigen::Vector3d toEigen(const btVector3& v) { return Eigen::Vector3d(v.x(), v.y(), v.z()); }

btTransform toBullet(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.rotation());
  return btTransform(btQuaternion(static_cast<btScalar>(q.x()), static_cast<btScalar>(q.y()),
                                  static_cast<btScalar>(q.z()), static_cast<btScalar>(q.w())),
                     toBullet(Eigen::Vector3d(pose.translation())));
}

SurfaceKind kindOf(const btCollisionObject* object) {
  return object ? static_cast<SurfaceKind>(object->getUserIndex()) : SurfaceKind::kNone;
}

// Bullet keeps pointers into the vertex and index arrays, so they live next to the shape.
struct MeshBuffers {
  std::vector<btScalar> coordinates;
  std::vector<int> indices;
  std::unique_ptr<btTriangleIndexVertexArray> interface;
};

class OverlapCollector : public btCollisionWorld::ContactResultCallback {
 public:
  OverlapCollector(const btCollisionObject* query, double tolerance)
      : query_(query), tolerance_(tolerance) {}

  btScalar addSingleResult(btManifoldPoint& point, const btCollisionObjectWrapper* a, int, int,
                           const btCollisionObjectWrapper* b, int, int) override {
    if (point.getDistance() < -tolerance_) {
      const btCollisionObject* other =
          a->getCollisionObject() == query_ ? b->getCollisionObject() : a->getCollisionObject();
      kinds |= static_cast<unsigned>(kindOf(other));
    }
    return 0;
  }

  unsigned kinds = 0;

 private:
  const btCollisionObject* query_;
  double tolerance_;
};

// Keeps the manifold point nearest to a query sphere's centre.
class NearestPointCollector : public btCollisionWorld::ContactResultCallback {
 public:
  NearestPointCollector(const btCollisionObject* query, const Eigen::Vector3d& centre)
      : query_(query), centre_(centre) {}

  btScalar addSingleResult(btManifoldPoint& point, const btCollisionObjectWrapper* a, int, int,
                           const btCollisionObjectWrapper* b, int, int) override {
    const bool query_is_a = a->getCollisionObject() == query_;
    const Eigen::Vector3d on_surface =
        toEigen(query_is_a ? point.getPositionWorldOnB() : point.getPositionWorldOnA());
    const double distance = (on_surface - centre_).norm();
    if (!nearest || distance < nearest->distance) {
      nearest = SurfacePoint{kindOf(query_is_a ? b->getCollisionObject() : a->getCollisionObject()),
                             on_surface, distance};
    }
    return 0;
  }

  std::optional<SurfacePoint> nearest;

 private:
  const btCollisionObject* query_;
  Eigen::Vector3d centre_;
};

}  // namespace

struct Scene::BulletState {
  btDefaultCollisionConfiguration configuration;
  btCollisionDispatcher dispatcher{&configuration};
  btDbvtBroadphase broadphase;
  btCollisionWorld world{&dispatcher, &broadphase, &configuration};
  std::vector<std::unique_ptr<MeshBuffers>> meshes;
  std::vector<std::unique_ptr<btCollisionShape>> shapes;
  std::vector<std::unique_ptr<btCollisionObject>> objects;

  ~BulletState() {
    for (auto& object : objects) world.removeCollisionObject(object.get());
  }
};

Scene::Scene(const TriangleMesh& object, const Config& config)
    : config_(config), object_mesh_(object), bullet_(std::make_unique<BulletState>()) {
  if (object.empty()) throw std::runtime_error("Scene: the object mesh has no triangles");
  addTriangleMesh(object, SurfaceKind::kObject);
  if (config_.add_table) {
    // A triangle mesh rather than a btBoxShape: Bullet's ray test against a convex shape is an
    // iterative cast that, at the grazing angles of a table's far side, reports hits millimetres
    // above its top, which segmentation cannot tell from an object on it.
    const Eigen::Vector3d lower(config_.table_centre_xy.x() - config_.table_size_xy.x() / 2,
                                config_.table_centre_xy.y() - config_.table_size_xy.y() / 2, -config_.table_thickness);
    const Eigen::Vector3d upper(config_.table_centre_xy.x() + config_.table_size_xy.x() / 2,
                                config_.table_centre_xy.y() + config_.table_size_xy.y() / 2, 0.0);
    TriangleMesh table;
    for (int i = 0; i < 8; ++i)
      table.vertices.emplace_back(i & 1 ? upper.x() : lower.x(), i & 2 ? upper.y() : lower.y(),
                                  i & 4 ? upper.z() : lower.z());
    // Two outward-wound triangles per face (vertex index bits: x = 1, y = 2, z = 4).
    for (const Eigen::Vector4i& quad : {Eigen::Vector4i(0, 2, 3, 1), Eigen::Vector4i(4, 5, 7, 6),
                                        Eigen::Vector4i(0, 1, 5, 4), Eigen::Vector4i(2, 6, 7, 3),
                                        Eigen::Vector4i(0, 4, 6, 2), Eigen::Vector4i(1, 3, 7, 5)}) {
      table.triangles.emplace_back(quad[0], quad[1], quad[2]);
      table.triangles.emplace_back(quad[0], quad[2], quad[3]);
    }
    addTriangleMesh(table, SurfaceKind::kTable);
  }
  bullet_->world.updateAabbs();
}

Scene::~Scene() = default;

void Scene::addStatic(std::unique_ptr<btCollisionShape> shape, const Eigen::Isometry3d& pose,
                      SurfaceKind kind) {
  auto object = std::make_unique<btCollisionObject>();
  object->setCollisionShape(shape.get());
  object->setWorldTransform(toBullet(pose));
  object->setUserIndex(static_cast<int>(kind));
  bullet_->world.addCollisionObject(object.get(), static_cast<int>(kind), -1);
  bullet_->shapes.push_back(std::move(shape));
  bullet_->objects.push_back(std::move(object));
}

void Scene::addObstacleBox(const Eigen::Vector3d& half_extents, const Eigen::Isometry3d& pose) {
  addStatic(std::make_unique<btBoxShape>(toBullet(half_extents)), pose, SurfaceKind::kObstacle);
  bullet_->world.updateAabbs();
}

void Scene::addObstacleMesh(const TriangleMesh& mesh) {
  if (mesh.empty()) throw std::runtime_error("Scene: an obstacle mesh has no triangles");
  addTriangleMesh(mesh, SurfaceKind::kObstacle);
}

void Scene::addTriangleMesh(const TriangleMesh& mesh, SurfaceKind kind) {
  auto buffers = std::make_unique<MeshBuffers>();
  buffers->coordinates.reserve(3 * mesh.vertices.size());
  for (const auto& v : mesh.vertices) {
    for (int i = 0; i < 3; ++i) buffers->coordinates.push_back(static_cast<btScalar>(v[i]));
  }
  buffers->indices.reserve(3 * mesh.triangles.size());
  for (const auto& t : mesh.triangles) {
    for (int i = 0; i < 3; ++i) buffers->indices.push_back(t[i]);
  }
  buffers->interface = std::make_unique<btTriangleIndexVertexArray>(
      static_cast<int>(mesh.triangles.size()), buffers->indices.data(),
      static_cast<int>(3 * sizeof(int)), static_cast<int>(mesh.vertices.size()),
      buffers->coordinates.data(), static_cast<int>(3 * sizeof(btScalar)));
  auto shape = std::make_unique<btBvhTriangleMeshShape>(buffers->interface.get(), true);
  bullet_->meshes.push_back(std::move(buffers));
  addStatic(std::move(shape), Eigen::Isometry3d::Identity(), kind);
  bullet_->world.updateAabbs();
}

RayHit Scene::castRay(const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                      unsigned kinds) const {
  RayHit result;
  const btVector3 bt_from = toBullet(from), bt_to = toBullet(to);
  btCollisionWorld::ClosestRayResultCallback callback(bt_from, bt_to);
  callback.m_collisionFilterMask = static_cast<int>(kinds);
  bullet_->world.rayTest(bt_from, bt_to, callback);
  if (!callback.hasHit()) return result;
  result.hit = true;
  result.kind = kindOf(callback.m_collisionObject);
  result.point = toEigen(callback.m_hitPointWorld);
  const Eigen::Vector3d direction = to - from;
  Eigen::Vector3d normal = toEigen(callback.m_hitNormalWorld).normalized();
  if (normal.dot(direction) > 0.0) normal = -normal;  // the side the ray came from
  result.normal = normal;
  result.distance = callback.m_closestHitFraction * direction.norm();
  return result;
}

std::vector<RayHit> Scene::castRays(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                                    unsigned kinds) const {
  if (from.cols() != to.cols()) {
    throw std::runtime_error("Scene::castRays: different numbers of start and end points");
  }
  std::vector<RayHit> hits;
  hits.reserve(from.cols());
  for (Eigen::Index i = 0; i < from.cols(); ++i) hits.push_back(castRay(from.col(i), to.col(i), kinds));
  return hits;
}

SweepHit Scene::sweepSphere(double radius, const Eigen::Vector3d& from, const Eigen::Vector3d& to,
                            unsigned kinds) const {
  SweepHit result;
  result.sphere_centre = to;
  btSphereShape sphere(static_cast<btScalar>(radius));
  // Bullet tests every triangle inside the bounding box of the whole sweep, which for a long
  // diagonal stroke is most of the object. Pieces one radius long, stopping at the first
  // contact, keep the box small.
  const double length = (to - from).norm();
  const int pieces = std::max(1, static_cast<int>(std::ceil(length / radius)));
  btCollisionWorld::ClosestConvexResultCallback callback(toBullet(from), toBullet(to));
  double piece_start = 0.0;
  for (int piece = 0; piece < pieces && !callback.hasHit(); ++piece) {
    piece_start = static_cast<double>(piece) / pieces;
    const double piece_end = static_cast<double>(piece + 1) / pieces;
    btTransform start = btTransform::getIdentity(), end = btTransform::getIdentity();
    start.setOrigin(toBullet(from + piece_start * (to - from)));
    end.setOrigin(toBullet(from + piece_end * (to - from)));
    callback = btCollisionWorld::ClosestConvexResultCallback(start.getOrigin(), end.getOrigin());
    callback.m_collisionFilterMask = static_cast<int>(kinds);
    bullet_->world.convexSweepTest(&sphere, start, end, callback, 0);
  }
  if (!callback.hasHit()) return result;
  result.hit = true;
  result.kind = kindOf(callback.m_hitCollisionObject);
  result.fraction = piece_start + callback.m_closestHitFraction / pieces;
  result.sphere_centre = from + result.fraction * (to - from);
  result.witness_point = toEigen(callback.m_hitPointWorld);
  // The sweep's own witness comes from GJK and often sits on a triangle corner (about half a
  // facet away from the true contact on a 1-degree tessellated sphere), while the sphere centre
  // at contact is accurate. Bullet's sphere-triangle closest point at that centre is exact.
  constexpr double kSearchSlack = 1e-4;
  const auto nearest =
      closestSurfacePoint(result.sphere_centre, radius + kSearchSlack, static_cast<unsigned>(result.kind));
  if (nearest && nearest->distance > 1e-9) {
    result.witness_point = nearest->point;
    result.normal = (result.sphere_centre - nearest->point) / nearest->distance;
    return result;
  }
  Eigen::Vector3d normal = toEigen(callback.m_hitNormalWorld).normalized();
  // Bullet's sign convention differs between shape pairs; the sphere is on the outside.
  const Eigen::Vector3d outward = result.sphere_centre - result.witness_point;
  if (outward.squaredNorm() > 0.0 ? normal.dot(outward) < 0.0 : normal.dot(to - from) > 0.0) {
    normal = -normal;
  }
  result.normal = normal;
  return result;
}

unsigned Scene::overlapsOf(btCollisionObject& query, unsigned kinds, double tolerance) const {
  OverlapCollector collector(&query, tolerance);
  collector.m_collisionFilterMask = static_cast<int>(kinds);
  bullet_->world.contactTest(&query, collector);
  return collector.kinds;
}

std::optional<SurfacePoint> Scene::closestSurfacePoint(const Eigen::Vector3d& centre,
                                                       double search_radius,
                                                       unsigned kinds) const {
  btSphereShape sphere(static_cast<btScalar>(search_radius));
  btCollisionObject query;
  query.setCollisionShape(&sphere);
  btTransform pose = btTransform::getIdentity();
  pose.setOrigin(toBullet(centre));
  query.setWorldTransform(pose);
  NearestPointCollector collector(&query, centre);
  collector.m_collisionFilterMask = static_cast<int>(kinds);
  bullet_->world.contactTest(&query, collector);
  if (collector.nearest && collector.nearest->distance > search_radius) return std::nullopt;
  return collector.nearest;
}

unsigned Scene::sphereOverlaps(double radius, const Eigen::Vector3d& centre,
                               unsigned kinds) const {
  btSphereShape sphere(static_cast<btScalar>(radius));
  btCollisionObject query;
  query.setCollisionShape(&sphere);
  btTransform pose = btTransform::getIdentity();
  pose.setOrigin(toBullet(centre));
  query.setWorldTransform(pose);
  return overlapsOf(query, kinds, 1e-6);
}

std::vector<unsigned> Scene::capsuleOverlaps(const std::vector<Capsule>& capsules, unsigned kinds,
                                             double tolerance) const {
  std::vector<unsigned> result;
  result.reserve(capsules.size());
  for (const Capsule& capsule : capsules) {
    const Eigen::Vector3d axis = capsule.b - capsule.a;
    const double length = axis.norm();
    std::unique_ptr<btConvexShape> shape;
    if (length < 1e-9) {
      shape = std::make_unique<btSphereShape>(static_cast<btScalar>(capsule.radius));
    } else {
      shape = std::make_unique<btCapsuleShapeZ>(static_cast<btScalar>(capsule.radius),
                                                static_cast<btScalar>(length));
    }
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = (capsule.a + capsule.b) / 2;
    if (length >= 1e-9) {
      pose.linear() =
          Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), axis / length)
              .toRotationMatrix();
    }
    btCollisionObject query;
    query.setCollisionShape(shape.get());
    query.setWorldTransform(toBullet(pose));
    result.push_back(overlapsOf(query, kinds, tolerance));
  }
  return result;
}

}  // namespace probe_sim
