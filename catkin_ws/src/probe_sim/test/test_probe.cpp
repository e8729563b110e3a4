#include "probe_sim/probe.h"
#include "probe_sim/procedural_objects.h"

#include "tessellated_sphere.h"

#include <gtest/gtest.h>

#include <cmath>
#include <memory>

using gpatlas_core::ProbeResult;
using gpatlas_core::Touch;
using probe_sim::Scene;
using probe_sim::SimulatedProber;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

using probe_sim_test::kCentre;
using probe_sim_test::kRadius;
using probe_sim_test::kSize;
using probe_sim_test::sagittaBound;

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Largest angle between a facet's normal and the sphere's radial direction anywhere on the
// facet (the largest is at a corner).
double facetTilt(const probe_sim::TriangleMesh& mesh) {
  double tilt = 0.0;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (int corner = 0; corner < 3; ++corner) {
      const Eigen::Vector3d& v = mesh.vertices[mesh.triangles[t][corner]];
      tilt = std::max(tilt, angleBetween(mesh.triangleNormal(t), v - kCentre));
    }
  }
  return tilt;
}

Eigen::Vector3d direction(double azimuth, double elevation) {
  return Eigen::Vector3d(std::cos(elevation) * std::cos(azimuth),
                         std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
}

// Outward normals over the part of the sphere a probe can approach (not from below the table).
// The angles are off the 1-degree tessellation grid so that most rays land inside triangles,
// where the facets deviate most from the sphere.
std::vector<Eigen::Vector3d> testDirections() {
  std::vector<Eigen::Vector3d> directions;
  for (double elevation : {-9.61, 0.37, 17.29, 45.53, 71.71, 89.45}) {
    for (double azimuth : {0.43, 37.38, 123.66, 200.5, 301.27}) {
      directions.push_back(direction(azimuth * kDegree, elevation * kDegree));
    }
  }
  return directions;
}

Touch poke(const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
  Touch touch;
  touch.kind = Touch::Kind::kPoke;
  touch.points = {point};
  touch.normals = {normal};
  touch.variances = {1.0};
  return touch;
}

class SphereObject : public ::testing::Test {
 protected:
  void SetUp() override {
    probe_sim::ProceduralConfig tessellation;
    tessellation.segments = 360;
    tessellation.rings = 180;
    scene_ = std::make_shared<Scene>(probe_sim::makeProceduralObject("sphere", kSize, tessellation));
    sagitta_ = sagittaBound(scene_->objectMesh());
  }

  std::shared_ptr<Scene> scene_;
  double sagitta_ = 0.0;
};

}  // namespace

TEST_F(SphereObject, TessellationIsFineEnoughForTheTolerances) {
  // 1-degree cells put the deepest triangle point ~1e-5 m inside a 5 cm sphere, and no facet
  // normal is more than a degree off the radial direction.
  EXPECT_GT(sagitta_, 0.0);
  EXPECT_LT(sagitta_, 1e-4);
  EXPECT_LT(facetTilt(scene_->objectMesh()), 1.0 * kDegree);
  RecordProperty("sagitta_um", std::to_string(sagitta_ * 1e6));
  RecordProperty("facet_tilt_deg", std::to_string(facetTilt(scene_->objectMesh()) / kDegree));
}

TEST_F(SphereObject, RayProbeHitsTheAnalyticContactWithTheAnalyticNormal) {
  SimulatedProber prober(scene_, probe_sim::makeProbeModel("ray"));
  double worst_position = 0.0, worst_normal = 0.0;
  for (const Eigen::Vector3d& n : testDirections()) {
    SCOPED_TRACE(n.transpose());
    for (double off_surface : {-0.03, 0.0, 0.04}) {
      // The waypoint the planner predicted may be off the real surface; the stroke still finds it.
      const ProbeResult result = prober.probe(poke(kCentre + (kRadius + off_surface) * n, n));
      ASSERT_TRUE(result.success) << result.reason;
      ASSERT_EQ(result.contacts.size(), 1u);
      const Eigen::Vector3d expected = kCentre + kRadius * n;
      worst_position = std::max(worst_position, (result.contacts[0].position - expected).norm());
      worst_normal = std::max(worst_normal, angleBetween(result.contacts[0].normal, n));
      EXPECT_LE((result.contacts[0].position - expected).norm(), sagitta_ + 1e-6);
      EXPECT_LT(angleBetween(result.contacts[0].normal, n), 1.0 * kDegree);
      // Free space: from 10 cm above the waypoint, 1 cm apart, outside the sphere with a margin.
      ASSERT_FALSE(result.free_space.empty());
      EXPECT_TRUE(result.free_space.front().isApprox(kCentre + (kRadius + off_surface + 0.1) * n));
      for (std::size_t i = 0; i < result.free_space.size(); ++i) {
        const double distance = (result.free_space[i] - kCentre).norm() - kRadius;
        EXPECT_GE(distance, 0.005 - sagitta_ - 1e-9);
        if (i > 0) {
          EXPECT_NEAR((result.free_space[i] - result.free_space[i - 1]).norm(), 0.01, 1e-9);
        }
      }
      // The last sample is the last one that fits before the margin.
      const double last = (result.free_space.back() - kCentre).norm() - kRadius;
      EXPECT_LT(last, 0.005 + 0.01 + sagitta_);
    }
  }
  RecordProperty("worst_contact_error_um", std::to_string(worst_position * 1e6));
  RecordProperty("worst_normal_error_deg", std::to_string(worst_normal / kDegree));
}

