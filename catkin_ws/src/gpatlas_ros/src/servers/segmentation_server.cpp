#include "gpatlas_conversions/conversions.h"
#include "gpatlas_ros/markers.h"
#include "gpatlas_ros/segmentation_server.h"

#include <tf2_eigen/tf2_eigen.h>

#include <cmath>
#include <sstream>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

SegmentationServer::SegmentationServer(ros::NodeHandle nh, ros::NodeHandle pnh)
    : nh_(nh), pnh_(pnh), tf_listener_(tf_buffer_) {
  RosParamReader reader(pnh_);
  gpatlas_core::PipelineFrames frames;
  readFrames(reader, &frames);
  world_frame_ = frames.world_frame;
  sensor_frame_ = frames.sensor_frame;
  tf_timeout_s_ = frames.tf_timeout_s;
  readSegmenter(reader, &config_);
  const std::string invalid = gpatlas_geometry::validate(config_);
  reader.report("segmentation");
  if (!invalid.empty()) {
    ROS_ERROR_STREAM("segmentation: inconsistent parameters (" << invalid << "); all segmentation defaults used");
    config_ = gpatlas_geometry::ObjectSegmenter::Config();
  }
  object_pub_ = pnh_.advertise<sensor_msgs::PointCloud2>("object_points", 1, true);
  plane_pub_ = pnh_.advertise<gpatlas_msgs::SupportPlane>("support_plane", 1, true);
  objects_pub_ = pnh_.advertise<visualization_msgs::MarkerArray>("objects", 1, true);
  points_sub_ = std::make_unique<TfGatedCloudSubscriber>(
      nh_, "points", &tf_buffer_, world_frame_, "segmentation", kTfWaitWarningS,
      [this](const sensor_msgs::PointCloud2::ConstPtr& msg) { onPoints(msg); });
  // After every member the callbacks use: a selection may come as soon as they are advertised.
  select_srv_ = pnh_.advertiseService("select_object", &SegmentationServer::onSelectObject, this);
  reset_srv_ = pnh_.advertiseService("reset", &SegmentationServer::onReset, this);
  clicked_sub_ = nh_.subscribe("clicked_point", 1, &SegmentationServer::onClickedPoint, this);
  ROS_INFO_STREAM("segmentation: listening on " << points_sub_->topic() << ", publishing "
                                                << object_pub_.getTopic() << " in '" << world_frame_ << "'");
}

void SegmentationServer::onPoints(const sensor_msgs::PointCloud2::ConstPtr& msg) {
  // roscpp does not catch exceptions thrown by subscription callbacks: one would end the
  // nodelet manager.
  try {
    std::vector<Eigen::Vector3d> points;
    std::size_t invalid = 0;
    std::string error;
    if (!cloudToWorld(*msg, tf_buffer_, world_frame_, tf_timeout_s_, &points, &invalid, &error)) {
      ROS_WARN_STREAM("segmentation: cloud ignored: " << error);
      return;
    }
    checkSensorFrame(*msg);
    std::lock_guard<std::mutex> lock(mutex_);
    gpatlas_geometry::ObjectSegmenter::Config config = config_;
    if (selection_) config.object_hint_m = selection_;
    const gpatlas_geometry::SegmentationResult result = gpatlas_geometry::ObjectSegmenter(config).segment(points);
    if (!result.ok && result.stats.after_crop == 0 && !points.empty()) {
      reportOutsideCropBox(*msg, points);
      return;
    }
    if (!result.ok) {
      ROS_WARN_STREAM("segmentation: " << result.message << " (" << msg->width * msg->height << " points in, "
                                       << invalid << " NaN)");
      return;
    }
    ROS_INFO_STREAM("segmentation: " << result.message << " from " << result.stats.input << " points ("
                                     << result.stats.plane_inliers << " on the table)");
    Latest latest;
    latest.clusters = result.clusters;
    latest.object = result.object_cluster;
    latest.stamp = msg->header.stamp;
    if (result.plane_found) {
      gpatlas_core::SupportPlane plane;
      plane.normal = result.plane_normal;
      plane.offset = result.plane_offset;
      latest.plane = toMsg(plane, world_frame_);
      latest.plane->header.stamp = msg->header.stamp;
    }
    latest_ = std::move(latest);
    publishLatest();
  } catch (const std::exception& e) {
    ROS_ERROR_STREAM("segmentation: message ignored: " << e.what());
  }
}

