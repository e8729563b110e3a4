#include "gpatlas_conversions/conversions.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

using namespace gpatlas_conversions;

namespace {

TEST(Conversions, TouchRoundTrip) {
  gpatlas_core::Touch touch;
  touch.kind = gpatlas_core::Touch::Kind::kSlide;
  touch.points = {{0.1, 0.2, 0.3}, {-1.0, 2.5, 1e-3}};
  touch.normals = {{0.0, 0.0, 1.0}, {1.0, 0.0, 0.0}};
  touch.variances = {0.05, 0.3};
  touch.strategy = "atlas_slide";
  touch.approach_path = {{0.5, 0.25, 0.4}, {0.3, 0.2, 0.3}, {0.2, 0.2, 0.3}};
  touch.retreat_path = {{-0.9, 2.5, 0.0}, {0.5, 0.25, 0.4}};
  gpatlas_core::Touch back;
  std::string error;
  ASSERT_TRUE(fromMsg(toMsg(touch), &back, &error)) << error;
  EXPECT_EQ(back.kind, touch.kind);
  ASSERT_EQ(back.points.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back.points[i], touch.points[i]);
    EXPECT_EQ(back.normals[i], touch.normals[i]);
    EXPECT_EQ(back.variances[i], touch.variances[i]);
  }
  EXPECT_EQ(back.strategy, "atlas_slide");
  EXPECT_FALSE(back.explores_unknown);
  EXPECT_EQ(back.approach_path, touch.approach_path);
  EXPECT_EQ(back.retreat_path, touch.retreat_path);
  touch.explores_unknown = true;
  ASSERT_TRUE(fromMsg(toMsg(touch), &back, &error)) << error;
  EXPECT_TRUE(back.explores_unknown);
}

TEST(Conversions, TouchJointTrajectoriesRoundTripByName) {
  gpatlas_core::Touch touch;
  touch.points = {{0.1, 0.2, 0.3}};
  touch.normals = {{0.0, 0.0, 1.0}};
  Eigen::VectorXd rest(3), above(3);
  rest << 0.1, -0.2, 0.3;
  above << 0.5, -0.2, 1.3;
  touch.approach_joints = {rest, above};
  touch.retreat_joints = {above, rest};
  const std::vector<std::string> names = {"a1", "a2", "a3"};
  const gpatlas_msgs::Touch msg = toMsg(touch, names, 0.5);
  ASSERT_EQ(msg.approach_trajectory.joint_names, names);
  ASSERT_EQ(msg.approach_trajectory.points.size(), 2u);
  // The slowest joint (a3: 1 rad) at 0.5 rad/s takes 2 s.
  EXPECT_DOUBLE_EQ(msg.approach_trajectory.points[0].time_from_start.toSec(), 0.0);
  EXPECT_NEAR(msg.approach_trajectory.points[1].time_from_start.toSec(), 2.0, 1e-9);

  gpatlas_core::Touch back;
  std::string error;
  ASSERT_TRUE(fromMsg(msg, &back, &error, &names)) << error;
  EXPECT_EQ(back.approach_joints, touch.approach_joints);
  EXPECT_EQ(back.retreat_joints, touch.retreat_joints);
  // Without names the trajectories are not read.
  ASSERT_TRUE(fromMsg(msg, &back, &error)) << error;
  EXPECT_TRUE(back.approach_joints.empty());

  // A receiver whose chain lists the joints in another order gets them in its own.
  const std::vector<std::string> reversed = {"a3", "a2", "a1"};
  std::vector<Eigen::VectorXd> path;
  ASSERT_TRUE(fromJointTrajectoryMsg(msg.approach_trajectory, reversed, &path, &error)) << error;
  ASSERT_EQ(path.size(), 2u);
  EXPECT_EQ(path[1], Eigen::Vector3d(1.3, -0.2, 0.5));

  const std::vector<std::string> other = {"a1", "a2", "b3"};
  EXPECT_FALSE(fromMsg(msg, &back, &error, &other));
  EXPECT_NE(error.find("'b3'"), std::string::npos) << error;
  gpatlas_msgs::Touch short_point = msg;
  short_point.approach_trajectory.points[1].positions.pop_back();
  EXPECT_FALSE(fromMsg(short_point, &back, &error, &names));
  EXPECT_NE(error.find("positions"), std::string::npos) << error;
  EXPECT_THROW(toMsg(touch, {"a1"}, 0.5), std::invalid_argument);
  EXPECT_THROW(toMsg(touch, names, 0.0), std::invalid_argument);
}

