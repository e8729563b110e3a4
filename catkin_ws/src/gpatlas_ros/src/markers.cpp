#include "gpatlas_ros/markers.h"

#include "gpatlas_conversions/conversions.h"

#include <Eigen/Geometry>

namespace gpatlas_ros {

using namespace gpatlas_conversions;

namespace {

std_msgs::ColorRGBA colour(double variance, double v_max, float alpha = 1.0f) {
  std_msgs::ColorRGBA c;
  varianceColour(variance, v_max, &c.r, &c.g, &c.b);
  c.a = alpha;
  return c;
}

visualization_msgs::Marker baseMarker(const std::string& frame, const std::string& ns, int id, int type) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.ns = ns;
  m.id = id;
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = m.scale.y = m.scale.z = 1.0;
  m.color.a = 1.0f;
  return m;
}

}  // namespace

visualization_msgs::MarkerArray objectBoxMarkers(const std::vector<std::vector<gpatlas_core::Vector3>>& clusters,
                                                 std::size_t explored, const std::string& frame) {
  visualization_msgs::MarkerArray out;
  out.markers.push_back(deleteAllMarker(frame));  // the boxes of the previous cloud go
  auto object = baseMarker(frame, "explored_object", 0, visualization_msgs::Marker::LINE_LIST);
  auto others = baseMarker(frame, "other_objects", 0, visualization_msgs::Marker::LINE_LIST);
  object.scale.x = 0.004;
  others.scale.x = 0.002;
  object.color.g = 1.0f;
  others.color.r = 1.0f;
  others.color.g = 0.5f;
  for (std::size_t i = 0; i < clusters.size(); ++i) {
    if (clusters[i].empty()) continue;
    Eigen::Vector3d lo = clusters[i].front(), hi = lo;
    for (const auto& p : clusters[i]) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
    visualization_msgs::Marker& m = i == explored ? object : others;
    // The 12 edges: between corners that differ in one coordinate.
    for (int a = 0; a < 8; ++a)
      for (int axis = 0; axis < 3; ++axis) {
        if (a & (1 << axis)) continue;
        const int b = a | (1 << axis);
        for (int corner : {a, b}) {
          geometry_msgs::Point p;
          p.x = (corner & 1) ? hi.x() : lo.x();
          p.y = (corner & 2) ? hi.y() : lo.y();
          p.z = (corner & 4) ? hi.z() : lo.z();
          m.points.push_back(p);
        }
      }
  }
  for (auto* m : {&object, &others})
    if (!m->points.empty()) out.markers.push_back(*m);
  return out;
}

visualization_msgs::Marker deleteAllMarker(const std::string& frame) {
  auto clear = baseMarker(frame, "", 0, visualization_msgs::Marker::CUBE);
  clear.action = visualization_msgs::Marker::DELETEALL;
  return clear;
}

visualization_msgs::MarkerArray deleteAllMarkers(const std::string& frame) {
  visualization_msgs::MarkerArray array;
  array.markers.push_back(deleteAllMarker(frame));
  return array;
}

visualization_msgs::Marker approachMarker(const std::vector<gpatlas_core::Vector3>& tip_path, const std::string& frame) {
  auto line = baseMarker(frame, "approach", 0, visualization_msgs::Marker::LINE_STRIP);
  line.scale.x = 0.004;
  line.color.r = 0.0f;
  line.color.g = 0.8f;
  line.color.b = 0.2f;
  for (const auto& p : tip_path) line.points.push_back(toPointMsg(p));
  return line;
}

