#pragma once

// What the rostests on ../shared's real cloud (mug_cloud_camera.launch) share.

#include <gpatlas_msgs/OctomapBinary.h>
#include <gpatlas_msgs/TrainingSet.h>

#include <ros/master.h>
#include <ros/network.h>
#include <ros/ros.h>
#include <sensor_msgs/PointCloud2.h>
#include <xmlrpcpp/XmlRpc.h>

#include <Eigen/Dense>
#include <octomap/OcTree.h>

#include <cmath>
#include <cstddef>
#include <filesystem>
#include <fstream>
#include <functional>
#include <mutex>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace mug_cloud_test {

// The recorded cloud's path (the test's ~pcd) in *path; true when the file is absent, and the
// test is to skip with skipMessage(*path).
inline bool recordedCloudAbsent(std::string* path) {
  ros::NodeHandle("~").getParam("pcd", *path);
  return !std::filesystem::is_regular_file(*path);
}

inline std::string skipMessage(const std::string& path) {
  return "no recorded cloud at '" + path + "' (../shared/data is absent): skipped";
}

// The camera's clouds (/camera/points) and the GP's models (its training sets) as they arrive.
class Arrivals {
 public:
  explicit Arrivals(ros::NodeHandle nh) {
    cloud_sub_ = nh.subscribe<sensor_msgs::PointCloud2>("/camera/points", 100,
                                                        [this](const sensor_msgs::PointCloud2::ConstPtr&) {
                                                          std::lock_guard<std::mutex> lock(mutex_);
                                                          ++clouds_;
                                                          last_cloud_ = ros::WallTime::now();
                                                        });
    model_sub_ = nh.subscribe<gpatlas_msgs::TrainingSet>("/gpatlas/gp_model/training_set", 100,
                                                         [this](const gpatlas_msgs::TrainingSet::ConstPtr&) {
                                                           std::lock_guard<std::mutex> lock(mutex_);
                                                           models_.push_back(ros::WallTime::now());
                                                         });
  }
  std::size_t clouds() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return clouds_;
  }
  ros::WallTime lastCloud() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return last_cloud_;
  }
  std::vector<ros::WallTime> models() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return models_;
  }

 private:
  mutable std::mutex mutex_;
  std::size_t clouds_{0};
  ros::WallTime last_cloud_;
  std::vector<ros::WallTime> models_;
  ros::Subscriber cloud_sub_, model_sub_;
};

// The process id of a node, asked of the master and then of the node (its XML-RPC getPid);
// 0 when either does not answer. Another test on this machine may run a manager of the same
// name under another master: the pid is asked, not searched for.
inline int nodePid(const std::string& node) {
  XmlRpc::XmlRpcValue args, result, payload;
  args[0] = ros::this_node::getName();
  args[1] = node;
  if (!ros::master::execute("lookupNode", args, result, payload, false)) return 0;
  std::string host, uri = static_cast<std::string>(payload);
  std::uint32_t port = 0;
  if (!ros::network::splitURI(uri, host, port)) return 0;
  XmlRpc::XmlRpcClient client(host.c_str(), static_cast<int>(port), "/");
  XmlRpc::XmlRpcValue caller, answer;
  caller[0] = ros::this_node::getName();
  if (!client.execute("getPid", caller, answer) || answer.getType() != XmlRpc::XmlRpcValue::TypeArray ||
      answer.size() < 3 || static_cast<int>(answer[0]) != 1)
    return 0;
  return static_cast<int>(answer[2]);
}

// A process's resident memory in MB (VmRSS), or a negative number when it is gone.
inline double residentMb(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return -1.0;
}

// The newest message of a topic, how many came and when the newest did, for the test's thread.
template <typename Msg>
class Latest {
 public:
  void set(const Msg& m) {
    std::lock_guard<std::mutex> lock(mutex_);
    msg_ = m;
    ++count_;
    received_ = ros::WallTime::now();
  }
  std::optional<Msg> get(std::size_t* count = nullptr) const {
    std::lock_guard<std::mutex> lock(mutex_);
    if (count) *count = count_;
    return msg_;
  }
  std::size_t count() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return count_;
  }
  ros::WallTime received() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return received_;
  }
  // Any message.
  std::optional<Msg> waitFor(double timeout_s) const {
    return waitFor(0, [](const Msg&) { return true; }, timeout_s);
  }
  // Waits until a message after the `after`-th one satisfies `ok`.
  std::optional<Msg> waitFor(std::size_t after, const std::function<bool(const Msg&)>& ok, double timeout_s) const {
    const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (ros::ok() && ros::WallTime::now() < end) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        if (msg_ && count_ > after && ok(*msg_)) return msg_;
      }
      ros::WallDuration(0.05).sleep();
    }
    return std::nullopt;
  }

 private:
  mutable std::mutex mutex_;
  std::optional<Msg> msg_;
  std::size_t count_{0};
  ros::WallTime received_;
};

// Least-squares circle through the points' (x, y) (Kasa's algebraic fit): centre and radius.
inline std::pair<Eigen::Vector2d, double> fitCircle(const std::vector<Eigen::Vector3d>& points) {
  Eigen::MatrixXd a(points.size(), 3);
  Eigen::VectorXd b(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    a.row(static_cast<Eigen::Index>(i)) << points[i].x(), points[i].y(), 1.0;
    b[static_cast<Eigen::Index>(i)] = points[i].head<2>().squaredNorm();
  }
  const Eigen::Vector3d s = a.colPivHouseholderQr().solve(b);
  const Eigen::Vector2d centre = 0.5 * s.head<2>();
  return {centre, std::sqrt(s[2] + centre.squaredNorm())};
}

// The octree an OctomapBinary carries, decoded as octomap_msgs' readTree does: no data is the
// empty tree (OctoMap's readBinaryData would read a root from nothing).
inline std::unique_ptr<octomap::OcTree> treeOf(const gpatlas_msgs::OctomapBinary& msg) {
  auto tree = std::make_unique<octomap::OcTree>(msg.resolution);
  if (msg.data.empty()) return tree;
  std::stringstream stream(std::string(msg.data.begin(), msg.data.end()));
  tree->readBinaryData(stream);
  return tree;
}

inline bool occupiedAt(const octomap::OcTree& tree, const Eigen::Vector3d& p) {
  const octomap::OcTreeNode* node = tree.search(p.x(), p.y(), p.z());
  return node && tree.isNodeOccupied(node);
}

}  // namespace mug_cloud_test