TEST(Conversions, MalformedTouchIsRefused) {
  gpatlas_msgs::Touch msg;
  msg.points.resize(2);
  msg.normals.resize(1);
  gpatlas_core::Touch touch;
  std::string error;
  EXPECT_FALSE(fromMsg(msg, &touch, &error));
  EXPECT_NE(error.find("normals"), std::string::npos);
  msg.normals.resize(2);
  msg.kind = 7;
  EXPECT_FALSE(fromMsg(msg, &touch, &error));
}

TEST(Conversions, SupportPlaneRoundTripAndNormalisation) {
  gpatlas_core::SupportPlane plane;
  plane.normal = Eigen::Vector3d(0.1, -0.2, 0.9).normalized();
  plane.offset = -0.73;
  const gpatlas_msgs::SupportPlane msg = gpatlas_conversions::toMsg(plane, "world");
  EXPECT_EQ(msg.header.frame_id, "world");
  gpatlas_core::SupportPlane back;
  std::string error;
  ASSERT_TRUE(gpatlas_conversions::fromMsg(msg, &back, &error)) << error;
  EXPECT_NEAR((back.normal - plane.normal).norm(), 0.0, 1e-15);
  EXPECT_DOUBLE_EQ(back.offset, plane.offset);
  // A non-unit normal describes the same plane: same heights after normalisation.
  gpatlas_msgs::SupportPlane scaled = msg;
  scaled.normal.x *= 3.0;
  scaled.normal.y *= 3.0;
  scaled.normal.z *= 3.0;
  scaled.offset *= 3.0;
  ASSERT_TRUE(gpatlas_conversions::fromMsg(scaled, &back, &error)) << error;
  const Eigen::Vector3d x(0.3, 0.4, -0.5);
  EXPECT_NEAR(back.height(x), plane.height(x), 1e-12);
  gpatlas_msgs::SupportPlane zero = msg;
  zero.normal.x = zero.normal.y = zero.normal.z = 0.0;
  EXPECT_FALSE(gpatlas_conversions::fromMsg(zero, &back, &error));
  EXPECT_FALSE(error.empty());
}

TEST(Conversions, APlaneMovedToAnotherFrameKeepsEveryPointsHeight) {
  gpatlas_core::SupportPlane plane;
  plane.normal = Eigen::Vector3d(0.3, 0.1, -0.9).normalized();
  plane.offset = 0.4;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, -2.0, 0.5).normalized()).toRotationMatrix();
  pose.translation() = Eigen::Vector3d(0.2, -1.1, 0.6);
  const gpatlas_core::SupportPlane moved = gpatlas_conversions::transformPlane(plane, pose);
  EXPECT_NEAR(moved.normal.norm(), 1.0, 1e-12);
  // Any point's signed height above the plane is the same in both frames.
  for (const Eigen::Vector3d x : {Eigen::Vector3d(0.0, 0.0, 0.0), Eigen::Vector3d(1.0, 2.0, -3.0),
                                  Eigen::Vector3d(-0.4, 0.25, 0.9)})
    EXPECT_NEAR(moved.height(pose * x), plane.height(x), 1e-12);
}

TEST(Conversions, ObservationsRoundTrip) {
  gpatlas_core::ProbeResult result;
  result.contacts.push_back({{1, 2, 3}, {0, 0, 1}});
  result.contacts.push_back({{4, 5, 6}, {0, 1, 0}});
  result.free_space = {{7, 8, 9}};
  gpatlas_core::ProbeResult back;
  std::string error;
  ASSERT_TRUE(fromMsg(toMsg(result), &back, &error)) << error;
  ASSERT_EQ(back.contacts.size(), 2u);
  EXPECT_EQ(back.contacts[1].position, result.contacts[1].position);
  EXPECT_EQ(back.contacts[1].normal, result.contacts[1].normal);
  ASSERT_EQ(back.free_space.size(), 1u);
  EXPECT_EQ(back.free_space[0], result.free_space[0]);
  EXPECT_TRUE(back.pads.empty());

  // A tactile pad's press.
  gpatlas_core::PadPress pad;
  pad.centre = {0.7, -0.02, 0.11};
  pad.orientation = Eigen::Quaterniond(Eigen::AngleAxisd(0.4, Eigen::Vector3d(1.0, 2.0, -1.0).normalized()));
  pad.size_m = 0.02;
  result.pads = {pad, pad};
  result.pads[1].size_m = 0.015;
  ASSERT_TRUE(fromMsg(toMsg(result), &back, &error)) << error;
  ASSERT_EQ(back.pads.size(), 2u);
  EXPECT_EQ(back.pads[0].centre, pad.centre);
  EXPECT_LT(back.pads[0].orientation.angularDistance(pad.orientation), 1e-12);
  EXPECT_EQ(back.pads[1].size_m, 0.015);
  // Mismatched or invalid pads are refused with a reason.
  gpatlas_msgs::Observations bad = toMsg(result);
  bad.pad_sizes_m.pop_back();
  EXPECT_FALSE(fromMsg(bad, &back, &error));
  EXPECT_NE(error.find("pad"), std::string::npos) << error;
  bad = toMsg(result);
  bad.pad_poses[0].orientation.w = 0.0;
  bad.pad_poses[0].orientation.x = 0.0;
  bad.pad_poses[0].orientation.y = 0.0;
  bad.pad_poses[0].orientation.z = 0.0;
  EXPECT_FALSE(fromMsg(bad, &back, &error));
  bad = toMsg(result);
  bad.pad_sizes_m[1] = -1.0;
  EXPECT_FALSE(fromMsg(bad, &back, &error));
}