visualization_msgs::Marker armTrailMarker(const std::vector<std::vector<gpatlas_motion::LinkCapsule>>& link_poses,
                                          const std::string& frame) {
  auto lines = baseMarker(frame, "approach_arm", 0, visualization_msgs::Marker::LINE_LIST);
  lines.scale.x = 0.006;
  lines.color.a = 1.0f;
  for (std::size_t i = 0; i < link_poses.size(); ++i) {
    const float t = link_poses.size() > 1 ? static_cast<float>(i) / static_cast<float>(link_poses.size() - 1) : 1.0f;
    std_msgs::ColorRGBA c;
    c.r = 0.9f * (1.0f - t) + 0.1f * t;
    c.g = 0.6f * (1.0f - t) + 0.3f * t;
    c.b = 0.1f * (1.0f - t) + 0.9f * t;
    c.a = 0.8f;
    for (const auto& link : link_poses[i]) {
      lines.points.push_back(toPointMsg(link.a));
      lines.points.push_back(toPointMsg(link.b));
      lines.colors.push_back(c);
      lines.colors.push_back(c);
    }
  }
  return lines;
}

visualization_msgs::Marker meshMarker(const gpatlas_core::TriangleMesh& mesh, double v_max, const std::string& frame) {
  auto m = baseMarker(frame, "predicted_surface", 0, visualization_msgs::Marker::TRIANGLE_LIST);
  const bool has_variance = mesh.vertex_variances.size() == mesh.vertices.size();
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const auto v = static_cast<std::size_t>(t[k]);
      m.points.push_back(toPointMsg(mesh.vertices[v]));
      m.colors.push_back(colour(has_variance ? mesh.vertex_variances[v] : 0.0, v_max));
    }
  }
  return m;
}

visualization_msgs::MarkerArray atlasMarkers(const gpatlas_core::Atlas& atlas, const std::vector<int>& path,
                                             double v_max, const std::string& frame) {
  visualization_msgs::MarkerArray array;
  auto clear = baseMarker(frame, "atlas", 0, visualization_msgs::Marker::CUBE);
  clear.action = visualization_msgs::Marker::DELETEALL;
  array.markers.push_back(clear);

  int id = 0;
  for (const auto& chart : atlas.charts()) {
    // A disk: a flat cylinder whose axis is the chart's normal.
    auto disk = baseMarker(frame, "atlas_charts", id++, visualization_msgs::Marker::CYLINDER);
    disk.pose.position = toPointMsg(chart.centre);
    const Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), chart.normal);
    disk.pose.orientation.x = q.x();
    disk.pose.orientation.y = q.y();
    disk.pose.orientation.z = q.z();
    disk.pose.orientation.w = q.w();
    disk.scale.x = disk.scale.y = 2.0 * chart.radius;
    disk.scale.z = 0.0015;
    disk.color = colour(chart.variance, v_max, 0.85f);
    array.markers.push_back(disk);
  }

  auto edges = baseMarker(frame, "atlas_tree", 0, visualization_msgs::Marker::LINE_LIST);
  edges.scale.x = 0.0015;
  edges.color.r = edges.color.g = edges.color.b = 0.85f;
  for (const auto& chart : atlas.charts()) {
    if (chart.parent < 0) continue;
    edges.points.push_back(toPointMsg(atlas.chart(chart.parent).centre));
    edges.points.push_back(toPointMsg(chart.centre));
  }
  if (!edges.points.empty()) array.markers.push_back(edges);

  if (path.size() >= 1) {
    auto line = baseMarker(frame, "atlas_path", 0, visualization_msgs::Marker::LINE_STRIP);
    line.scale.x = 0.006;
    line.color.r = 1.0f;
    line.color.g = 0.85f;
    line.color.b = 0.0f;
    for (int index : path) line.points.push_back(toPointMsg(atlas.chart(index).centre));
    if (line.points.size() == 1) line.points.push_back(line.points.front());
    array.markers.push_back(line);
    auto end = baseMarker(frame, "atlas_path", 1, visualization_msgs::Marker::SPHERE);
    end.pose.position = toPointMsg(atlas.chart(path.back()).centre);
    end.scale.x = end.scale.y = end.scale.z = 0.016;
    end.color = line.color;
    array.markers.push_back(end);
  }
  return array;
}

}  // namespace gpatlas_ros
