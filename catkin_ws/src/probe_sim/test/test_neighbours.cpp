// Neighbours in the simulated scene (simulation/neighbours): their text form, their placement
// around the explored object, and that the camera, the probe and the judge of the way meet them.

#include "probe_sim/depth_camera.h"
#include "probe_sim/probe.h"
#include "probe_sim/procedural_objects.h"
#include "probe_sim/simulation_settings.h"

#include <gpatlas_core/common/parameters.h>

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

namespace {

using probe_sim::NeighbourConfig;
using probe_sim::SimulationSettings;
using probe_sim::SurfaceKind;

constexpr double kPi = 3.14159265358979323846;

SimulationSettings settingsWith(const std::vector<std::string>& neighbours) {
  SimulationSettings s;
  s.object = "procedural:box";
  s.procedural_size_m = 0.1;
  s.object_position_xy_m = {0.7, 0.0};
  for (const std::string& text : neighbours) {
    std::string error;
    const auto n = probe_sim::parseNeighbour(text, &error);
    if (!n) throw std::runtime_error(error);
    s.neighbours.push_back(*n);
  }
  return s;
}

}  // namespace

TEST(Neighbours, ParseTheirTextFormAndRefuseMalformedOnes) {
  std::string error;
  const auto plain = probe_sim::parseNeighbour("procedural:box@0,0.2", &error);
  ASSERT_TRUE(plain) << error;
  EXPECT_EQ(plain->object, "procedural:box");
  EXPECT_EQ(plain->offset_xy_m, Eigen::Vector2d(0.0, 0.2));
  EXPECT_EQ(plain->yaw_rad, 0.0);
  EXPECT_EQ(plain->scale, 1.0);
  // A path may hold '@': the last one separates.
  const auto full = probe_sim::parseNeighbour("dir@x/jug.stl@-0.18,0.05,1.5,0.001", &error);
  ASSERT_TRUE(full) << error;
  EXPECT_EQ(full->object, "dir@x/jug.stl");
  EXPECT_EQ(full->offset_xy_m, Eigen::Vector2d(-0.18, 0.05));
  EXPECT_EQ(full->yaw_rad, 1.5);
  EXPECT_EQ(full->scale, 0.001);
  // Its formatted text reads back to the same neighbour.
  const auto again = probe_sim::parseNeighbour(probe_sim::formatNeighbour(*full), &error);
  ASSERT_TRUE(again) << error;
  EXPECT_EQ(again->object, full->object);
  EXPECT_EQ(again->offset_xy_m, full->offset_xy_m);
  EXPECT_EQ(again->scale, full->scale);
  for (const char* bad : {"procedural:box", "@0,0", "procedural:box@0", "procedural:box@0,0,0,1,2",
                          "procedural:box@0,0,0,0", "procedural:box@0,x", "procedural:box@0,,0", "procedural:box@0,nan"}) {
    error.clear();
    EXPECT_FALSE(probe_sim::parseNeighbour(bad, &error)) << bad;
    EXPECT_NE(error.find("OBJECT@DX,DY"), std::string::npos) << bad << ": " << error;
  }
}

TEST(Neighbours, AreReadFromTheSimulationSectionWithTheirErrorsNamed) {
  std::string error;
  const auto params = gpatlas_core::YamlParameters::fromString(
      "simulation:\n  neighbours: [\"procedural:box@0,0.2\", \"procedural:sphere@0.15,0,0,0.5\"]\n", &error);
  ASSERT_TRUE(params) << error;
  gpatlas_core::ParamReader reader(*params);
  SimulationSettings s;
  probe_sim::readSimulation(reader, &s);
  ASSERT_TRUE(reader.ok()) << reader.errors();
  ASSERT_EQ(s.neighbours.size(), 2u);
  EXPECT_EQ(s.neighbours[1].object, "procedural:sphere");
  EXPECT_EQ(s.neighbours[1].scale, 0.5);

  const auto bad = gpatlas_core::YamlParameters::fromString("simulation:\n  neighbours: [\"procedural:box\"]\n", &error);
  ASSERT_TRUE(bad) << error;
  gpatlas_core::ParamReader bad_reader(*bad);
  probe_sim::readSimulation(bad_reader, &s);
  EXPECT_FALSE(bad_reader.ok());
  EXPECT_NE(bad_reader.errors().find("simulation/neighbours"), std::string::npos) << bad_reader.errors();
}