TEST(Conversions, TrainingSetRebuildsTheSameModel) {
  std::mt19937 rng(1);
  std::normal_distribution<double> g;
  std::vector<gpatlas_core::TrainingPoint> pts;
  for (int i = 0; i < 60; ++i) {
    Eigen::Vector3d d(g(rng), g(rng), std::abs(g(rng)));
    gpatlas_core::TrainingPoint p;
    p.position = 0.1 * d.normalized();
    p.noise_sigma = 0.05;
    p.source = i % 2 ? gpatlas_core::PointSource::kTouch : gpatlas_core::PointSource::kVision;
    // How far the contacts lay from the prediction (the evidence rule reads it): must survive the trip.
    if (i % 2) p.prediction_error_m = 0.001 * i;
    pts.push_back(p);
  }
  gpatlas_core::TrainingPoint outside;
  outside.position = {0, 0, 0.15};
  outside.label = gpatlas_core::PointLabel::kOutside;
  outside.source = gpatlas_core::PointSource::kFreeSpace;
  outside.noise_sigma = 0.2;
  outside.surface_distance_m = 0.04;  // its target follows the frame: must survive the trip
  pts.push_back(outside);
  gpatlas_core::TrainingPoint table = outside;  // the table seen beside the object
  table.position = {0.12, 0.0, -0.09};
  table.source = gpatlas_core::PointSource::kViewSupport;
  pts.push_back(table);
  // A contact's tangent slope (f does not change across the normal): direction and target.
  gpatlas_core::TrainingPoint tangent = pts.front();
  tangent.slope_direction = Eigen::Vector3d(0.3, -0.2, 0.1).cross(tangent.position).normalized();
  tangent.target_override = 0.0;
  pts.push_back(tangent);
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(pts).ok);
  ASSERT_TRUE(gpatlas_core::observesSlope(model.observations().back()));
  // Hyperparameters away from the defaults (as tuning leaves them): the replica must take the sender's.
  const Eigen::VectorXd tuned = model.hyperparameters().array() + 0.1;
  ASSERT_TRUE(model.setHyperparameters(tuned).ok);
  model.setPositionSdScale(0.05);  // as a calibration leaves it

  gpatlas_core::SurfaceModelState contents;
  std::string error;
  ASSERT_TRUE(fromMsg(toMsg(model), &contents, &error)) << error;
  EXPECT_EQ(contents.model, model.name());
  ASSERT_EQ(contents.observations.size(), model.observations().size());
  for (std::size_t i = 0; i < contents.observations.size(); ++i) {
    EXPECT_EQ(contents.observations[i].position, model.observations()[i].position);
    EXPECT_EQ(contents.observations[i].label, model.observations()[i].label);
    EXPECT_EQ(contents.observations[i].source, model.observations()[i].source);
    EXPECT_EQ(contents.observations[i].noise_sigma, model.observations()[i].noise_sigma);
    const double a = contents.observations[i].surface_distance_m, b = model.observations()[i].surface_distance_m;
    EXPECT_TRUE(a == b || (std::isnan(a) && std::isnan(b)));
    EXPECT_EQ(contents.observations[i].slope_direction, model.observations()[i].slope_direction);
    const double c = contents.observations[i].target_override, d = model.observations()[i].target_override;
    EXPECT_TRUE(c == d || (std::isnan(c) && std::isnan(d)));
    const double e = contents.observations[i].prediction_error_m, f = model.observations()[i].prediction_error_m;
    EXPECT_TRUE(e == f || (std::isnan(e) && std::isnan(f)));
    EXPECT_EQ(std::isfinite(f), model.observations()[i].source == gpatlas_core::PointSource::kTouch &&
                                    !gpatlas_core::observesSlope(model.observations()[i]));
  }
  EXPECT_EQ(contents.centroid, model.centroid());
  EXPECT_EQ(contents.scale, model.scale());
  EXPECT_EQ(contents.position_sd_scale, model.positionSdScale());
  std::unique_ptr<gpatlas_core::SurfaceModel> rebuilt_model;
  ASSERT_TRUE(modelFromMsg(toMsg(model), gpatlas_core::SurfaceModelConfig(), &rebuilt_model, &error)) << error;
  const gpatlas_core::SurfaceModel& rebuilt = *rebuilt_model;
  EXPECT_LT((rebuilt.hyperparameters() - tuned).norm(), 1e-12);
  EXPECT_EQ(rebuilt.positionSdScale(), model.positionSdScale());
  const Eigen::Vector3d q(0.02, -0.03, 0.08);
  EXPECT_NEAR(rebuilt.mean(q), model.mean(q), 1e-12);
  EXPECT_NEAR(rebuilt.variance(q), model.variance(q), 1e-12);
  EXPECT_LT((rebuilt.predict(q).gradient - model.predict(q).gradient).norm(), 1e-9);
  // A source this build does not know is refused.
  gpatlas_msgs::TrainingSet unknown = toMsg(model);
  unknown.sources.back() = 5;
  EXPECT_FALSE(fromMsg(unknown, &contents, &error));
  // Without the slope the replica would differ: the check above can fail.
  pts.pop_back();
  gpatlas_core::GpisModel without_slope;
  ASSERT_TRUE(without_slope.fitInFrame(pts, model.centroid(), model.scale()).ok);
  EXPECT_GT(std::abs(without_slope.mean(q) - model.mean(q)) + std::abs(without_slope.variance(q) - model.variance(q)),
            1e-6);
}

