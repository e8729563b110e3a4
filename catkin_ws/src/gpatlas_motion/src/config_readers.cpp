#include "gpatlas_motion/config_readers.h"

namespace gpatlas_motion {

void readApproach(gpatlas_core::ParamReader& r, ApproachConfig* c) {
  c->enabled = r.flag("approach/enabled", c->enabled);
  c->rest_tip_position_m = r.vector3("approach/rest_tip_position_m", c->rest_tip_position_m);
  c->occupied_probability = r.number("approach/occupied_probability", c->occupied_probability, 1e-6, 1.0 - 1e-6);
  c->approach_distance_m = r.number("approach/approach_distance_m", c->approach_distance_m, 1e-3, 1.0);
  c->clearance_m = r.number("approach/clearance_m", c->clearance_m, 0.0, 0.5);
  c->max_planning_time_s = r.number("approach/max_planning_time_s", c->max_planning_time_s, 1e-3, 60.0);
  c->max_tilt_deg = r.number("approach/max_tilt_deg", c->max_tilt_deg, 0.0, 89.0);
  c->probe.tip_radius_m = r.number("approach/tip_radius_m", c->probe.tip_radius_m, 1e-4, 0.5);
  c->probe.shaft_radius_m = r.number("approach/shaft_radius_m", c->probe.shaft_radius_m, 1e-4, 0.5);
  c->probe.shaft_length_m = r.number("approach/shaft_length_m", c->probe.shaft_length_m, 1e-4, 2.0);
  c->use_arm = r.flag("approach/use_arm", c->use_arm);
  c->arm_base_link = r.text("approach/arm_base_link", c->arm_base_link);
  c->arm_tip_link = r.text("approach/arm_tip_link", c->arm_tip_link);
  c->arm_link_radius_m = r.number("approach/arm_link_radius_m", c->arm_link_radius_m, 1e-3, 0.5);
  c->arm_joint_speed_rad_s = r.number("approach/arm_joint_speed_rad_s", c->arm_joint_speed_rad_s, 1e-3, 10.0);
}

void readSceneMap(gpatlas_core::ParamReader& r, SceneMapConfig* c) {
  c->enabled = r.flag("collision_map/scene_enabled", c->enabled);
  c->min_corner_m = r.vector3("collision_map/scene_min_corner_m", c->min_corner_m);
  c->max_corner_m = r.vector3("collision_map/scene_max_corner_m", c->max_corner_m);
  c->max_range_m = r.number("collision_map/scene_max_range_m", c->max_range_m, 0.05, 100.0);
  c->hit_probability = r.number("collision_map/scene_hit_probability", c->hit_probability, 0.51, 0.999);
  c->miss_probability = r.number("collision_map/scene_miss_probability", c->miss_probability, 0.001, 0.49);
  c->object_margin_m = r.number("collision_map/scene_object_margin_m", c->object_margin_m, 0.0, 0.5);
  c->shadow_depth_m = r.number("collision_map/scene_shadow_depth_m", c->shadow_depth_m, 0.0, 1.0);
  c->unseen_reach_m = r.number("collision_map/scene_unseen_reach_m", c->unseen_reach_m, 0.0, 1.0);
}

}  // namespace gpatlas_motion
