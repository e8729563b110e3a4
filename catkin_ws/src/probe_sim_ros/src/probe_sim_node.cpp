// probe_sim_node: the simulated probe and depth camera as a ROS node (see simulation_server.h).

#include "simulation_server.h"

#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "probe_sim");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  probe_sim::SimulationServer server(nh, pnh);
  // Two threads, so that joint_states keeps flowing (and the arm keeps moving in rviz) while a
  // long slide is being probed; the server guards the simulation with a mutex.
  ros::MultiThreadedSpinner spinner(2);
  spinner.spin();
  return 0;
}