TEST_F(SphereObject, ObliqueRayMatchesTheAnalyticLineSphereIntersection) {
  probe_sim::RayProbe ray;
  const Eigen::Vector3d n = direction(0.4, 0.3);
  const Eigen::Vector3d tangent = n.cross(Eigen::Vector3d::UnitZ()).normalized();
  for (double lateral : {0.01, 0.025, 0.04}) {
    const Eigen::Vector3d waypoint = kCentre + kRadius * n + lateral * tangent;
    const probe_sim::ProbeStroke stroke = ray.stroke(*scene_, waypoint, n);
    ASSERT_EQ(stroke.touched, probe_sim::SurfaceKind::kObject);
    // Line p(s) = start - s n; |p - c| = R gives s = b - sqrt(b^2 - |start - c|^2 + R^2).
    const Eigen::Vector3d start = waypoint + 0.1 * n;
    const double b = (start - kCentre).dot(n);
    const double s = b - std::sqrt(b * b - (start - kCentre).squaredNorm() + kRadius * kRadius);
    const Eigen::Vector3d expected = start - s * n;
    // A radial error e of the facets becomes e / cos(incidence) along an oblique ray.
    const double incidence = angleBetween(expected - kCentre, n);
    EXPECT_LE((stroke.contact.position - expected).norm(), sagitta_ / std::cos(incidence) + 1e-6);
    EXPECT_LT(angleBetween(stroke.contact.normal, (expected - kCentre).normalized()), 1.0 * kDegree);
  }
}

TEST_F(SphereObject, SphereProbeWitnessPointAndNormalMatchTheSphere) {
  SimulatedProber prober(scene_, probe_sim::makeProbeModel("sphere"));
  // A 2 cm sphere resting on a facet tilted by a against the radial direction touches it
  // 2 cm * sin(a) to the side of the analytic contact; with the facets' sagitta that bounds
  // the distance from the analytic point (about 0.25 mm at 1-degree facets).
  const double tolerance = 0.02 * std::sin(facetTilt(scene_->objectMesh())) + sagitta_;
  RecordProperty("tolerance_um", std::to_string(tolerance * 1e6));
  double worst_position = 0.0, worst_normal = 0.0;
  for (const Eigen::Vector3d& n : testDirections()) {
    SCOPED_TRACE(n.transpose());
    const ProbeResult result = prober.probe(poke(kCentre + kRadius * n, n));
    ASSERT_TRUE(result.success) << result.reason;
    ASSERT_EQ(result.contacts.size(), 1u);
    const Eigen::Vector3d expected = kCentre + kRadius * n;
    worst_position = std::max(worst_position, (result.contacts[0].position - expected).norm());
    worst_normal = std::max(worst_normal, angleBetween(result.contacts[0].normal, n));
    EXPECT_LE((result.contacts[0].position - expected).norm(), tolerance);
    EXPECT_LT(angleBetween(result.contacts[0].normal, n), 1.0 * kDegree);
    // Free space is where the probe centre was: never closer than the probe radius.
    for (const Eigen::Vector3d& centre : result.free_space) {
      EXPECT_GE((centre - kCentre).norm() - kRadius, 0.02 - 1e-4);
    }
  }
  RecordProperty("worst_contact_error_um", std::to_string(worst_position * 1e6));
  RecordProperty("worst_normal_error_deg", std::to_string(worst_normal / kDegree));
}

TEST_F(SphereObject, MissReturnsOnlyFreeSpaceOutsideTheObject) {
  for (const std::string& model : probe_sim::probeModelNames()) {
    SCOPED_TRACE(model);
    SimulatedProber prober(scene_, probe_sim::makeProbeModel(model));
    // Beside the sphere, moving horizontally: passes 0.15 m from its centre.
    const ProbeResult result =
        prober.probe(poke(kCentre + Eigen::Vector3d(0.15, 0.0, 0.0), Eigen::Vector3d::UnitY()));
    EXPECT_FALSE(result.success);
    EXPECT_EQ(result.reason, "no contact");
    EXPECT_TRUE(result.contacts.empty());
    EXPECT_EQ(result.free_space.size(), 21u);  // 0.2 m stroke sampled every 0.01 m, both ends
    for (const Eigen::Vector3d& p : result.free_space) {
      EXPECT_GT((p - kCentre).norm(), kRadius);
    }
  }
}