// The camera view travels with the training set, to float precision; none stays none.
TEST(Conversions, TrainingSetCarriesTheCameraView) {
  gpatlas_core::CameraView view;
  view.origin = {0.1, -0.6, 0.9};
  view.points = {{0.7, 0.05, 0.12}, {0.71, -0.02, 0.1}, {0.69, 0.0, 0.15}};
  gpatlas_msgs::TrainingSet msg;
  setView(view, &msg);
  std::optional<gpatlas_core::CameraView> back;
  std::string error;
  ASSERT_TRUE(viewFromMsg(msg, &back, &error)) << error;
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(back->origin, view.origin);
  ASSERT_EQ(back->points.size(), view.points.size());
  for (std::size_t i = 0; i < view.points.size(); ++i) EXPECT_LT((back->points[i] - view.points[i]).norm(), 1e-7);

  setView(std::nullopt, &msg);
  EXPECT_TRUE(msg.view_points.empty());
  ASSERT_TRUE(viewFromMsg(msg, &back, &error)) << error;
  EXPECT_FALSE(back.has_value());

  setView(view, &msg);
  msg.view_origin.y = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(viewFromMsg(msg, &back, &error));
  EXPECT_FALSE(back.has_value());
  EXPECT_NE(error.find("camera view"), std::string::npos) << error;
}

TEST(Conversions, CloudRoundTripSkipsNaN) {
  std::vector<Eigen::Vector3d> pts = {{0.5, 0.25, -0.125}, {1, 2, 3}, {std::nan(""), 0, 0}};
  const auto cloud = pointsToCloud(pts, {0.0, 0.2, 0.1}, 0.2, "world");
  EXPECT_EQ(cloud.header.frame_id, "world");
  std::vector<Eigen::Vector3d> back;
  std::size_t invalid = 0;
  std::string error;
  ASSERT_TRUE(cloudToPoints(cloud, &back, &invalid, &error)) << error;
  EXPECT_EQ(invalid, 1u);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0], pts[0]);  // exactly representable in float32
  EXPECT_EQ(back[1], pts[1]);
}

TEST(Conversions, CloudWithoutXyzIsRefused) {
  sensor_msgs::PointCloud2 cloud;
  cloud.width = 3;
  cloud.height = 1;
  std::vector<Eigen::Vector3d> back;
  std::size_t invalid = 0;
  std::string error;
  EXPECT_FALSE(cloudToPoints(cloud, &back, &invalid, &error));
  EXPECT_NE(error.find("x, y, z"), std::string::npos);
}

