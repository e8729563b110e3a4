#include "probe_sim/object_mesh.h"
#include "probe_sim/simulation_settings.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <string>

namespace fs = std::filesystem;
using probe_sim::TriangleMesh;

namespace {

// Fresh directory per test, removed afterwards.
class TempDir {
 public:
  TempDir() {
    std::random_device device;
    path_ = fs::temp_directory_path() / ("probe_sim_test_" + std::to_string(device()));
    fs::create_directories(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

 private:
  fs::path path_;
};

void writeBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
}

// Expects loadMesh to throw a std::runtime_error whose message names the file and contains
// every given fragment.
void expectLoadError(const std::string& path, const std::vector<std::string>& fragments,
                     double scale = 1.0) {
  try {
    probe_sim::loadMesh(path, scale);
    FAIL() << "loading '" << path << "' should fail";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(path), std::string::npos) << message;
    for (const auto& fragment : fragments) {
      EXPECT_NE(message.find(fragment), std::string::npos)
          << "'" << message << "' lacks '" << fragment << "'";
    }
  }
}

TriangleMesh unitTetrahedron() {
  TriangleMesh mesh;
  mesh.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  return mesh;
}

fs::path sharedObjectsDir() {
  return fs::path(PROBE_SIM_SOURCE_DIR) / ".." / ".." / ".." / ".." / "shared" / "objects";
}

}  // namespace

// ---------------------------------------------------------------- loaders and errors

TEST(MeshLoading, StlRoundTripKeepsGeometryAndAppliesScaleAndPose) {
  TempDir dir;
  const TriangleMesh original = unitTetrahedron();
  probe_sim::saveStl(original, dir.file("tetra.stl"));
  // 84-byte header + 50 bytes per triangle is the binary STL definition.
  EXPECT_EQ(fs::file_size(dir.file("tetra.stl")), 84u + 50u * 4u);

  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << 1.0, 2.0, 3.0;
  const TriangleMesh loaded = probe_sim::loadMesh(dir.file("tetra.stl"), 0.5, pose);
  ASSERT_EQ(loaded.triangles.size(), 4u);
  const Eigen::AlignedBox3d box = loaded.boundingBox();
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d(1.0, 2.0, 3.0), 1e-6));
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d(1.5, 2.5, 3.5), 1e-6));
}

TEST(MeshLoading, AsciiStlPlyAndObjGiveTheSameSquare) {
  TempDir dir;
  writeBytes(dir.file("square.stl"),
             "solid square\n"
             " facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 2 0 0\n"
             "   vertex 2 1 0\n  endloop\n endfacet\n"
             " facet normal 0 0 1\n  outer loop\n   vertex 0 0 0\n   vertex 2 1 0\n"
             "   vertex 0 1 0\n  endloop\n endfacet\nendsolid square\n");
  writeBytes(dir.file("square.ply"),
             "ply\nformat ascii 1.0\ncomment a quad\nelement vertex 4\nproperty float x\n"
             "property float y\nproperty float z\nproperty uchar red\nelement face 1\n"
             "property list uchar int vertex_indices\nend_header\n"
             "0 0 0 255\n2 0 0 255\n2 1 0 255\n0 1 0 255\n4 0 1 2 3\n");
  writeBytes(dir.file("square.obj"),
             "# a quad\nv 0 0 0\nv 2 0 0\nv 2 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 -1//1\n");

  // Binary little-endian PLY with double coordinates and int32 indices.
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty double x\n"
      "property double y\nproperty double z\nelement face 1\n"
      "property list uchar int vertex_indices\nend_header\n";
  const double xyz[4][3] = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}};
  binary.append(reinterpret_cast<const char*>(xyz), sizeof(xyz));
  binary.push_back(static_cast<char>(4));
  const std::int32_t quad[4] = {0, 1, 2, 3};
  binary.append(reinterpret_cast<const char*>(quad), sizeof(quad));
  writeBytes(dir.file("square_binary.ply"), binary);

  for (const char* name : {"square.stl", "square.ply", "square.obj", "square_binary.ply"}) {
    SCOPED_TRACE(name);
    const TriangleMesh mesh = probe_sim::loadMesh(dir.file(name));
    ASSERT_EQ(mesh.triangles.size(), 2u);
    double area = 0.0;
    for (const auto& t : mesh.triangles) {
      area += 0.5 * (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                        .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]])
                        .norm();
    }
    EXPECT_NEAR(area, 2.0, 1e-9);
    EXPECT_TRUE(mesh.boundingBox().max().isApprox(Eigen::Vector3d(2, 1, 0)));
  }
}