TEST_F(SphereObject, TableContactIsNotAnObjectContact) {
  SimulatedProber prober(scene_, probe_sim::makeProbeModel("ray"));
  const ProbeResult result =
      prober.probe(poke(Eigen::Vector3d(0.3, 0.2, 0.0), Eigen::Vector3d::UnitZ()));
  EXPECT_FALSE(result.success);
  EXPECT_NE(result.reason.find("table"), std::string::npos) << result.reason;
  EXPECT_EQ(result.free_space.size(), 10u);  // 0.1 m down to the table minus the 5 mm margin
}

TEST_F(SphereObject, SlideCollectsContactsEverySlideStep) {
  SimulatedProber::Config config;
  config.slide_step_m = 0.005;
  Touch slide;
  slide.kind = Touch::Kind::kSlide;
  // Four waypoints along a meridian from the equator up to 60 degrees.
  for (double elevation : {0.0, 20.0, 40.0, 60.0}) {
    const Eigen::Vector3d n = direction(0.3, elevation * kDegree);
    slide.points.push_back(kCentre + kRadius * n);
    slide.normals.push_back(n);
  }
  double path_length = 0.0;
  for (std::size_t i = 1; i < slide.points.size(); ++i) {
    path_length += (slide.points[i] - slide.points[i - 1]).norm();
  }
  for (const std::string model : {"ray", "sphere"}) {  // the point probes: one contact per attempt
    SCOPED_TRACE(model);
    SimulatedProber prober(scene_, probe_sim::makeProbeModel(model), config);
    const ProbeResult result = prober.probe(slide);
    ASSERT_TRUE(result.success) << result.reason;
    const auto expected_attempts = static_cast<std::size_t>(std::ceil(path_length / 0.005)) + 1;
    EXPECT_EQ(result.contacts.size(), expected_attempts);
    for (std::size_t i = 0; i < result.contacts.size(); ++i) {
      const Eigen::Vector3d& p = result.contacts[i].position;
      EXPECT_NEAR((p - kCentre).norm(), kRadius, sagitta_ + 1e-6);  // on the mesh
      if (i > 0) {
        // Contacts on the arc are a little further apart than attempts on the chords.
        const double gap = (p - result.contacts[i - 1].position).norm();
        EXPECT_GT(gap, 0.004);
        EXPECT_LT(gap, 0.0055);
      }
    }
    EXPECT_LT((result.contacts.front().position - slide.points.front()).norm(), 1e-3);
    EXPECT_LT((result.contacts.back().position - slide.points.back()).norm(), 1e-3);
    // Each attempt samples its stroke every 1 cm from 10 cm out down to 5 mm before contact
    // (of the ray, or of the probe sphere's 2 cm radius): 10 or 8 samples.
    const std::size_t per_attempt = model == "ray" ? 10 : 8;
    EXPECT_EQ(result.free_space.size(), per_attempt * expected_attempts);
  }
}

TEST_F(SphereObject, ContactNoiseHasTheConfiguredSpreadAndIsSeeded) {
  probe_sim::ProbeModelConfig config;
  config.sphere.position_noise_m = 0.001;
  config.sphere.seed = 5;
  // The noise does not depend on the tessellation: a coarse sphere keeps this test fast.
  auto coarse = std::make_shared<Scene>(probe_sim::makeProceduralObject("sphere", kSize));
  SimulatedProber noisy(coarse, probe_sim::makeProbeModel("sphere", config));
  SimulatedProber same_seed(coarse, probe_sim::makeProbeModel("sphere", config));
  SimulatedProber exact(coarse, probe_sim::makeProbeModel("sphere"));
  double squared_error = 0.0;
  int samples = 0;
  for (int repeat = 0; repeat < 10; ++repeat) {
    for (const Eigen::Vector3d& n : testDirections()) {
      const Touch touch = poke(kCentre + kRadius * n, n);
      const ProbeResult a = noisy.probe(touch);
      const ProbeResult b = same_seed.probe(touch);
      const ProbeResult truth = exact.probe(touch);
      ASSERT_TRUE(a.success && b.success && truth.success);
      EXPECT_EQ(a.contacts[0].position, b.contacts[0].position);
      squared_error += (a.contacts[0].position - truth.contacts[0].position).squaredNorm();
      samples += 3;
    }
  }
  // 900 Gaussian samples: the estimated sigma is within a few percent of the truth.
  EXPECT_NEAR(std::sqrt(squared_error / samples), 0.001, 0.0001);
}