void SegmentationServer::publishLatest() {
  // The plane first: the GP model uses it with the object cloud (and refits if it comes late).
  if (latest_->plane) plane_pub_.publish(*latest_->plane);
  sensor_msgs::PointCloud2 out = pointsToCloud(latest_->clusters[latest_->object], {}, 1.0, world_frame_);
  out.header.stamp = latest_->stamp;
  object_pub_.publish(out);
  visualization_msgs::MarkerArray boxes = objectBoxMarkers(latest_->clusters, latest_->object, world_frame_);
  for (auto& m : boxes.markers) m.header.stamp = latest_->stamp;
  objects_pub_.publish(boxes);
}

bool SegmentationServer::onSelectObject(gpatlas_msgs::SelectObject::Request& req,
                                        gpatlas_msgs::SelectObject::Response& res) {
  // Nothing may escape a service callback: it would end the nodelet manager.
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    select(req.point, &res);
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("selection failed: ") + e.what();
  }
  return true;
}

void SegmentationServer::onClickedPoint(const geometry_msgs::PointStamped::ConstPtr& msg) {
  gpatlas_msgs::SelectObject::Response res;
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    select(*msg, &res);
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("selection failed: ") + e.what();
  }
  if (res.success) ROS_INFO_STREAM("segmentation: clicked point: " << res.message);
  else ROS_WARN_STREAM("segmentation: clicked point: " << res.message);
}

namespace {

std::string describe(const Eigen::Vector3d& p) {
  std::ostringstream out;
  out.precision(3);
  out << "(" << p.x() << ", " << p.y() << ", " << p.z() << ")";
  return out.str();
}

}  // namespace

void SegmentationServer::select(const geometry_msgs::PointStamped& point, gpatlas_msgs::SelectObject::Response* res) {
  res->success = false;
  const Eigen::Vector3d given(point.point.x, point.point.y, point.point.z);
  if (!given.allFinite()) {
    res->message = "the point " + describe(given) + " is not finite; the current object is kept";
    return;
  }
  if (!latest_) {
    res->message = "no cloud segmented yet (segmentation waits for clouds on " + points_sub_->topic() +
                   "): nothing to select from; the object hint stays segmentation/object_hint_m";
    return;
  }
  // An empty frame is taken to be world_frame, as for clouds; a stamp of 0 asks for the latest transform.
  const std::string frame = point.header.frame_id.empty() ? world_frame_ : point.header.frame_id;
  std::vector<Eigen::Vector3d> in_world{given};
  std::string error;
  if (!transformToWorld(tf_buffer_, world_frame_, frame, point.header.stamp, tf_timeout_s_, &in_world, &error)) {
    res->message = "no transform from the point's frame '" + frame + "' to '" + world_frame_ + "': " + error +
                   "; the current object is kept";
    return;
  }
  const gpatlas_core::Vector3& p = in_world.front();
  const std::optional<std::size_t> picked =
      gpatlas_geometry::clusterNear(latest_->clusters, p, config_.select_max_distance_m, &res->distance_m);
  std::ostringstream message;
  message.precision(3);
  if (!picked) {
    message << "no object within " << 100.0 * config_.select_max_distance_m << " cm of " << describe(p) << " in '"
            << world_frame_ << "' (segmentation/select_max_distance_m): the nearest of the " << latest_->clusters.size()
            << " clusters is " << 100.0 * res->distance_m << " cm away; the current object is kept";
    res->message = message.str();
    return;
  }
  const std::vector<gpatlas_core::Vector3>& cluster = latest_->clusters[*picked];
  res->success = true;
  res->changed = *picked != latest_->object;
  res->object_points = static_cast<std::uint32_t>(cluster.size());
  selection_ = gpatlas_geometry::centroidOf(cluster);
  message << "cluster " << *picked + 1 << " of " << latest_->clusters.size() << " (" << cluster.size()
          << " points, centroid " << describe(*selection_) << ") ";
  if (!res->changed) {
    message << "is already the explored object: kept";
  } else {
    message << "is the explored object now: " << switchObject(*picked);
  }
  res->message = message.str();
}