TEST(Conversions, MalformedCloudsAreRefusedBeforeAnyRead) {
  std::vector<Eigen::Vector3d> pts = {{1, 2, 3}, {4, 5, 6}};
  std::vector<Eigen::Vector3d> back;
  std::size_t invalid = 0;
  std::string error;
  auto narrow = pointsToCloud(pts, {}, 1.0, "world");
  narrow.point_step = 4;  // z (offset 8) no longer fits in a point
  EXPECT_FALSE(cloudToPoints(narrow, &back, &invalid, &error));
  EXPECT_NE(error.find("point_step"), std::string::npos) << error;
  auto padded = pointsToCloud(pts, {}, 1.0, "world");
  padded.height = 2;
  padded.width = 1;
  padded.row_step = padded.point_step + 8;
  padded.data.resize(2 * padded.row_step);
  EXPECT_FALSE(cloudToPoints(padded, &back, &invalid, &error));
  EXPECT_NE(error.find("padded"), std::string::npos) << error;
  auto short_data = pointsToCloud(pts, {}, 1.0, "world");
  short_data.data.resize(short_data.point_step);
  EXPECT_FALSE(cloudToPoints(short_data, &back, &invalid, &error));
}

TEST(Conversions, VarianceColourGoesFromBlueToRed) {
  float r, g, b;
  varianceColour(0.0, 0.1, &r, &g, &b);
  EXPECT_FLOAT_EQ(b, 1.0f);
  EXPECT_FLOAT_EQ(r, 0.0f);
  varianceColour(0.5, 0.1, &r, &g, &b);
  EXPECT_FLOAT_EQ(r, 1.0f);
  EXPECT_FLOAT_EQ(b, 0.0f);
  varianceColour(std::numeric_limits<double>::quiet_NaN(), 0.1, &r, &g, &b);
  EXPECT_FLOAT_EQ(r, 1.0f);
}

// The plan request of next_touch: everything the loop fills travels (the reachable test and the
// support plane are the planner nodelet's own).
TEST(Conversions, PlanRequestRoundTrip) {
  gpatlas_core::PlanRequest request;
  request.v_max = 0.05;
  request.start = gpatlas_core::Vector3(0.4, -0.1, 0.2);
  request.evidence_state.attempted_targets = {{0.1, 0.2, 0.3}, {0.5, 0.0, -0.25}};
  request.evidence_state.attempted_target_errors_m = {0.004, std::numeric_limits<double>::quiet_NaN()};
  request.evidence_state.empty_unknown_pokes = 3;
  request.footprint_radius_m = 0.01;
  request.seed = 0x9e3779b97f4a7c15ull;
  const gpatlas_msgs::GetNextTouch::Request msg = toMsg(request);
  EXPECT_TRUE(msg.use_start);
  // The node's own values, which no field of this request asks for.
  const gpatlas_conversions::NodePlanDefaults node{0.3, 0.007, 12345};
  const gpatlas_core::PlanRequest back = fromMsg(msg, node);
  EXPECT_EQ(back.v_max, request.v_max);
  ASSERT_TRUE(back.start.has_value());
  EXPECT_EQ(*back.start, *request.start);
  EXPECT_EQ(back.evidence_state.attempted_targets, request.evidence_state.attempted_targets);
  ASSERT_EQ(back.evidence_state.attempted_target_errors_m.size(), 2u);
  EXPECT_EQ(back.evidence_state.attempted_target_errors_m[0], 0.004);
  EXPECT_TRUE(std::isnan(back.evidence_state.attempted_target_errors_m[1]));
  EXPECT_EQ(back.evidence_state.empty_unknown_pokes, 3);
  EXPECT_EQ(back.footprint_radius_m, request.footprint_radius_m);
  EXPECT_EQ(back.seed, request.seed);
  // The stop rule travels: the V_max rule alone (no bound) is said by its own constant, not by
  // the node's parameter, and a bound travels as itself.
  EXPECT_EQ(msg.stop_rule, gpatlas_msgs::GetNextTouch::Request::STOP_RULE_V_MAX_ONLY);
  EXPECT_FALSE(back.max_position_sd_m.has_value());
  request.max_position_sd_m = 0.004;
  EXPECT_EQ(toMsg(request).stop_rule, gpatlas_msgs::GetNextTouch::Request::STOP_RULE_POSITION_SD);
  EXPECT_EQ(fromMsg(toMsg(request), node).max_position_sd_m, std::optional<double>(0.004));
  // A seed of 0 is a seed like any other.
  request.seed = 0;
  EXPECT_EQ(fromMsg(toMsg(request), node).seed, 0u);

  request.start.reset();
  EXPECT_FALSE(toMsg(request).use_start);
  EXPECT_FALSE(fromMsg(toMsg(request), node).start.has_value());
}