TEST_F(SphereObject, ObstacleInTheWayStopsTheProbe) {
  Scene scene(scene_->objectMesh());
  // A thin plate 3 cm above the top of the sphere.
  Eigen::Isometry3d plate = Eigen::Isometry3d::Identity();
  plate.translation() = kCentre + Eigen::Vector3d(0, 0, kRadius + 0.03);
  scene.addObstacleBox(Eigen::Vector3d(0.05, 0.05, 0.002), plate);
  const probe_sim::ProbeStroke stroke =
      probe_sim::RayProbe().stroke(scene, kCentre + kRadius * Eigen::Vector3d::UnitZ(),
                                   Eigen::Vector3d::UnitZ());
  EXPECT_EQ(stroke.touched, probe_sim::SurfaceKind::kObstacle);
  EXPECT_NEAR(stroke.contact.position.z(), plate.translation().z() + 0.002, 1e-4);
  // Only the object is returned when asked for it: the plate is skipped.
  const probe_sim::RayHit object_only =
      scene.castRay(kCentre + Eigen::Vector3d(0, 0, 0.2), kCentre,
                    static_cast<unsigned>(probe_sim::SurfaceKind::kObject));
  ASSERT_TRUE(object_only.hit);
  EXPECT_EQ(object_only.kind, probe_sim::SurfaceKind::kObject);
  EXPECT_NEAR(object_only.point.z(), kSize, sagitta_ + 1e-6);
}

TEST_F(SphereObject, BadTouchesFailWithAReason) {
  SimulatedProber prober(scene_, probe_sim::makeProbeModel("sphere"));
  const double nan = std::nan("");
  struct Case {
    Touch touch;
    std::string reason_fragment;
  };
  Touch empty;
  Touch mismatched = poke(kCentre, Eigen::Vector3d::UnitZ());
  mismatched.normals.clear();
  std::vector<Case> cases = {
      {empty, "empty"},
      {poke(Eigen::Vector3d(nan, 0, 0), Eigen::Vector3d::UnitZ()), "not finite"},
      {poke(kCentre, Eigen::Vector3d(0, nan, 1)), "normal 0"},
      {poke(kCentre, Eigen::Vector3d::Zero()), "zero"},
      {mismatched, "normals"},
  };
  Touch slide = poke(kCentre + kRadius * Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitX());
  slide.kind = Touch::Kind::kSlide;
  slide.points.push_back(Eigen::Vector3d(0, 0, std::numeric_limits<double>::infinity()));
  slide.normals.push_back(Eigen::Vector3d::UnitX());
  cases.push_back({slide, "waypoint 1"});
  Touch bad_path = poke(kCentre + kRadius * Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitX());
  bad_path.approach_path = {Eigen::Vector3d(0.3, 0, 0.1), Eigen::Vector3d(nan, 0, 0)};
  cases.push_back({bad_path, "approach path is not finite"});
  for (const Case& c : cases) {
    const ProbeResult result = prober.probe(c.touch);
    EXPECT_FALSE(result.success);
    EXPECT_NE(result.reason.find(c.reason_fragment), std::string::npos) << result.reason;
    EXPECT_TRUE(result.contacts.empty());
  }
  // A sphere probe cannot start through the surface: here the stroke would start with the
  // sphere centre 5 mm inside the object. (A start entirely inside a closed mesh is not
  // detected: without a watertight mesh there is no reliable inside test.)
  const ProbeResult inside = prober.probe(poke(kCentre - 0.055 * Eigen::Vector3d::UnitX(),
                                               Eigen::Vector3d::UnitX()));
  EXPECT_FALSE(inside.success);
  EXPECT_NE(inside.reason.find("overlaps the object"), std::string::npos) << inside.reason;
  EXPECT_THROW(probe_sim::makeProbeModel("laser"), std::runtime_error);
}

TEST(HollowObjects, OpenTopsLetARayReachTheFloorOrTheTable) {
  const double size = 0.12;
  for (const std::string name : {"bowl", "mug", "funnel"}) {
    SCOPED_TRACE(name);
    const Scene scene(probe_sim::makeProceduralObject(name, size));
    // The cup's axis passes through the centre of the rim (the top ring of vertices).
    Eigen::Vector3d rim_centre = Eigen::Vector3d::Zero();
    int rim_count = 0;
    const double top = scene.objectMesh().boundingBox().max().z();
    for (const auto& v : scene.objectMesh().vertices) {
      if (v.z() > top - 1e-9) {
        rim_centre += v;
        ++rim_count;
      }
    }
    ASSERT_GT(rim_count, 0);
    rim_centre /= rim_count;
    const probe_sim::RayHit hit =
        scene.castRay(rim_centre + Eigen::Vector3d(0, 0, 0.05), rim_centre - Eigen::Vector3d(0, 0, 0.3));
    ASSERT_TRUE(hit.hit);
    if (name == std::string("funnel")) {
      EXPECT_EQ(hit.kind, probe_sim::SurfaceKind::kTable);  // straight through the spout
    } else {
      EXPECT_EQ(hit.kind, probe_sim::SurfaceKind::kObject);
      EXPECT_GT(hit.point.z(), 0.0);  // a floor above the table ...
      EXPECT_LT(hit.point.z(), 0.1 * size);  // ... near the bottom, not a lid
      EXPECT_TRUE(hit.normal.isApprox(Eigen::Vector3d::UnitZ(), 1e-6));
    }
  }
}

