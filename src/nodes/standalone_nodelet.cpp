// Standalone node running one of the package's nodelets in its own process, with the same
// parameters, topics and remappings as the nodelet. Built once per nodelet (CMakeLists.txt sets
// SAG_NODELET_TYPE and SAG_NODE_NAME): rosrun sag_hand_tracker tracker_node, segmentation_node,
// camera_driver_node, studio_driver_node.
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, SAG_NODE_NAME);
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string nodelet_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), SAG_NODELET_TYPE, remappings, nodelet_argv)) {
    ROS_FATAL("could not load the nodelet %s", SAG_NODELET_TYPE);
    return 1;
  }
  ros::spin();
  return 0;
}