// What a request leaves to the node (an empty request: every one) comes from the node's values,
// and a request's own values override them one by one.
TEST(Conversions, PlanRequestLeavesToTheNode) {
  const gpatlas_conversions::NodePlanDefaults node{0.3, 0.007, 12345};
  gpatlas_msgs::GetNextTouch::Request msg;
  msg.v_max = 0.02;             // not used without use_v_max
  msg.max_position_sd_m = 0.5;  // not used with STOP_RULE_PARAMETER
  msg.seed = 9;                 // not used without use_seed
  gpatlas_core::PlanRequest request = fromMsg(msg, node);
  EXPECT_EQ(request.v_max, 0.3);
  EXPECT_EQ(request.max_position_sd_m, std::optional<double>(0.007));
  EXPECT_EQ(request.seed, 12345u);
  msg.use_v_max = true;
  msg.use_seed = true;
  msg.stop_rule = gpatlas_msgs::GetNextTouch::Request::STOP_RULE_POSITION_SD;
  request = fromMsg(msg, node);
  EXPECT_EQ(request.v_max, 0.02);
  EXPECT_EQ(request.max_position_sd_m, std::optional<double>(0.5));
  EXPECT_EQ(request.seed, 9u);
  msg.stop_rule = gpatlas_msgs::GetNextTouch::Request::STOP_RULE_V_MAX_ONLY;
  EXPECT_FALSE(fromMsg(msg, node).max_position_sd_m.has_value());
  // A node whose own rule is V_max alone passes that on.
  msg.stop_rule = gpatlas_msgs::GetNextTouch::Request::STOP_RULE_PARAMETER;
  EXPECT_FALSE(fromMsg(msg, {0.3, std::nullopt, 1}).max_position_sd_m.has_value());
}

// The planner's answer, for every status: the cap reached stays the cap reached (the exploration
// then stops as planner_cap_reached, as the bench's does), not an error.
TEST(Conversions, PlanResultRoundTripForEveryStatus) {
  using gpatlas_core::PlanStatus;
  for (const PlanStatus status : {PlanStatus::kTouch, PlanStatus::kConverged, PlanStatus::kCapReached, PlanStatus::kError}) {
    SCOPED_TRACE(gpatlas_core::toString(status));
    gpatlas_core::PlanResult result;
    result.status = status;
    result.message = "why";
    result.max_evaluated_variance = 0.25;
    result.elapsed_s = 1.5;
    result.unreachable_candidates = 7;
    result.unreachable_area_fraction = 0.125;
    result.budget_exhausted = status != PlanStatus::kConverged;
    if (status == PlanStatus::kTouch) {
      result.touch.kind = gpatlas_core::Touch::Kind::kSlide;
      result.touch.points = {{0.1, 0.2, 0.3}, {0.1, 0.25, 0.3}};
      result.touch.normals = {{0.0, 0.0, 1.0}, {0.0, 1.0, 0.0}};
      result.touch.variances = {0.3, 0.4};
      result.touch.strategy = "atlas_slide";
    }
    const gpatlas_msgs::GetNextTouch::Response msg = toMsg(result);
    const gpatlas_core::PlanResult back = fromMsg(msg);
    EXPECT_EQ(back.status, status);
    EXPECT_EQ(back.message, "why");
    EXPECT_EQ(back.max_evaluated_variance, 0.25);
    EXPECT_EQ(back.elapsed_s, 1.5);
    EXPECT_EQ(back.unreachable_candidates, 7);
    EXPECT_EQ(back.unreachable_area_fraction, 0.125);
    EXPECT_EQ(back.budget_exhausted, status != PlanStatus::kConverged);
    EXPECT_EQ(back.touch.points, result.touch.points);
    EXPECT_EQ(back.touch.normals, result.touch.normals);
    EXPECT_EQ(back.touch.variances, result.touch.variances);
    EXPECT_EQ(back.touch.kind, result.touch.kind);
  }
  gpatlas_core::PlanResult capped;
  capped.status = PlanStatus::kCapReached;
  EXPECT_EQ(toMsg(capped).status, gpatlas_msgs::GetNextTouch::Response::CAP_REACHED);
}

