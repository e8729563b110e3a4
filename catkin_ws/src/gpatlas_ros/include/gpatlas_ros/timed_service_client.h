#pragma once

#include <gpatlas_ros/wait_report.h>
#include <ros/ros.h>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace gpatlas_ros {

// The exploration node's service calls, each with a timeout: ros::service::call has none, and a
// server that never answers (an arm stuck mid-motion, a hung driver) would freeze the
// exploration for good. A call runs on a worker thread with its own copy of the request; past
// the timeout it is given up on and reported. Call joinWorkers() after ros::shutdown(), which
// makes any call still blocked return.
class TimedServiceClient {
 public:
  // `service_timeout_s`: how long a service may take to appear; `call_timeout_s`: to answer.
  TimedServiceClient(ros::NodeHandle nh, double service_timeout_s, double call_timeout_s)
      : nh_(nh), service_timeout_s_(service_timeout_s), call_timeout_s_(call_timeout_s) {}

  // The loop's services, over persistent connections: a call per step, several steps a second,
  // and a new connection for each would ask the master for the service every time (and a busy
  // master refuses now and then). A connection that failed or timed out is opened again at the
  // next call.
  template <typename Srv>
  bool call(const std::string& name, Srv& srv);

  // Optional services (the ground truth, the map's saving), asked once at the start or the end:
  // whether `name` is offered within a short wait, and one call on a connection of its own,
  // given at most kOptionalCallTimeoutS.
  bool isOffered(const std::string& name) const {
    return ros::service::waitForService(nh_.resolveName(name), ros::Duration(kOptionalServiceWaitS));
  }
  template <typename Srv>
  bool callOptional(const std::string& name, Srv& srv) {
    return timedCall(nh_.resolveName(name), srv, std::min(call_timeout_s_, kOptionalCallTimeoutS));
  }

  // Joins the call workers; call after ros::shutdown().
  void joinWorkers() {
    for (auto& worker : workers_)
      if (worker.joinable()) worker.join();
    workers_.clear();
  }

  std::string resolveName(const std::string& name) const { return nh_.resolveName(name); }

 private:
  // Optional: not worth a wait.
  static constexpr double kOptionalServiceWaitS = 2.0;
  static constexpr double kOptionalCallTimeoutS = 30.0;

  // Waits at most service_timeout_s_ for the service `name` to be offered, saying every
  // kWaitReportPeriodS which one and how it is remapped.
  bool waitForService(const std::string& name) const {
    const std::string resolved = nh_.resolveName(name);
    WaitReport report("exploration", [this, &name] {
      return "the service " + remapHint(nh_, name) + " to be offered; gives up after service_timeout_s (" +
             seconds(service_timeout_s_) + ")";
    });
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(service_timeout_s_);
    for (;;) {
      const double left_s = (deadline - ros::WallTime::now()).toSec();
      if (left_s <= 0.0) return false;
      if (ros::service::waitForService(resolved, ros::Duration(std::min(left_s, 1.0)))) return true;
      if (!ros::ok()) return false;
      report.poll();
    }
  }

  // Calls the service on `client` (persistent), or on a connection of its own without one.
  template <typename Srv>
  bool timedCall(const std::string& resolved, Srv& srv, double timeout_s, const ros::ServiceClient* client = nullptr);

  ros::NodeHandle nh_;
  double service_timeout_s_;
  double call_timeout_s_;
  std::vector<std::thread> workers_;  // service calls in flight or abandoned (see timedCall)
  std::map<std::string, ros::ServiceClient> clients_;  // call's connections, by resolved name
};

template <typename Srv>
bool TimedServiceClient::call(const std::string& name, Srv& srv) {
  const std::string resolved = nh_.resolveName(name);
  ros::ServiceClient& client = clients_[resolved];
  if (!client || !client.isValid()) {
    if (!waitForService(name)) {
      ROS_ERROR_STREAM("exploration: service " << resolved << " not available after " << service_timeout_s_ << " s");
      return false;
    }
    client = nh_.serviceClient<Srv>(resolved, true);
  }
  if (timedCall(resolved, srv, call_timeout_s_, &client)) return true;
  clients_.erase(resolved);
  return false;
}

template <typename Srv>
bool TimedServiceClient::timedCall(const std::string& resolved, Srv& srv, double timeout_s,
                                   const ros::ServiceClient* client) {
  struct Pending {
    std::mutex mutex;
    std::condition_variable answered;
    bool done{false};
    bool ok{false};
    Srv srv;
  };
  auto pending = std::make_shared<Pending>();
  pending->srv = srv;
  // A copy of the handle: a call given up on keeps its connection, the next gets a new one.
  ros::ServiceClient connection = client ? *client : ros::ServiceClient();
  try {
    workers_.emplace_back([pending, resolved, connection]() mutable {
      const bool ok = connection ? connection.call(pending->srv) : ros::service::call(resolved, pending->srv);
      std::lock_guard<std::mutex> lock(pending->mutex);
      pending->ok = ok;
      pending->done = true;
      pending->answered.notify_all();
    });
  } catch (const std::system_error& e) {
    ROS_ERROR_STREAM("exploration: cannot call " << resolved << ": " << e.what());
    return false;
  }
  WaitReport report("exploration", [&resolved, timeout_s] {
    return "the answer of " + resolved + "; gives up after call_timeout_s (" + seconds(timeout_s) + ")";
  });
  using Clock = std::chrono::steady_clock;
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  std::unique_lock<std::mutex> lock(pending->mutex);
  while (!pending->answered.wait_until(lock, std::min(deadline, Clock::now() + Clock::duration(std::chrono::seconds(1))),
                                       [&pending]() { return pending->done; })) {
    if (Clock::now() >= deadline) {
      ROS_ERROR_STREAM("exploration: " << resolved << " did not answer within " << timeout_s << " s");
      return false;
    }
    report.poll();
  }
  lock.unlock();
  workers_.back().join();  // finished: reap it now (the last started is this call's)
  workers_.pop_back();
  if (!pending->ok) {
    ROS_ERROR_STREAM("exploration: call to " << resolved << " failed");
    return false;
  }
  srv = pending->srv;
  return true;
}

}  // namespace gpatlas_ros