TEST(HollowObjects, MugHandleStandsOutOnThePlusXSide) {
  const double size = 0.12;
  const Scene scene(probe_sim::makeProceduralObject("mug", size));
  const Eigen::AlignedBox3d box = scene.objectMesh().boundingBox();
  // At half height the handle is the outermost part on +x: a ray coming from +x first hits it
  // at the bounding box's +x face ...
  const double mid = box.center().z();
  const probe_sim::RayHit handle =
      scene.castRay(Eigen::Vector3d(0.5, 0.0, mid), Eigen::Vector3d(-0.5, 0.0, mid));
  ASSERT_TRUE(handle.hit);
  EXPECT_NEAR(handle.point.x(), box.max().x(), 1e-3 * size);
  // ... while near the rim (above the handle) the same ray reaches the cup wall, further in.
  const double high = box.max().z() - 0.02 * size;
  const probe_sim::RayHit wall =
      scene.castRay(Eigen::Vector3d(0.5, 0.0, high), Eigen::Vector3d(-0.5, 0.0, high));
  ASSERT_TRUE(wall.hit);
  EXPECT_LT(wall.point.x(), box.max().x() - 0.15 * size);
  // The far side (-x) has no handle: the cup wall is the bounding box there.
  const probe_sim::RayHit back =
      scene.castRay(Eigen::Vector3d(-0.5, 0.0, mid), Eigen::Vector3d(0.5, 0.0, mid));
  ASSERT_TRUE(back.hit);
  EXPECT_NEAR(back.point.x(), box.min().x(), 1e-3 * size);
}

// The probe's body (a 2 cm tip and a shaft behind it) moved along a path of tip positions: each
// separate stretch in contact with the scene counts once.
TEST_F(SphereObject, PathContactsCountEachStretchThroughTheSceneOnce) {
  const gpatlas_motion::ProbeGeometry body;
  const Eigen::Vector3d down = -Eigen::Vector3d::UnitZ();
  const auto contacts = [&](const std::vector<Eigen::Vector3d>& path, const Eigen::Vector3d& direction) {
    return probe_sim::countPathContacts(*scene_, body, path, direction, 0.002);
  };
  const Eigen::Vector3d left(-0.2, 0.0, kRadius), right(0.2, 0.0, kRadius);
  EXPECT_EQ(contacts({left, right}, down), 1);
  EXPECT_EQ(contacts({left, right, left}, down), 2);
  // 2 mm above the sphere's top with the tip, the shaft pointing away: clear.
  const Eigen::Vector3d over(0.0, 0.0, 2 * kRadius + body.tip_radius_m + 0.002);
  EXPECT_EQ(contacts({over - Eigen::Vector3d(0.2, 0, 0), over + Eigen::Vector3d(0.2, 0, 0)}, down), 0);
  // The same path with the probe pointing up: its shaft hangs through the sphere and the table.
  EXPECT_EQ(contacts({over - Eigen::Vector3d(0.2, 0, 0), over + Eigen::Vector3d(0.2, 0, 0)}, -down), 1);
  // Grazing the table away from the sphere is one long contact.
  EXPECT_EQ(contacts({Eigen::Vector3d(-0.3, 0.3, 0.01), Eigen::Vector3d(0.3, 0.3, 0.01)}, down), 1);
  EXPECT_EQ(contacts({over}, down), 0);
  EXPECT_EQ(contacts({}, down), 0);
}

// Without a planned path the probe goes straight from its rest to the approach pose, through
// the object when it stands in the way; along a planned path round it, it hits nothing. The touch
// is made either way.
TEST_F(SphereObject, TheWayToATouchAndBackIsJudgedAgainstTheTrueScene) {
  probe_sim::SimulatedProber::Config config;
  config.rest_tip_position = Eigen::Vector3d(0.3, 0.0, kRadius);
  SimulatedProber prober(scene_, probe_sim::makeProbeModel("ray"), config);
  Touch touch = poke(kCentre - kRadius * Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitX());
  ProbeResult straight = prober.probe(touch);
  EXPECT_TRUE(straight.success) << straight.reason;
  EXPECT_EQ(straight.approach_collisions, 1);
  EXPECT_EQ(straight.retreat_collisions, 1);

  const Eigen::Vector3d approach_pose = touch.points[0] - 0.1 * Eigen::Vector3d::UnitX();
  touch.approach_path = {config.rest_tip_position, Eigen::Vector3d(0.3, 0.0, 0.3), Eigen::Vector3d(-0.15, 0.0, 0.3),
                         approach_pose};
  touch.retreat_path.assign(touch.approach_path.rbegin(), touch.approach_path.rend());
  const ProbeResult planned = prober.probe(touch);
  EXPECT_TRUE(planned.success) << planned.reason;
  EXPECT_EQ(planned.approach_collisions, 0);
  EXPECT_EQ(planned.retreat_collisions, 0);
  ASSERT_EQ(planned.contacts.size(), 1u);
  EXPECT_NEAR((planned.contacts[0].position - touch.points[0]).norm(), 0.0, 1e-3);

  config.motion_check_step_m = 0.0;
  EXPECT_THROW(SimulatedProber(scene_, probe_sim::makeProbeModel("ray"), config), std::runtime_error);
}