// The nodelet's own answers (no model, a stale one) and a malformed touch are errors to the loop.
TEST(Conversions, PlanAnswersWithoutAPlanAreErrors) {
  gpatlas_msgs::GetNextTouch::Response msg;
  const std::vector<std::uint8_t> statuses{gpatlas_msgs::GetNextTouch::Response::NO_MODEL,
                                           gpatlas_msgs::GetNextTouch::Response::STALE_MODEL, 200};
  for (const std::uint8_t status : statuses) {
    msg.status = status;
    msg.message = "no";
    const gpatlas_core::PlanResult result = fromMsg(msg);
    EXPECT_EQ(result.status, gpatlas_core::PlanStatus::kError) << int(status);
    EXPECT_EQ(result.message, "no");
  }
  msg.status = gpatlas_msgs::GetNextTouch::Response::TOUCH;
  msg.touch.points.resize(2);
  msg.touch.normals.resize(1);
  const gpatlas_core::PlanResult malformed = fromMsg(msg);
  EXPECT_EQ(malformed.status, gpatlas_core::PlanStatus::kError);
  EXPECT_NE(malformed.message.find("malformed touch"), std::string::npos) << malformed.message;
}

TEST(Conversions, AtlasKeepsItsChartsAndPath) {
  gpatlas_core::Atlas atlas;
  gpatlas_core::Chart root;
  root.centre = {0.1, 0.2, 0.3};
  root.normal = {0.0, 0.0, 1.0};
  root.radius = 0.02;
  root.variance = 0.05;
  gpatlas_core::Chart child = root;
  child.centre = {0.12, 0.2, 0.3};
  child.normal = {0.0, 1.0, 0.0};
  child.radius = 0.01;
  child.variance = 0.3;
  child.parent = 0;
  atlas.addChart(root);
  atlas.addChart(child);
  const gpatlas_msgs::Atlas msg = toMsg(atlas, {0, 1});
  ASSERT_EQ(msg.charts.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const gpatlas_core::Chart& chart = atlas.chart(static_cast<int>(i));
    EXPECT_EQ(fromMsg(msg.charts[i].centre), chart.centre);
    EXPECT_EQ(fromMsg(msg.charts[i].normal), chart.normal);
    EXPECT_EQ(msg.charts[i].radius_m, chart.radius);
    EXPECT_EQ(msg.charts[i].variance, chart.variance);
    EXPECT_EQ(msg.charts[i].parent, chart.parent);
  }
  EXPECT_EQ(msg.path, (std::vector<int>{0, 1}));
}

TEST(Conversions, ProbeAnswerRoundTrip) {
  gpatlas_core::ProbeResult result;
  result.success = true;
  result.reason = "pressed";
  result.contacts = {{{0.1, 0.2, 0.3}, {0.0, 0.0, 1.0}}, {{0.1, 0.21, 0.3}, {0.0, 1.0, 0.0}}};
  result.free_space = {{0.1, 0.2, 0.35}};
  result.approach_collisions = 2;
  result.retreat_collisions = 1;
  const gpatlas_core::ProbeResult back = fromMsg(toProbeResponseMsg(result));
  EXPECT_TRUE(back.success);
  EXPECT_EQ(back.reason, "pressed");
  ASSERT_EQ(back.contacts.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back.contacts[i].position, result.contacts[i].position);
    EXPECT_EQ(back.contacts[i].normal, result.contacts[i].normal);
  }
  EXPECT_EQ(back.free_space, result.free_space);
  EXPECT_EQ(back.approach_collisions, 2);
  EXPECT_EQ(back.retreat_collisions, 1);

  gpatlas_msgs::Probe::Response malformed = toProbeResponseMsg(result);
  malformed.observations.contact_normals.pop_back();
  const gpatlas_core::ProbeResult refused = fromMsg(malformed);
  EXPECT_FALSE(refused.success);
  EXPECT_TRUE(refused.contacts.empty());
  EXPECT_NE(refused.reason.find("malformed observations"), std::string::npos) << refused.reason;
}

