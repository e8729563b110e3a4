#include "bench_truth.h"

#include <gpatlas_geometry/shape_metrics.h>
#include <probe_sim/depth_camera.h>
#include <probe_sim/reachability.h>
#include <probe_sim/scene.h>

#include <cmath>
#include <filesystem>
#include <optional>
#include <stdexcept>

namespace gpatlas_bench {

namespace {

// Which of the shape metrics' truth samples the camera at `eye` sees: the first hit of its ray
// to the sample is the sample itself.
std::vector<bool> samplesSeenFrom(const probe_sim::Scene& scene, const probe_sim::TriangleMesh& mesh,
                                  const Eigen::Vector3d& eye) {
  const gpatlas_geometry::ShapeMetrics::Config metrics;
  const std::vector<gpatlas_core::Vector3> samples =
      gpatlas_geometry::sampleMeshSurface(mesh, metrics.samples_per_mesh, gpatlas_geometry::truthSampleSeed(metrics.seed));
  Eigen::Matrix3Xd from(3, static_cast<Eigen::Index>(samples.size())), to(3, from.cols());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    from.col(static_cast<Eigen::Index>(i)) = eye;
    // A millimetre beyond the sample, so that the sample's own triangle is hit.
    to.col(static_cast<Eigen::Index>(i)) = samples[i] + 1e-3 * (samples[i] - eye).normalized();
  }
  const std::vector<probe_sim::RayHit> hits = scene.castRays(from, to);
  std::vector<bool> seen(samples.size(), false);
  for (std::size_t i = 0; i < samples.size(); ++i)
    seen[i] = hits[i].hit && hits[i].distance >= (samples[i] - eye).norm() - 1e-3;
  return seen;
}

}  // namespace

GroundTruth loadObject(const std::string& spec, double scale, const Options& o) {
  GroundTruth gt;
  const std::string prefix = "procedural:";
  gt.name = spec.rfind(prefix, 0) == 0 ? spec.substr(prefix.size()) : std::filesystem::path(spec).stem().string();
  probe_sim::SimulationSettings simulation = o.simulation;
  simulation.object = spec;
  simulation.object_scale = scale;
  gt.mesh = probe_sim::loadSimulatedObject(simulation);
  // A camera the settings cannot place fails every run of the object, with the reason.
  std::string camera_error;
  if (const std::optional<Eigen::Isometry3d> camera = probe_sim::cameraPose(simulation, o.urdf_xml, &camera_error))
    gt.sample_seen = samplesSeenFrom(*probe_sim::makeSimulatedScene(simulation, gt.mesh), gt.mesh, camera->translation());
  return gt;
}

void measureReachability(GroundTruth& gt, const probe_sim::SimulationSettings& simulation, int directions) {
  const probe_sim::Scene scene(gt.mesh, probe_sim::sceneConfig(simulation));
  probe_sim::ReachabilityConfig config;
  config.directions = directions;
  const probe_sim::ReachableSurface split = probe_sim::splitReachableSurface(scene, config);
  gt.reachable_area_fraction = split.reachable_area_fraction;
  gt.sample_reachable.clear();
  // The very points ShapeMetrics::compare measures truth-to-predicted on, with their triangles.
  const gpatlas_geometry::ShapeMetrics::Config metrics;
  std::vector<std::size_t> owners;
  const std::vector<gpatlas_core::Vector3> samples = gpatlas_geometry::sampleMeshSurface(
      gt.mesh, metrics.samples_per_mesh, gpatlas_geometry::truthSampleSeed(metrics.seed), &owners);
  if (split.reachable.triangles.empty() || samples.empty()) {
    gt.floor_rmse_gt_to_pred = std::nan("");
    gt.reachability_measured = true;
    return;
  }
  const gpatlas_geometry::MeshDistanceIndex onto_reachable(split.reachable, metrics.index);
  if (!onto_reachable.ok()) throw std::runtime_error("reachable surface index: " + onto_reachable.message());
  double sum_squared = 0.0;
  for (std::size_t i = 0; i < samples.size(); ++i) {
    gt.sample_reachable.push_back(split.triangle_reachable[owners[i]]);
    if (!gt.sample_reachable.back()) sum_squared += std::pow(onto_reachable.distance(samples[i]), 2);
  }
  gt.floor_rmse_gt_to_pred = std::sqrt(sum_squared / static_cast<double>(samples.size()));
  gt.reachability_measured = true;
}

}  // namespace gpatlas_bench
