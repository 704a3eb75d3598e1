#!/usr/bin/env bash
# Installs what rost needs to build, test and run on Debian 12 (as root, or
# through sudo). Safe to run again.
set -euo pipefail
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
packages=(
  build-essential cmake ninja-build pkg-config
  libeigen3-dev libopencv-dev libcamera-dev libcli11-dev zlib1g-dev libpng-dev
  libgtest-dev googletest libgmock-dev libbenchmark-dev
  g++-aarch64-linux-gnu g++-arm-linux-gnueabihf qemu-user
  clang libclang-rt-14-dev valgrind ffmpeg
  pybind11-dev python3-dev python3-numpy python3-pytest python3-hypothesis python3-opencv python3-matplotlib
  # rost.fleet's missions as Dask tasks (a LocalCluster or a scheduler on many machines;
  # docs/fleet.md) and its test on a LocalCluster.
  python3-distributed
  # ROS 1 (1.15): rost_node (its images through image_transport), rost_msgs
  # generation (gencpp, genpy; std_msgs' .msg files), bags; the node and bag
  # tests (rosmaster, rospy, rosbag, rosservice).
  libroscpp-dev libsensor-msgs-dev libstd-msgs-dev libstd-srvs-dev librosbag-dev librosbag-storage-dev
  libimage-transport-dev
  ros-std-msgs python3-genpy python3-gencpp
  python3-rosmaster python3-rosbag python3-rostopic python3-rospy python3-rosservice
  python3-sensor-msgs python3-std-srvs
  # ROS 1's command-line tools, as a ROS user runs the node (and the launch
  # test): roslaunch and roscore (python3-roslaunch; rosout, the log node
  # roscore starts), rosparam, rosnode, rosrun (rosbash; rospack-tools finds
  # packages), image_transport's list_transports and republish.
  python3-roslaunch rosout python3-rosparam python3-rosnode rosbash rospack-tools image-transport-tools
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing: ${missing[*]}"
  $SUDO apt-get update -q
  $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