TEST(Neighbours, StandOnTheTableAtTheirOffsetFromTheObjectTurnedByTheirYaw) {
  const SimulationSettings s = settingsWith({"procedural:box@0,0.2", "procedural:box@-0.2,0,0.7853981633974483,0.5"});
  const probe_sim::TriangleMesh object = probe_sim::loadSimulatedObject(s);
  const std::vector<probe_sim::TriangleMesh> neighbours = probe_sim::loadNeighbours(s, object);
  ASSERT_EQ(neighbours.size(), 2u);
  const Eigen::AlignedBox3d first = neighbours[0].boundingBox(), second = neighbours[1].boundingBox();
  EXPECT_TRUE(first.center().head<2>().isApprox(Eigen::Vector2d(0.7, 0.2), 1e-9)) << first.center().transpose();
  EXPECT_NEAR(first.min().z(), 0.0, 1e-12);
  EXPECT_NEAR(first.sizes().x(), 0.1, 1e-9);  // procedural_size_m
  // Half the size, turned by 45 degrees: its footprint is the square's diagonal.
  EXPECT_TRUE(second.center().head<2>().isApprox(Eigen::Vector2d(0.5, 0.0), 1e-9)) << second.center().transpose();
  EXPECT_NEAR(second.sizes().x(), 0.05 * std::sqrt(2.0), 1e-6);
  EXPECT_NEAR(second.sizes().z(), 0.05, 1e-9);
}

TEST(Neighbours, ThatOverlapTheObjectOrEachOtherOrLeaveTheTableAreRefused) {
  const auto refused = [](const std::vector<std::string>& neighbours, const std::string& why) {
    const SimulationSettings s = settingsWith(neighbours);
    const probe_sim::TriangleMesh object = probe_sim::loadSimulatedObject(s);
    try {
      probe_sim::loadNeighbours(s, object);
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
      return;
    }
    ADD_FAILURE() << "accepted: " << neighbours.back();
  };
  refused({"procedural:box@0.09,0"}, "overlaps the explored object's");
  refused({"procedural:box@0,0.2", "procedural:box@0.05,0.25"}, "overlaps neighbour 0's");
  refused({"procedural:box@0,0.58"}, "does not stand on the table");
  refused({"procedural:teapot@0,0.2"}, "simulation/neighbours[0]");
  // Just clear of the object (its 0.1 m box and the neighbour's meet 1 mm apart).
  const SimulationSettings s = settingsWith({"procedural:box@0.101,0"});
  EXPECT_EQ(probe_sim::loadNeighbours(s, probe_sim::loadSimulatedObject(s)).size(), 1u);
}

// A user's pick of a neighbour: nearestObject finds it from a point beside it, and the scene made
// with it explored has it as the object (ground truth, contacts) and the former object as an obstacle.
TEST(Neighbours, APickedNeighbourBecomesTheExploredObject) {
  const SimulationSettings s = settingsWith({"procedural:box@0,0.2"});
  const std::vector<probe_sim::TriangleMesh> objects = probe_sim::sceneObjects(s, probe_sim::loadSimulatedObject(s));
  ASSERT_EQ(objects.size(), 2u);
  double distance = -1.0;
  EXPECT_EQ(probe_sim::nearestObject(objects, Eigen::Vector3d(0.7, 0.2, 0.11), &distance), 1u);
  EXPECT_NEAR(distance, 0.01, 1e-9);  // 1 cm above the neighbour's 0.1 m top
  EXPECT_EQ(probe_sim::nearestObject(objects, Eigen::Vector3d(0.7, 0.0, 0.05), &distance), 0u);
  EXPECT_EQ(distance, 0.0);  // inside the object's box

  const auto scene = probe_sim::makeSimulatedScene(s, objects, 1);
  EXPECT_TRUE(scene->objectMesh().boundingBox().isApprox(objects[1].boundingBox()));
  probe_sim::RayProbe::Config ray;
  ray.start_offset_m = 0.05;
  probe_sim::RayProbe probe(ray);
  // Down onto each top: the neighbour is the object now, the former object an obstacle.
  EXPECT_EQ(probe.stroke(*scene, Eigen::Vector3d(0.7, 0.2, 0.1), Eigen::Vector3d::UnitZ()).touched, SurfaceKind::kObject);
  EXPECT_EQ(probe.stroke(*scene, Eigen::Vector3d(0.7, 0.0, 0.1), Eigen::Vector3d::UnitZ()).touched, SurfaceKind::kObstacle);
  EXPECT_THROW(probe_sim::makeSimulatedScene(s, objects, 2), std::invalid_argument);
}