// The counts the loop records travel as the model counted them: free space is its own count, not
// every point but the contacts (points behind contacts and slopes are neither).
TEST(Conversions, TouchUpdateRoundTrip) {
  gpatlas_core::TouchUpdate update;
  update.ok = true;
  update.message = "added";
  update.contacts_added = 3;
  update.contact_positions = {{0.5, -0.1, 0.2}, {0.51, -0.1, 0.2}, {0.5, -0.09, 0.21}};
  update.free_points_added = 5;
  update.points_added = 11;
  update.contacts_refused.outside_workspace = 2;
  update.free_space_refused.non_finite = 1;
  update.budget_full = true;
  const gpatlas_msgs::AddObservations::Response msg = toMsg(update);
  EXPECT_EQ(msg.num_refused, 3u);
  const gpatlas_core::TouchUpdate back = fromMsg(msg);
  EXPECT_TRUE(back.ok);
  EXPECT_EQ(back.message, "added");
  EXPECT_EQ(back.contacts_added, 3);
  EXPECT_EQ(back.contact_positions, update.contact_positions);
  EXPECT_EQ(back.free_points_added, 5);
  EXPECT_EQ(back.points_added, 11);
  EXPECT_TRUE(back.budget_full);
}

TEST(Conversions, ApproachAnswerGivesThePathsAndTheArmsJointPaths) {
  gpatlas_msgs::PlanApproach::Response msg;
  msg.success = true;
  msg.message = "planned";
  msg.planning_time_s = 0.25;
  const std::vector<Eigen::Vector3d> there{{0.5, 0.0, 0.5}, {0.3, 0.0, 0.4}}, back{{0.3, 0.0, 0.4}, {0.5, 0.0, 0.5}};
  for (const auto& p : there) msg.approach.push_back(toPointMsg(p));
  for (const auto& p : back) msg.retreat.push_back(toPointMsg(p));
  Eigen::VectorXd rest(2), above(2);
  rest << 0.1, -0.2;
  above << 0.4, 0.3;
  const std::vector<std::string> names{"shoulder", "elbow"};
  msg.approach_trajectory = toJointTrajectoryMsg({rest, above}, names, 0.5);
  msg.retreat_trajectory = toJointTrajectoryMsg({above, rest}, names, 0.5);
  gpatlas_core::ApproachResult result;
  std::vector<std::string> joint_names;
  std::string error;
  ASSERT_TRUE(fromMsg(msg, &result, &joint_names, &error)) << error;
  EXPECT_TRUE(result.ok);
  EXPECT_EQ(result.message, "planned");
  EXPECT_DOUBLE_EQ(result.planning_ms, 250.0);
  EXPECT_EQ(result.approach_path, there);
  EXPECT_EQ(result.retreat_path, back);
  EXPECT_EQ(result.approach_joints, (std::vector<Eigen::VectorXd>{rest, above}));
  EXPECT_EQ(result.retreat_joints, (std::vector<Eigen::VectorXd>{above, rest}));
  EXPECT_EQ(joint_names, names);
  EXPECT_FALSE(result.guarded_entry);
  msg.guarded_entry = true;
  ASSERT_TRUE(fromMsg(msg, &result, &joint_names, &error)) << error;
  EXPECT_TRUE(result.guarded_entry);

  msg.map_stale = true;
  ASSERT_TRUE(fromMsg(msg, &result, &joint_names, &error)) << error;
  EXPECT_NE(result.message.find("older model"), std::string::npos) << result.message;
  msg.retreat_trajectory.points[0].positions.pop_back();
  EXPECT_FALSE(fromMsg(msg, &result, &joint_names, &error));
  // Without the arm: the probe's paths alone.
  gpatlas_msgs::PlanApproach::Response probe_only;
  probe_only.success = true;
  for (const auto& p : there) probe_only.approach.push_back(toPointMsg(p));
  joint_names.clear();
  ASSERT_TRUE(fromMsg(probe_only, &result, &joint_names, &error)) << error;
  EXPECT_TRUE(result.approach_joints.empty());
  EXPECT_TRUE(joint_names.empty());
}

TEST(Conversions, MeshRoundTrip) {
  gpatlas_core::TriangleMesh mesh;
  mesh.vertices = {{0.0, 0.0, 0.0}, {1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
  mesh.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  gpatlas_core::TriangleMesh back;
  std::string error;
  ASSERT_TRUE(fromMsg(toMsg(mesh), &back, &error)) << error;
  EXPECT_EQ(back.vertices, mesh.vertices);
  EXPECT_EQ(back.triangles, mesh.triangles);
  shape_msgs::Mesh broken = toMsg(mesh);
  broken.triangles[2].vertex_indices[1] = 4;
  EXPECT_FALSE(fromMsg(broken, &back, &error));
  EXPECT_NE(error.find("triangle 2"), std::string::npos) << error;
}

}  // namespace
