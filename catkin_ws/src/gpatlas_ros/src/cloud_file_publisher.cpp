// A recorded cloud as the camera: reads a PCD or PLY file once (PCL's readers) and publishes it
// on `points` (sensor_msgs/PointCloud2) in `~frame_id`, once and latched (`~rate_hz` 0), or as a
// stream at `~rate_hz` for `~duration_s` (0: until shut down), each message freshly stamped, the
// way a driver streams. The single cloud waits up to `~wait_for_subscriber_s` for a subscriber before
// it is stamped. NaN points are kept: an organised cloud stays organised. A .pcd file is checked
// (gpatlas_geometry::checkPcdFile) before PCL reads it: PCL's reader crashes on an empty or corrupt
// one. With `~estimate_camera_pose` (recorded_cloud.launch's camera_pose:=auto), the camera's
// pose in `~world_frame` comes from the cloud itself (gpatlas_geometry::estimateCameraPose: the
// table at z = 0) and is broadcast as a static transform before the cloud, its camera_pose:=
// argument logged.

#include "gpatlas_conversions/conversions.h"
#include "gpatlas_geometry/camera_pose.h"
#include "gpatlas_geometry/cloud_file.h"

#include <pcl/PCLPointCloud2.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl_conversions/pcl_conversions.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <string>

namespace {

std::string lowerExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

// Empty when the file was read; otherwise why not.
std::string readCloud(const std::string& path, sensor_msgs::PointCloud2* cloud) {
  if (path.empty()) return "~file is empty: give the path of a .pcd or .ply cloud";
  if (!std::filesystem::is_regular_file(path)) return "no such file: " + path;
  pcl::PCLPointCloud2 pcl_cloud;
  const std::string extension = lowerExtension(path);
  int status = -1;
  if (extension == ".pcd") {
    if (const std::string error = gpatlas_geometry::checkPcdFile(path); !error.empty()) return error;
    status = pcl::io::loadPCDFile(path, pcl_cloud);
  } else if (extension == ".ply") {
    status = pcl::io::loadPLYFile(path, pcl_cloud);
  } else {
    return path + ": unknown extension '" + extension + "' (.pcd or .ply)";
  }
  if (status < 0) return path + ": PCL could not read it (status " + std::to_string(status) + ")";
  if (pcl_cloud.width * pcl_cloud.height == 0) return path + ": the cloud has no points";
  pcl_conversions::fromPCL(pcl_cloud, *cloud);
  return "";
}

// The camera's pose from the cloud, broadcast as world_frame -> the cloud's frame; empty when it
// is, else why not.
std::string broadcastEstimatedPose(const sensor_msgs::PointCloud2& cloud, const std::string& world_frame,
                                   tf2_ros::StaticTransformBroadcaster* broadcaster) {
  std::vector<Eigen::Vector3d> points;
  std::size_t invalid = 0;
  std::string error;
  if (!gpatlas_conversions::cloudToPoints(cloud, &points, &invalid, &error)) return error;
  const gpatlas_geometry::CameraPose pose = gpatlas_geometry::estimateCameraPose(points);
  if (!pose.ok) return pose.message;
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = ros::Time::now();
  transform.header.frame_id = world_frame;
  transform.child_frame_id = cloud.header.frame_id;
  transform.transform.translation.x = pose.translation.x();
  transform.transform.translation.y = pose.translation.y();
  transform.transform.translation.z = pose.translation.z();
  transform.transform.rotation.x = pose.rotation.x();
  transform.transform.rotation.y = pose.rotation.y();
  transform.transform.rotation.z = pose.rotation.z();
  transform.transform.rotation.w = pose.rotation.w();
  broadcaster->sendTransform(transform);
  ROS_INFO_STREAM("cloud_file_publisher: camera_pose:=auto: the table is " << pose.table_offset
                                                                          << " m below the camera, which looks "
                                                                          << pose.looking_down_deg << " degrees down: camera_pose:=\""
                                                                          << gpatlas_geometry::cameraPoseArgument(pose)
                                                                          << "\"");
  return "";
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "cloud_file_publisher");
  ros::NodeHandle nh, pnh("~");
  const std::string path = pnh.param<std::string>("file", "");
  const std::string frame_id = pnh.param<std::string>("frame_id", "camera_optical_frame");
  const double rate_hz = pnh.param("rate_hz", 0.0);
  const double duration_s = pnh.param("duration_s", 0.0);
  const double wait_for_subscriber_s = pnh.param("wait_for_subscriber_s", 10.0);
  if (!(rate_hz >= 0.0) || !(duration_s >= 0.0)) {
    ROS_FATAL_STREAM("cloud_file_publisher: ~rate_hz and ~duration_s must be >= 0 (got " << rate_hz << ", "
                                                                                        << duration_s << ")");
    return 1;
  }
  sensor_msgs::PointCloud2 cloud;
  if (const std::string error = readCloud(path, &cloud); !error.empty()) {
    ROS_FATAL_STREAM("cloud_file_publisher: " << error);
    return 1;
  }
  cloud.header.frame_id = frame_id;
  tf2_ros::StaticTransformBroadcaster broadcaster;
  if (pnh.param("estimate_camera_pose", false)) {
    const std::string world_frame = pnh.param<std::string>("world_frame", "world");
    if (const std::string error = broadcastEstimatedPose(cloud, world_frame, &broadcaster); !error.empty()) {
      ROS_FATAL_STREAM("cloud_file_publisher: camera_pose:=auto: " << error
                                                                   << "; give the camera's pose as camera_pose:=\"x y z qx qy qz qw\"");
      return 1;
    }
  }
  ROS_INFO_STREAM("cloud_file_publisher: " << path << ": " << cloud.width << " x " << cloud.height << " points in '"
                                           << frame_id << "', "
                                           << (rate_hz > 0.0 ? std::to_string(rate_hz) + " Hz" : std::string("once")));
  // Latched: a pipeline that starts later still gets the one view.
  ros::Publisher pub = nh.advertise<sensor_msgs::PointCloud2>("points", 1, /*latch=*/rate_hz == 0.0);
  if (rate_hz == 0.0) {
    // Stamped when the pipeline listens, so that the stamp says when the view reached it.
    const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(wait_for_subscriber_s);
    while (ros::ok() && pub.getNumSubscribers() == 0 && ros::WallTime::now() < give_up) {
      // The one wait of this process: said after 10 s (wait_for_subscriber_s may be longer), as
      // every wait of the pipeline is.
      ROS_WARN_STREAM_DELAYED_THROTTLE(10.0, "cloud_file_publisher: waiting for a subscriber on "
                                                 << pub.getTopic() << " (remap points:=... to change it) for at most "
                                                 << wait_for_subscriber_s << " s (~wait_for_subscriber_s)");
      ros::WallDuration(0.05).sleep();
    }
    cloud.header.stamp = ros::Time::now();
    pub.publish(cloud);
    ros::spin();
    return 0;
  }
  ros::Rate rate(rate_hz);
  const ros::Time start = ros::Time::now();
  std::uint32_t published = 0;
  while (ros::ok() && (duration_s == 0.0 || (ros::Time::now() - start).toSec() < duration_s)) {
    cloud.header.stamp = ros::Time::now();
    cloud.header.seq = published++;
    pub.publish(cloud);
    rate.sleep();
  }
  ROS_INFO_STREAM("cloud_file_publisher: " << published << " clouds published in " << (ros::Time::now() - start).toSec()
                                           << " s");
  ros::spin();
  return 0;
}
