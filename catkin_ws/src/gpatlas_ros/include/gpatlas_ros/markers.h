#pragma once

// rviz markers for the model, the atlas and the collision map (pure functions).

#include <gpatlas_core/planning/atlas.h>
#include <gpatlas_core/common/triangle_mesh.h>
#include <gpatlas_motion/arm.h>

#include <visualization_msgs/Marker.h>
#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <vector>

namespace gpatlas_ros {

// Triangle list with per-vertex colours from the vertex variances (blue low, red >= v_max).
visualization_msgs::Marker meshMarker(const gpatlas_core::TriangleMesh& mesh, double v_max, const std::string& frame);
// The probe's planned approach: its tip's path as a green line.
visualization_msgs::Marker approachMarker(const std::vector<gpatlas_core::Vector3>& tip_path, const std::string& frame);
// The segmented objects' axis-aligned bounding boxes as lines: the explored one (cluster
// `explored`) green in namespace explored_object, the others orange in other_objects.
visualization_msgs::MarkerArray objectBoxMarkers(const std::vector<std::vector<gpatlas_core::Vector3>>& clusters,
                                                 std::size_t explored, const std::string& frame);
// The arm along a planned joint path: its links' axes at configurations sampled along it (one
// list of link capsules each), in a colour that goes from the start's to the end's.
visualization_msgs::Marker armTrailMarker(const std::vector<std::vector<gpatlas_motion::LinkCapsule>>& link_poses,
                                          const std::string& frame);

// What a latched marker topic says after a reset: rviz drops every marker it showed from it.
visualization_msgs::Marker deleteAllMarker(const std::string& frame);
visualization_msgs::MarkerArray deleteAllMarkers(const std::string& frame);

// Chart disks (coloured by variance), tree edges, and the chosen path (thick, yellow).
visualization_msgs::MarkerArray atlasMarkers(const gpatlas_core::Atlas& atlas, const std::vector<int>& path,
                                             double v_max, const std::string& frame);

}  // namespace gpatlas_ros
