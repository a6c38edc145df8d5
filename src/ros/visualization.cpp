#include "sag_hand_tracker/ros/visualization.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "sag_hand_tracker/energy/colour.h"
#include "sag_hand_tracker/energy/hand_projection.h"

namespace sag_hand_tracker {
namespace {

geometry_msgs::Point toPoint(const Eigen::Vector3d& p) {
  geometry_msgs::Point point;
  point.x = p.x();
  point.y = p.y();
  point.z = p.z();
  return point;
}

geometry_msgs::Quaternion toQuaternion(const Eigen::Matrix3d& rotation) {
  const Eigen::Quaterniond q(rotation);
  geometry_msgs::Quaternion msg;
  msg.x = q.x();
  msg.y = q.y();
  msg.z = q.z();
  msg.w = q.w();
  return msg;
}

}  // namespace

visualization_msgs::MarkerArray makeHandMarkers(const HandModel& model, const PosedHand& hand,
                                                const std_msgs::Header& header) {
  visualization_msgs::MarkerArray markers;
  for (size_t g = 0; g < hand.gaussians.size(); ++g) {
    visualization_msgs::Marker m;
    m.header = header;
    m.ns = "gaussians";
    m.id = static_cast<int>(g);
    m.type = visualization_msgs::Marker::SPHERE;
    m.action = visualization_msgs::Marker::ADD;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(hand.gaussians[g].cov);
    Eigen::Matrix3d axes = eig.eigenvectors();
    if (axes.determinant() < 0) axes.col(2) = -axes.col(2);  // a rotation, not a reflection
    m.pose.position = toPoint(hand.gaussians[g].mean);
    m.pose.orientation = toQuaternion(axes);
    const Eigen::Vector3d sigma = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
    m.scale.x = 2.0 * sigma[0];
    m.scale.y = 2.0 * sigma[1];
    m.scale.z = 2.0 * sigma[2];
    const Eigen::Vector3d rgb = hsvToRgb(model.gaussians[g].hsv);
    m.color.r = static_cast<float>(rgb[0]);
    m.color.g = static_cast<float>(rgb[1]);
    m.color.b = static_cast<float>(rgb[2]);
    m.color.a = 0.8f;
    markers.markers.push_back(m);
  }
  visualization_msgs::Marker lines;
  lines.header = header;
  lines.ns = "skeleton";
  lines.id = 0;
  lines.type = visualization_msgs::Marker::LINE_LIST;
  lines.action = visualization_msgs::Marker::ADD;
  lines.pose.orientation.w = 1.0;
  lines.scale.x = 0.002;
  lines.color.r = lines.color.g = lines.color.b = 0.9f;
  lines.color.a = 1.0f;
  for (size_t b = 0; b < model.bones.size(); ++b) {
    const Eigen::Isometry3d& frame = hand.bone_frames[b];
    if (model.bones[b].parent >= 0) {  // parent origin -> bone origin
      lines.points.push_back(toPoint(hand.bone_frames[model.bones[b].parent].translation()));
      lines.points.push_back(toPoint(frame.translation()));
    }
    if (model.bones[b].length > 0.0) {  // along the bone's x axis
      lines.points.push_back(toPoint(frame.translation()));
      lines.points.push_back(toPoint(frame * Eigen::Vector3d(model.bones[b].length, 0.0, 0.0)));
    }
  }
  markers.markers.push_back(lines);
  return markers;
}

void drawHandOverlay(const Camera& camera, const PosedHand& hand, cv::Mat* bgr) {
  drawProjectedEllipses(projectHand(hand, camera), cv::Scalar(255, 255, 0), bgr);
}

}  // namespace sag_hand_tracker