// ---------------------------------------------------------------- the tactile pad (patch)

namespace {

probe_sim::PatchProbe::Config patchConfig(double indentation = 0.001, double curvature = 0.0) {
  probe_sim::PatchProbe::Config config;
  config.indentation_m = indentation;
  config.pad_curvature_radius_m = curvature;
  return config;
}

// Largest lateral distance (across the pad's normal n) of the patch's points from `centre`.
double patchExtent(const probe_sim::ProbeStroke& stroke, const Eigen::Vector3d& n, const Eigen::Vector3d& centre) {
  double extent = 0.0;
  for (const gpatlas_core::Contact& c : stroke.patch) {
    const Eigen::Vector3d offset = c.position - centre;
    extent = std::max(extent, (offset - offset.dot(n) * n).norm());
  }
  return extent;
}

}  // namespace

TEST_F(SphereObject, APatchOnTheSphereLiesOnItWithItsNormalsOverTheDiscThePadOverlaps) {
  for (const double curvature : {0.0, 0.03}) {
    probe_sim::PatchProbe pad(patchConfig(0.001, curvature));
    // The overlap of pad and sphere pressed 1 mm together: the gap at lateral distance r is
    // r^2 / 2 (1 / R + 1 / R_pad), so the contact is a disc of radius sqrt(2 delta / (1/R + 1/R_pad)).
    const double inverse = 1.0 / kRadius + (curvature > 0.0 ? 1.0 / curvature : 0.0);
    const double disc = std::sqrt(2.0 * 0.001 / inverse);
    for (const Eigen::Vector3d& n : testDirections()) {
      if (n.z() < 0.3) continue;  // the pad is 2 cm wide: clear of the table
      SCOPED_TRACE(n.transpose());
      const probe_sim::ProbeStroke stroke = pad.stroke(*scene_, kCentre + (kRadius + 0.01) * n, n);
      ASSERT_EQ(stroke.touched, probe_sim::SurfaceKind::kObject) << stroke.failure;
      ASSERT_GT(stroke.patch.size(), 50u);
      std::size_t with_normal = 0;
      for (const gpatlas_core::Contact& c : stroke.patch) {
        const Eigen::Vector3d radial = (c.position - kCentre).normalized();
        EXPECT_LE(std::abs((c.position - kCentre).norm() - kRadius), sagitta_ + 1e-6);
        if (c.normal.norm() == 0.0) continue;
        ++with_normal;
        EXPECT_LT(angleBetween(c.normal, radial), 2.0 * kDegree);
      }
      EXPECT_GT(with_normal, stroke.patch.size() * 9 / 10);
      // The disc, to the output grid's spacing (1 mm: the outermost points lie within a block).
      // The disc is centred where the pad's axis meets the sphere.
      const Eigen::Vector3d axis_point = kCentre + kRadius * n;
      EXPECT_LT(patchExtent(stroke, n, axis_point), disc + 0.0003);
      EXPECT_GT(patchExtent(stroke, n, axis_point), disc - 0.0015);
      EXPECT_LT(angleBetween(stroke.contact.position - kCentre, n), 2.0 * kDegree);
      // The pad at its deepest press: its centre 1 mm into the sphere along the axis, facing out.
      ASSERT_EQ(stroke.pad.size(), 1u);
      EXPECT_LT((stroke.pad[0].centre - (kCentre + (kRadius - 0.001) * n)).norm(), sagitta_ + 1e-6);
      EXPECT_LT((stroke.pad[0].orientation * Eigen::Vector3d::UnitZ() - n).norm(), 1e-12);
      EXPECT_EQ(stroke.pad[0].size_m, 0.02);
      // Free space in front of the pad, not in the sphere.
      ASSERT_FALSE(stroke.free_space.empty());
      for (const Eigen::Vector3d& f : stroke.free_space) EXPECT_GT((f - kCentre).norm(), kRadius);
    }
  }
}

TEST_F(SphereObject, APressAtTheEndOfTheSearchStillSeesItsWholeDiscAndFreeSpaceOnlyOutside) {
  const probe_sim::PatchProbe::Config config = patchConfig(0.001);
  probe_sim::PatchProbe pad(config);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  // The first contact 0.2 mm before the end of the 2 d search: the pressed pad reaches 0.8 mm
  // beyond it, and so must its depth image and its free space.
  const double d = config.start_offset_m;
  const Eigen::Vector3d top = kCentre + kRadius * up;
  const probe_sim::ProbeStroke stroke = pad.stroke(*scene_, top + (d - 0.0002) * up, up);
  ASSERT_EQ(stroke.touched, probe_sim::SurfaceKind::kObject) << stroke.failure;
  const double disc = std::sqrt(2.0 * 0.001 * kRadius);
  EXPECT_GT(patchExtent(stroke, up, top), disc - 0.0015);
  for (const gpatlas_core::Contact& c : stroke.patch)
    EXPECT_LE(std::abs((c.position - kCentre).norm() - kRadius), sagitta_ + 1e-6);
  ASSERT_FALSE(stroke.free_space.empty());
  for (const Eigen::Vector3d& f : stroke.free_space) EXPECT_GT((f - kCentre).norm(), kRadius);
}