TEST(MeshLoading, MissingEmptyTruncatedAndCorruptFilesGiveClearErrors) {
  TempDir dir;
  expectLoadError(dir.file("does_not_exist.stl"), {"cannot open"});

  writeBytes(dir.file("empty.stl"), "");
  expectLoadError(dir.file("empty.stl"), {"empty"});

  probe_sim::saveStl(unitTetrahedron(), dir.file("whole.stl"));
  std::ifstream in(dir.file("whole.stl"), std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  writeBytes(dir.file("truncated.stl"), bytes.substr(0, bytes.size() - 30));
  expectLoadError(dir.file("truncated.stl"), {"truncated"});

  std::mt19937 rng(42);
  std::string noise(1000, '\0');
  for (char& c : noise) c = static_cast<char>(rng() & 0xff);
  // Make sure the random header cannot announce exactly the right size by accident.
  const std::uint32_t impossible = 0xffffffu;
  std::memcpy(&noise[80], &impossible, sizeof(impossible));
  writeBytes(dir.file("noise.stl"), noise);
  expectLoadError(dir.file("noise.stl"), {"corrupt"});

  writeBytes(dir.file("short.stl"), "abc");
  expectLoadError(dir.file("short.stl"), {"header"});

  writeBytes(dir.file("noise.ply"), noise);
  expectLoadError(dir.file("noise.ply"), {"PLY"});

  writeBytes(dir.file("truncated.ply"),
             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
             "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
             "end_header\n0 0 0\n1 0 0\n");
  expectLoadError(dir.file("truncated.ply"), {"ends early"});

  writeBytes(dir.file("huge_count.ply"),
             "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\n"
             "end_header\n\x01\x02");
  expectLoadError(dir.file("huge_count.ply"), {"more than the file can hold"});

  writeBytes(dir.file("bad_index.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n");
  expectLoadError(dir.file("bad_index.obj"), {"vertex that does not exist"});

  writeBytes(dir.file("no_faces.obj"), "v 0 0 0\nv 1 0 0\n");
  expectLoadError(dir.file("no_faces.obj"), {"no triangles"});

  writeBytes(dir.file("mesh.xyz"), "0 0 0\n");
  expectLoadError(dir.file("mesh.xyz"), {"unknown mesh extension"});
}

TEST(MeshLoading, PlaceOnTableCentresAndGrounds) {
  TriangleMesh mesh = unitTetrahedron();
  mesh.scale(0.2);
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() << 5.0, -3.0, 7.0;
  mesh.transform(pose);
  probe_sim::placeOnTable(mesh, Eigen::Vector2d(0.1, 0.2));
  const Eigen::AlignedBox3d box = mesh.boundingBox();
  EXPECT_TRUE(box.min().isApprox(Eigen::Vector3d(0.0, 0.1, 0.0), 1e-12)) << box.min().transpose();
  EXPECT_TRUE(box.max().isApprox(Eigen::Vector3d(0.2, 0.3, 0.2), 1e-12)) << box.max().transpose();
}

// A 100 mm object saved in millimetres: read as metres it is larger than the table, and the
// error names the scale that fixes it.
TEST(MeshLoading, AnObjectLargerThanTheTableAsksForItsScale) {
  TempDir dir;
  TriangleMesh millimetres = unitTetrahedron();
  millimetres.scale(100.0);
  probe_sim::saveStl(millimetres, dir.file("tetra_mm.stl"));
  probe_sim::SimulationSettings settings;
  settings.object = dir.file("tetra_mm.stl");
  try {
    probe_sim::loadSimulatedObject(settings);
    ADD_FAILURE() << "a 100 m object was placed on the table";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("100 m across"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("object_scale 0.001"), std::string::npos) << e.what();
  }
  settings.object_scale = 0.001;
  const TriangleMesh placed = probe_sim::loadSimulatedObject(settings);
  EXPECT_NEAR(placed.boundingBox().sizes().maxCoeff(), 0.1, 1e-9);
}

TEST(MeshLoading, RejectsBadScale) {
  TempDir dir;
  probe_sim::saveStl(unitTetrahedron(), dir.file("tetra.stl"));
  for (double scale : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    SCOPED_TRACE(scale);
    expectLoadError(dir.file("tetra.stl"), {"scale"}, scale);
  }
}

// Extents from the README of the shared folder (which measured them independently), with 2 mm
// slack for rounding in that table.
TEST(MeshLoading, SharedScannedObjectsLoadWithPlausibleBounds) {
  const fs::path folder = sharedObjectsDir();
  if (!fs::is_directory(folder)) {
    GTEST_SKIP() << "shared objects folder not found at " << folder
                 << " (it is not part of the repository)";
  }
  struct Expected {
    const char* file;
    double scale;
    Eigen::Vector3d extent;
  };
  const Expected objects[] = {
      {"bowlA.stl", 1.0, {0.144, 0.144, 0.052}},    {"containerA.stl", 1.0, {0.193, 0.155, 0.132}},
      {"jug.stl", 1.0, {0.179, 0.130, 0.189}},      {"kettle.stl", 1.0, {0.244, 0.192, 0.228}},
      {"mugD.stl", 1.0, {0.136, 0.105, 0.101}},     {"funnel_big_mm.stl", 0.001, {0.1338, 0.1102, 0.1452}},
  };
  for (const Expected& expected : objects) {
    SCOPED_TRACE(expected.file);
    const TriangleMesh mesh = probe_sim::loadMesh((folder / expected.file).string(), expected.scale);
    EXPECT_GT(mesh.triangles.size(), 10000u);
    const Eigen::Vector3d extent = mesh.boundingBox().sizes();
    for (int axis = 0; axis < 3; ++axis) EXPECT_NEAR(extent[axis], expected.extent[axis], 2e-3);
  }
}

TEST(MeshLoading, SavingNamesTheFileItCannotWrite) {
  TempDir dir;
  const std::string path = dir.file("missing_folder/tetra.stl");
  try {
    probe_sim::saveStl(unitTetrahedron(), path);
    FAIL() << "writing into a missing folder should fail";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind("mesh file '" + path + "': cannot write the STL (", 0), 0u) << message;
  }
}
