#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/servers.h"

#include <gpatlas_msgs/OctomapBinary.h>
#include <visualization_msgs/MarkerArray.h>

#include <octomap/OcTree.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace gpatlas_ros {

struct CollisionMapServer::Map {
  explicit Map(double resolution) : tree(resolution) {}
  octomap::OcTree tree;
};

CollisionMapServer::CollisionMapServer(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh), pnh_(pnh) {
  ParamReader reader(pnh_);
  gpatlas_core::PipelineFrames frames;
  readFrames(reader, &frames);
  world_frame_ = frames.world_frame;
  readSurfaceModel(reader, &model_config_);
  gpatlas_core::StrategyChoice plugins;  // a model of your own, loaded before it is built
  readStrategyChoice(reader, &plugins);
  loadPluginLibraries(plugins.libraries, reader, "collision_map");
  readCollisionMap(reader, &map_config_);
  reader.report("collision_map");
  octomap_pub_ = pnh_.advertise<gpatlas_msgs::OctomapBinary>("octomap_binary", 1, true);
  voxels_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("occupied_voxels", 1, true);
  save_srv_ = pnh_.advertiseService("save_map", &CollisionMapServer::onSaveMap, this);
  training_sub_ = nh_.subscribe("training_set", 1, &CollisionMapServer::onTrainingSet, this);
}

void CollisionMapServer::onTrainingSet(const gpatlas_msgs::TrainingSet::ConstPtr& msg) {
  // roscpp does not catch exceptions thrown by subscription callbacks: one would end the
  // nodelet manager.
  try {
    if (msg->points.empty()) {  // the GP node was reset
      std::lock_guard<std::mutex> lock(mutex_);
      map_.reset();
      return;
    }
    std::unique_ptr<gpatlas_core::SurfaceModel> model;
    std::string error;
    if (!modelFromMsg(*msg, model_config_, &model, &error)) {
      ROS_ERROR_STREAM("collision_map: " << error);
      return;
    }
    const gpatlas_core::OccupancyGrid grid = gpatlas_core::OccupancyGridBuilder(map_config_.grid).build(*model);
    if (!grid.ok) {
      ROS_ERROR_STREAM("collision_map: " << grid.message);
      return;
    }
    auto map = std::make_shared<Map>(grid.resolution);
    map->tree.setOccupancyThres(map_config_.occupied_probability);
    std::size_t occupied = 0;
    for (int k = 0; k < grid.size.z(); ++k)
      for (int j = 0; j < grid.size.y(); ++j)
        for (int i = 0; i < grid.size.x(); ++i) {
          const double p = std::clamp(static_cast<double>(grid.probabilities[grid.index(i, j, k)]), 1e-3, 1.0 - 1e-3);
          const Eigen::Vector3d x = grid.position(i, j, k);
          map->tree.setNodeValue(octomap::point3d(static_cast<float>(x.x()), static_cast<float>(x.y()), static_cast<float>(x.z())),
                                 static_cast<float>(std::log(p / (1.0 - p))));
          occupied += p > map_config_.occupied_probability ? 1 : 0;
        }
    map->tree.updateInnerOccupancy();
    map->tree.prune();

    gpatlas_msgs::OctomapBinary out;
    out.header.frame_id = world_frame_;
    out.header.stamp = msg->header.stamp;
    out.id = map->tree.getTreeType();
    out.resolution = map->tree.getResolution();
    out.binary = true;
    std::stringstream stream;
    map->tree.writeBinaryData(stream);
    const std::string bytes = stream.str();
    out.data.assign(bytes.begin(), bytes.end());
    octomap_pub_.publish(out);

    visualization_msgs::MarkerArray markers;
    visualization_msgs::Marker cubes;
    cubes.header = out.header;
    cubes.ns = "occupied_voxels";
    cubes.type = visualization_msgs::Marker::CUBE_LIST;
    cubes.action = visualization_msgs::Marker::ADD;
    cubes.pose.orientation.w = 1.0;
    cubes.scale.x = cubes.scale.y = cubes.scale.z = map->tree.getResolution();
    for (auto it = map->tree.begin_leafs(); it != map->tree.end_leafs(); ++it) {
      if (!map->tree.isNodeOccupied(*it)) continue;
      geometry_msgs::Point p;
      p.x = it.getX();
      p.y = it.getY();
      p.z = it.getZ();
      cubes.points.push_back(p);
      std_msgs::ColorRGBA c;
      const double probability = it->getOccupancy();
      c.r = static_cast<float>(probability);
      c.g = 0.3f;
      c.b = static_cast<float>(1.0 - probability);
      c.a = 0.5f;
      cubes.colors.push_back(c);
    }
    markers.markers.push_back(cubes);
    voxels_pub_.publish(markers);

    std::lock_guard<std::mutex> lock(mutex_);
    map_ = map;
    ROS_INFO_STREAM("collision_map: " << occupied << " of " << grid.probabilities.size() << " cells occupied (P > "
                                      << map_config_.occupied_probability << ") at " << grid.resolution << " m");
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("collision_map: message ignored: " << e.what());
  }
}

bool CollisionMapServer::onSaveMap(gpatlas_msgs::SaveMap::Request& req, gpatlas_msgs::SaveMap::Response& res) {
  std::shared_ptr<Map> map;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    map = map_;
  }
  if (!map) {
    res.success = false;
    res.message = "no collision map yet: the GP has not published a training set";
    return true;
  }
  if (req.path.empty()) {
    res.success = false;
    res.message = "path is empty";
    return true;
  }
  // The answer names the absolute path: a relative one is resolved against the node's working
  // directory, which roslaunch sets to ~/.ros.
  std::error_code ignored;
  const std::filesystem::path absolute = std::filesystem::absolute(req.path, ignored);
  const std::string shown = absolute.empty() ? req.path : absolute.string();
  errno = 0;
  std::ofstream file(shown, std::ios::binary | std::ios::trunc);
  if (!file) {
    res.success = false;
    res.message = "cannot write " + shown + ": " + (errno != 0 ? std::strerror(errno) : "cannot open the file");
    return true;
  }
  res.success = map->tree.writeBinaryConst(file) && static_cast<bool>(file.flush());
  res.message = res.success ? "wrote " + shown : "cannot write " + shown + ": the write failed (disk full?)";
  return true;
}

}  // namespace gpatlas_ros