TEST_F(SphereObject, APadThatWouldStartInTheObjectIsRefused) {
  probe_sim::PatchProbe pad(patchConfig(0.001));
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  // The pad's start, start_offset_m above the waypoint, is on the sphere's top.
  const probe_sim::ProbeStroke stroke =
      pad.stroke(*scene_, kCentre + (kRadius - pad.startOffset()) * up, up);
  EXPECT_EQ(stroke.touched, probe_sim::SurfaceKind::kNone);
  EXPECT_TRUE(stroke.patch.empty());
  EXPECT_NE(stroke.failure.find("object"), std::string::npos) << stroke.failure;
}

TEST(PatchProbe, ABoxEdgeGivesBothFacesWithTheirNormals) {
  constexpr double kBox = 0.1;
  Scene scene(probe_sim::makeProceduralObject("box", kBox));
  probe_sim::PatchProbe pad(patchConfig(0.002));
  const Eigen::Vector3d n = Eigen::Vector3d(1.0, 0.0, 1.0).normalized();
  const Eigen::Vector3d edge(kBox / 2, 0.003, kBox);
  const probe_sim::ProbeStroke stroke = pad.stroke(scene, edge, n);
  ASSERT_EQ(stroke.touched, probe_sim::SurfaceKind::kObject);
  std::size_t top = 0, side = 0;
  for (const gpatlas_core::Contact& c : stroke.patch) {
    const double distance = *probe_sim::proceduralSignedDistance("box", kBox, c.position);
    EXPECT_LT(std::abs(distance), 1e-6);
    // Away from the crease the normal is its face's (at the crease the depth's gradient blends them).
    const double to_top = kBox - c.position.z(), to_side = kBox / 2 - c.position.x();
    if (c.normal.norm() == 0.0 || std::max(to_top, to_side) < 0.0006) continue;
    const Eigen::Vector3d face = to_top < to_side ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d::UnitX();
    (to_top < to_side ? top : side) += 1;
    EXPECT_LT(angleBetween(c.normal, face), 1.0 * kDegree) << c.position.transpose();
  }
  // Pressed 2 mm along the diagonal, each face is in contact up to 2 * sqrt(2) mm from the edge.
  EXPECT_GT(top, 10u);
  EXPECT_GT(side, 10u);
}

TEST(PatchProbe, AGimbalSettlesThePadFlatOnAFaceItApproachesTilted) {
  constexpr double kBox = 0.1;
  Scene scene(probe_sim::makeProceduralObject("box", kBox));
  const Eigen::Vector3d top(0.0, 0.0, kBox);
  const auto tiltedFromUp = [](double degrees) {
    return Eigen::Vector3d(std::sin(degrees * kDegree), 0.0, std::cos(degrees * kDegree));
  };
  probe_sim::PatchProbe::Config config = patchConfig(0.001);
  // Rigid, 20 degrees off the face: a strip along the pad's lower edge, 1 mm / tan(20 deg) wide.
  const probe_sim::ProbeStroke rigid = probe_sim::PatchProbe(config).stroke(scene, top, tiltedFromUp(20.0));
  ASSERT_EQ(rigid.touched, probe_sim::SurfaceKind::kObject);
  EXPECT_LT(rigid.patch.size(), 20u * 4u);
  // With a 30-degree gimbal the pad lies flat on the face: the whole 20 x 20 mm pad in contact.
  config.gimbal_range_deg = 30.0;
  const probe_sim::ProbeStroke settled = probe_sim::PatchProbe(config).stroke(scene, top, tiltedFromUp(20.0));
  ASSERT_EQ(settled.touched, probe_sim::SurfaceKind::kObject) << settled.note;
  EXPECT_GE(settled.patch.size(), 20u * 20u);
  std::size_t with_normal = 0;
  for (const gpatlas_core::Contact& c : settled.patch) {
    EXPECT_NEAR(c.position.z(), kBox, 1e-6);
    if (c.normal.norm() > 0.0) {
      ++with_normal;
      EXPECT_LT(angleBetween(c.normal, Eigen::Vector3d::UnitZ()), 0.1 * kDegree);
    }
  }
  EXPECT_GT(with_normal, 0u);  // the normals were checked
  ASSERT_EQ(settled.pad.size(), 1u);
  EXPECT_LT(angleBetween(settled.pad[0].orientation * Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()),
            0.1 * kDegree);
  // The pad turned about its centre on the mount's axis, a few millimetres from where that axis
  // meets the face: it did not slide sideways to its first-touching corner (about 10 mm away).
  const Eigen::Vector3d axis = tiltedFromUp(20.0);
  const Eigen::Vector3d off_axis = (settled.pad[0].centre - top) - (settled.pad[0].centre - top).dot(axis) * axis;
  EXPECT_LT(off_axis.norm(), 0.002);
  for (const Eigen::Vector3d& f : settled.free_space) EXPECT_GT(f.z(), kBox);
  // 40 degrees off: the gimbal turns its 30, and the pad presses 10 degrees off the face.
  const probe_sim::ProbeStroke limited = probe_sim::PatchProbe(config).stroke(scene, top, tiltedFromUp(40.0));
  ASSERT_EQ(limited.touched, probe_sim::SurfaceKind::kObject);
  ASSERT_EQ(limited.pad.size(), 1u);
  EXPECT_NEAR(angleBetween(limited.pad[0].orientation * Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitZ()),
              10.0 * kDegree, 0.1 * kDegree);
  EXPECT_LT(limited.patch.size(), settled.patch.size() / 2);
  // Near the face's edge, tilted over it: whatever the pad settles on lies on the box.
  const probe_sim::ProbeStroke edge =
      probe_sim::PatchProbe(config).stroke(scene, Eigen::Vector3d(kBox / 2 - 0.004, 0.0, kBox), tiltedFromUp(20.0));
  ASSERT_EQ(edge.touched, probe_sim::SurfaceKind::kObject) << edge.note;
  for (const gpatlas_core::Contact& c : edge.patch)
    EXPECT_LT(std::abs(*probe_sim::proceduralSignedDistance("box", kBox, c.position)), 1e-6);
  for (const Eigen::Vector3d& f : edge.free_space)
    EXPECT_GT(*probe_sim::proceduralSignedDistance("box", kBox, f), 0.0);
  config.gimbal_range_deg = 91.0;
  EXPECT_THROW(probe_sim::PatchProbe{config}, std::runtime_error);
}

