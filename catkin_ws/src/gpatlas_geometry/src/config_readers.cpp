#include "gpatlas_geometry/config_readers.h"

namespace gpatlas_geometry {

using gpatlas_core::ParamReader;

void readMesher(ParamReader& r, SurfaceMesher::Config* c) {
  c->resolution_m = r.number("mesh/resolution_m", c->resolution_m, 1e-4, 1.0);
}

void readSegmenter(ParamReader& r, ObjectSegmenter::Config* c) {
  c->crop_min_m = r.vector3("segmentation/crop_min_m", c->crop_min_m);
  c->crop_max_m = r.vector3("segmentation/crop_max_m", c->crop_max_m);
  c->voxel_leaf_m = r.optionalNumber("segmentation/voxel_leaf_m", c->voxel_leaf_m, 1.0);
  c->remove_plane = r.flag("segmentation/remove_plane", c->remove_plane);
  c->plane_distance_m = r.number("segmentation/plane_distance_m", c->plane_distance_m, 1e-5, 1.0);
  c->cluster_tolerance_m = r.number("segmentation/cluster_tolerance_m", c->cluster_tolerance_m, 1e-5, 1.0);
  c->cluster_min_points = static_cast<std::size_t>(
      r.integer("segmentation/cluster_min_points", static_cast<int>(c->cluster_min_points), 1, 100000000));
  // An empty list: the largest cluster; [x, y, z]: the cluster closest to that point.
  const std::vector<double> hint = r.numbers("segmentation/object_hint_m", {});
  if (hint.size() == 3) c->object_hint_m = Vector3(hint[0], hint[1], hint[2]);
  else if (!hint.empty()) r.invalid("segmentation/object_hint_m", "must be [] or a list of 3 numbers");
  c->select_max_distance_m = r.number("segmentation/select_max_distance_m", c->select_max_distance_m, 1e-4, 1.0);
}

}  // namespace gpatlas_geometry
