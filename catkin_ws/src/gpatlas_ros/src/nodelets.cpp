// Nodelet shims: each builds its server from the nodelet's handles and keeps it alive.

#include "gpatlas_ros/atlas_planner_server.h"
#include "gpatlas_ros/collision_map_server.h"
#include "gpatlas_ros/gp_model_server.h"
#include "gpatlas_ros/segmentation_server.h"

#include <nodelet/nodelet.h>
#include <pluginlib/class_list_macros.hpp>
#include <ros/ros.h>

#include <memory>

namespace gpatlas_ros {

template <typename Server>
class ServerNodelet : public nodelet::Nodelet {
 private:
  void onInit() override {
    try {
      server_ = std::make_unique<Server>(getNodeHandle(), getPrivateNodeHandle());
    } catch (const std::exception& e) {
      // A failed nodelet must not take the manager down: report and stay inert.
      NODELET_ERROR_STREAM("cannot start: " << e.what());
    }
  }
  std::unique_ptr<Server> server_;
};

class SegmentationNodelet : public ServerNodelet<SegmentationServer> {};
class GpModelNodelet : public ServerNodelet<GpModelServer> {};
class AtlasPlannerNodelet : public ServerNodelet<AtlasPlannerServer> {};
class CollisionMapNodelet : public ServerNodelet<CollisionMapServer> {};

}  // namespace gpatlas_ros

PLUGINLIB_EXPORT_CLASS(gpatlas_ros::SegmentationNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(gpatlas_ros::GpModelNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(gpatlas_ros::AtlasPlannerNodelet, nodelet::Nodelet)
PLUGINLIB_EXPORT_CLASS(gpatlas_ros::CollisionMapNodelet, nodelet::Nodelet)