TEST(PatchProbe, GrazingAndTooDeepPressesGiveAClearResult) {
  // A 4 cm square plate, 2 mm thick, on the table.
  probe_sim::TriangleMesh plate = probe_sim::makeProceduralObject("box", 0.04);
  for (Eigen::Vector3d& v : plate.vertices) v.z() *= 0.05;
  Scene scene(plate);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  // Pressed 3 mm over the plate's edge: the pad passes the plate's thickness and meets the table.
  probe_sim::PatchProbe deep(patchConfig(0.003));
  const probe_sim::ProbeStroke through = deep.stroke(scene, Eigen::Vector3d(0.02, 0.0, 0.002), up);
  ASSERT_EQ(through.touched, probe_sim::SurfaceKind::kObject);
  EXPECT_NE(through.note.find("table"), std::string::npos) << through.note;
  for (const gpatlas_core::Contact& c : through.patch) {
    EXPECT_NEAR(c.position.z(), 0.002, 1e-6);
    EXPECT_LE(c.position.x(), 0.02 + 1e-9);
  }
  // No indentation on the sphere's top: only the pixels at the first contact touch.
  const probe_sim::TriangleMesh sphere = probe_sim::makeProceduralObject("sphere", kSize);
  const probe_sim::ProbeStroke graze =
      probe_sim::PatchProbe(patchConfig(0.0)).stroke(Scene(sphere), kCentre + kRadius * up, up);
  ASSERT_EQ(graze.touched, probe_sim::SurfaceKind::kObject);
  EXPECT_GE(graze.patch.size(), 1u);
  EXPECT_LE(graze.patch.size(), 4u);
  EXPECT_LT(patchExtent(graze, up, graze.contact.position), 0.001);
  // Missing everything: free space along the way, no contact.
  const probe_sim::ProbeStroke miss =
      probe_sim::PatchProbe().stroke(Scene(sphere), kCentre + Eigen::Vector3d(0.2, 0.0, 0.0), up);
  EXPECT_EQ(miss.touched, probe_sim::SurfaceKind::kTable);
  // Bad pads are refused.
  EXPECT_THROW(probe_sim::PatchProbe(patchConfig(-0.001)), std::runtime_error);
  EXPECT_THROW(probe_sim::PatchProbe(patchConfig(0.001, 0.01)), std::runtime_error);  // below the half diagonal
  probe_sim::PatchProbe::Config too_fine;
  too_fine.resolution_m = 1e-6;
  EXPECT_THROW(probe_sim::PatchProbe{too_fine}, std::runtime_error);
}

TEST_F(SphereObject, TheProberReportsThePatchAsTheTouchsContacts) {
  SimulatedProber prober(scene_, probe_sim::makeProbeModel("patch"));
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, 0.2, 1.0).normalized();
  const ProbeResult result = prober.probe(poke(kCentre + kRadius * n, n));
  ASSERT_TRUE(result.success) << result.reason;
  EXPECT_GT(result.contacts.size(), 100u);
  EXPECT_EQ(result.pads.size(), 1u);
  for (const gpatlas_core::Contact& c : result.contacts)
    EXPECT_LE(std::abs((c.position - kCentre).norm() - kRadius), sagitta_ + 1e-6);
}
