#!/usr/bin/env bash
# Installs every Debian package the workspace needs. Idempotent: when all are present it
# only checks and returns (no apt-get update, no network).
set -euo pipefail

PACKAGES=(
  # build tooling
  build-essential cmake ccache catkin catkin-lint python3-catkin-pkg ros-cmake-modules
  # ROS 1 core (Debian's ROS_DISTRO=Debian)
  ros-message-generation ros-message-runtime libroscpp-dev rosbash rospack-tools rosout
  python3-rospy python3-roslaunch python3-rosmaster python3-rosnode python3-rostopic
  python3-rosservice python3-rosmsg python3-rosparam
  libnodeletlib-dev libnodelet-dev libnodeletlib-tools pluginlib-dev libclass-loader-dev
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev python3-tf2-ros
  # a real camera's set-up: static_transform_publisher (extrinsics), rosbag play (recorded views)
  tf2-tools python3-rosbag
  # algorithms
  libyaml-cpp-dev libpcl-dev libpcl-conversions-dev liboctomap-dev libbullet-dev libceres-dev libeigen3-dev libtbb-dev libopenblas-dev
  liborocos-kdl-dev libkdl-parser-dev liburdf-dev liburdfdom-dev liburdfdom-tools libompl-dev libfcl-dev
  ros-robot-state-publisher joint-state-publisher joint-state-publisher-gui
  # tests and benchmarks
  librostest-dev python3-rostest libgtest-dev googletest libbenchmark-dev python3-nose python3-yaml
  # a single-node Slurm for the test of scripts/slurm_bench.sh
  slurmd slurmctld slurm-client munge
  # messages (the .msg definitions are needed by message generation)
  ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-visualization-msgs ros-shape-msgs
  ros-pcl-msgs ros-tf2-msgs ros-std-srvs ros-trajectory-msgs libstd-msgs-dev libgeometry-msgs-dev
  libsensor-msgs-dev libvisualization-msgs-dev libshape-msgs-dev libpcl-msgs-dev
  libtf2-msgs-dev libstd-srvs-dev libtrajectory-msgs-dev python3-std-msgs python3-geometry-msgs python3-sensor-msgs
  python3-visualization-msgs python3-shape-msgs python3-std-srvs python3-trajectory-msgs
  # visualisation, plots, screenshots
  rviz xvfb python3-matplotlib python3-numpy imagemagick
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$pkg" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$pkg")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "[deps] all ${#PACKAGES[@]} Debian packages present"
  exit 0
fi

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  SUDO="sudo"
fi
echo "[deps] installing ${#missing[@]} missing Debian packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "[deps] done"
