// Standalone node running sag_hand_tracker/StudioDriverNodelet in its own process (same
// parameters, topics and remappings as the nodelet): rosrun sag_hand_tracker studio_driver_node
#include <nodelet/loader.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "studio_driver_node");
  nodelet::Loader loader;
  const nodelet::M_string remappings(ros::names::getRemappings());
  const nodelet::V_string nodelet_argv(argv + 1, argv + argc);
  if (!loader.load(ros::this_node::getName(), "sag_hand_tracker/StudioDriverNodelet", remappings,
                   nodelet_argv)) {
    ROS_FATAL("could not load the nodelet sag_hand_tracker/StudioDriverNodelet");
    return 1;
  }
  ros::spin();
  return 0;
}