TEST(Neighbours, TheCameraSeesThemAndTheProbeAndItsBodyHitThem) {
  const SimulationSettings s = settingsWith({"procedural:box@0,0.2"});
  const auto scene = probe_sim::makeSimulatedScene(s, probe_sim::loadSimulatedObject(s));
  // The camera above the table between the two: both boxes in its cloud, each labelled.
  probe_sim::DepthCamera::Config camera_config = probe_sim::cameraConfig(s, 1);
  probe_sim::DepthCamera camera(camera_config, probe_sim::lookAt(Eigen::Vector3d(0.2, 0.1, 0.6), Eigen::Vector3d(0.7, 0.1, 0.05)));
  const probe_sim::DepthCloud cloud = camera.capture(*scene);
  int on_object = 0, on_neighbour = 0;
  for (Eigen::Index i = 0; i < cloud.points_world.cols(); ++i) {
    const Eigen::Vector3d p = cloud.points_world.col(i);
    if (cloud.labels[static_cast<std::size_t>(i)] == SurfaceKind::kObstacle) {
      ++on_neighbour;
      // On the neighbour's box (0.65..0.75, 0.15..0.25, 0..0.1), within the camera's noise.
      EXPECT_TRUE((p.array() >= Eigen::Array3d(0.645, 0.145, -0.005)).all() &&
                  (p.array() <= Eigen::Array3d(0.755, 0.255, 0.105)).all())
          << p.transpose();
    } else if (cloud.labels[static_cast<std::size_t>(i)] == SurfaceKind::kObject) {
      ++on_object;
    }
  }
  EXPECT_GT(on_object, 100);
  EXPECT_GT(on_neighbour, 100);

  // A ray probe aimed at the object's +y face from beyond the neighbour stops on the neighbour.
  probe_sim::RayProbe::Config ray;
  ray.start_offset_m = 0.3;
  probe_sim::RayProbe probe(ray);
  const probe_sim::ProbeStroke stroke = probe.stroke(*scene, Eigen::Vector3d(0.7, 0.05, 0.05), Eigen::Vector3d::UnitY());
  EXPECT_EQ(stroke.touched, SurfaceKind::kObstacle);
  EXPECT_NEAR(stroke.contact.position.y(), 0.25, 1e-6);

  // The probe's body on a way from the rest across the neighbour meets it once; beside it, never.
  const gpatlas_motion::ProbeGeometry body;
  const Eigen::Vector3d down(0.0, 0.0, -1.0);
  unsigned met = 0;
  EXPECT_EQ(probe_sim::countPathContacts(*scene, body, {{0.7, 0.4, 0.05}, {0.7, 0.12, 0.05}}, down, 0.004, &met), 1);
  EXPECT_EQ(met, static_cast<unsigned>(SurfaceKind::kObstacle));
  met = 0;
  EXPECT_EQ(probe_sim::countPathContacts(*scene, body, {{0.7, 0.4, 0.2}, {0.7, 0.12, 0.2}}, down, 0.004, &met), 0);
  EXPECT_EQ(met, 0u);
  // On into the object, through the gap between them: two contacts, the object's too.
  EXPECT_EQ(probe_sim::countPathContacts(*scene, body, {{0.7, 0.4, 0.05}, {0.7, 0.0, 0.05}}, down, 0.004, &met), 2);
  EXPECT_EQ(met, static_cast<unsigned>(SurfaceKind::kObstacle) | static_cast<unsigned>(SurfaceKind::kObject));
}