std::string SegmentationServer::switchObject(std::size_t index) {
  latest_->object = index;
  // The old object's touches do not belong to the new one: the GP starts over, and fits the next
  // cloud even when it fits only on request (fit_every_cloud false).
  std::string said;
  for (const char* name : {"reset_model", "fit_next_model"}) {
    ros::ServiceClient client = nh_.serviceClient<std_srvs::Trigger>(name);
    std_srvs::Trigger trigger;
    if (!client.waitForExistence(ros::Duration(2.0))) {
      said += std::string(said.empty() ? "" : "; ") + "no " + client.getService() + " (the GP keeps its model)";
      continue;
    }
    if (!client.call(trigger) || !trigger.response.success)
      said += std::string(said.empty() ? "" : "; ") + client.getService() + " failed: " + trigger.response.message;
  }
  publishLatest();
  return said.empty() ? "the model is reset and refitted on it" : said;
}

bool SegmentationServer::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& res) {
  try {
    std::lock_guard<std::mutex> lock(mutex_);
    selection_.reset();
    res.success = true;
    if (!latest_) {
      res.message = "selection cleared: the object is segmentation/object_hint_m's again";
      return true;
    }
    const std::size_t index = gpatlas_geometry::chooseObject(latest_->clusters, config_.object_hint_m);
    if (index == latest_->object) {
      res.message = "selection cleared: segmentation/object_hint_m's object is the explored one already";
    } else {
      res.message = "selection cleared: back to segmentation/object_hint_m's object, cluster " +
                    std::to_string(index + 1) + ": " + switchObject(index);
    }
  } catch (const std::exception& e) {
    res.success = false;
    res.message = std::string("reset failed: ") + e.what();
  }
  return true;
}

namespace {

std::string span(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::ostringstream out;
  out.precision(3);
  out << "x [" << lo.x() << ", " << hi.x() << "], y [" << lo.y() << ", " << hi.y() << "], z [" << lo.z() << ", "
      << hi.z() << "] m";
  return out.str();
}

}  // namespace

void SegmentationServer::reportOutsideCropBox(const sensor_msgs::PointCloud2& msg,
                                              const std::vector<Eigen::Vector3d>& points) {
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const Eigen::Vector3d& p : points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const auto& c = config_;
  ROS_ERROR_STREAM_THROTTLE(10.0, "segmentation: none of the cloud's "
                                      << points.size() << " points (frame '" << msg.header.frame_id << "'; in '"
                                      << world_frame_ << "' they span " << span(lo, hi)
                                      << ") lies in the crop box " << span(c.crop_min_m, c.crop_max_m) << " of '"
                                      << world_frame_
                                      << "' (segmentation/crop_min_m, crop_max_m). The workspace is given in "
                                         "world_frame, z up with the table near z = 0: check the camera's pose in "
                                         "tf, or move the box");
}

void SegmentationServer::checkSensorFrame(const sensor_msgs::PointCloud2& msg) {
  if (sensor_frame_.empty() || msg.header.frame_id == sensor_frame_) return;
  // A frame tf has never heard of is reported at once; a known one gets the usual wait.
  if (tf_buffer_._frameExists(sensor_frame_) &&
      tf_buffer_.canTransform(world_frame_, sensor_frame_, msg.header.stamp, ros::Duration(tf_timeout_s_)))
    return;
  // The GP places the view's free space and occluded interior from sensor_frame's origin; without
  // it they are gone, and a smooth fit closes every opening the camera looked into.
  ROS_ERROR_STREAM_THROTTLE(10.0, "segmentation: the camera's cloud is in frame '"
                                      << msg.header.frame_id << "', but sensor_frame is '" << sensor_frame_
                                      << "', which has no transform to '" << world_frame_
                                      << "': the model loses the view's free space (a mug gets a lid). Set the "
                                         "parameter sensor_frame: "
                                      << msg.header.frame_id << " (or publish '" << sensor_frame_ << "' in tf)");
}

}  // namespace gpatlas_ros
