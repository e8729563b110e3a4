// The configuration file against the Configs' readers, the YAML source, and the view builder.
#include "gpatlas_core/config/config_readers.h"
#include "gpatlas_core/exploration/exploration_report.h"
#include "gpatlas_core/common/parameters.h"
#include "gpatlas_core/observations/view_training.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <utility>
#include <set>

namespace {

using gpatlas_core::ParamReader;
using gpatlas_core::Vector3;
using gpatlas_core::YamlParameters;

// A scope reads under its namespace, nested scopes append theirs, and the names it reports
// (read, defaulted, invalid) are full.
TEST(ParamReader, AScopeReadsUnderItsNamespaceAndReportsFullNames) {
  std::string error;
  const auto params = YamlParameters::fromString("a: {b: {x: 2}, x: 3}\nx: 4\n", &error);
  ASSERT_TRUE(params) << error;
  ParamReader reader(*params);
  {
    const ParamReader::Scope a(reader, "a");
    EXPECT_EQ(reader.integer("x", 0, 0, 10), 3);
    {
      const ParamReader::Scope b(reader, "b/");
      EXPECT_EQ(reader.scope(), "a/b/");
      EXPECT_EQ(reader.integer("x", 0, 0, 10), 2);
      EXPECT_EQ(reader.integer("y", 5, 0, 10), 5);
    }
    EXPECT_EQ(reader.scope(), "a/");
    reader.invalid("z", "bad");
    EXPECT_EQ(reader.integer("x", 0, 0, 1), 0);  // 3 is out of range: the fallback, reported
  }
  EXPECT_EQ(reader.scope(), "");
  EXPECT_EQ(reader.integer("x", 0, 0, 10), 4);
  EXPECT_EQ(reader.readNames(), (std::vector<std::string>{"a/x", "a/b/x", "a/b/y", "a/x", "x"}));
  EXPECT_EQ(reader.defaultedNames(), std::vector<std::string>{"a/b/y"});
  EXPECT_NE(reader.errors().find("a/z: bad"), std::string::npos) << reader.errors();
  EXPECT_NE(reader.errors().find("a/x: = 3 is outside [0, 1]"), std::string::npos) << reader.errors();
}

// A strategy made by the registry reads its own section: its values reach it, a refused one is
// reported under the strategy's namespace, and another section is not read.
TEST(StrategyRegistry, AStrategyReadsItsSettingsUnderItsNamespace) {
  std::string error;
  const auto params = YamlParameters::fromString(
      "mine: {planner: {max_charts: 0}, frontier: {cell_m: 0.02}}\nplanner: {max_charts: 5}\n", &error);
  ASSERT_TRUE(params) << error;
  ParamReader reader(*params);
  const auto poke = gpatlas_core::makeStrategy("atlas_poke", reader, 0, "mine");
  EXPECT_EQ(poke->name(), "atlas_poke");
  EXPECT_FALSE(reader.ok());
  EXPECT_NE(reader.errors().find("mine/planner/max_charts"), std::string::npos) << reader.errors();
  const auto& read = reader.readNames();
  EXPECT_TRUE(std::count(read.begin(), read.end(), "mine/evidence/max_distance"));
  EXPECT_FALSE(std::count(read.begin(), read.end(), "planner/max_charts"));
  EXPECT_FALSE(std::count(read.begin(), read.end(), "mine/frontier/cell_m"));  // atlas_frontier's
  ParamReader frontier_reader(*params);
  gpatlas_core::makeStrategy("atlas_frontier", frontier_reader, 0, "mine");
  const auto& frontier_read = frontier_reader.readNames();
  EXPECT_TRUE(std::count(frontier_read.begin(), frontier_read.end(), "mine/frontier/cell_m"));
  EXPECT_THROW(gpatlas_core::makeStrategy("no_such_strategy", reader, 0), std::invalid_argument);
}

TEST(YamlParameters, AnOverlaySetsItsLeavesAndKeepsTheRest) {
  std::string error;
  auto base = YamlParameters::fromString(
      "exploration: {v_max: 0.1, max_actions: 100}\nsegmentation: {crop_min_m: [0, 0, 0]}\nstrategy: atlas_poke\n", &error);
  auto overlay = YamlParameters::fromString(
      "exploration: {v_max: 0.05}\nsegmentation: {crop_min_m: [0.1, -0.2, 0.3]}\nmodel: {type: gpis}\n", &error);
  ASSERT_TRUE(base && overlay) << error;
  ASSERT_TRUE(base->overlay(*overlay, &error)) << error;
  EXPECT_DOUBLE_EQ(*base->number("exploration/v_max"), 0.05);
  EXPECT_EQ(*base->integer("exploration/max_actions"), 100);
  EXPECT_EQ(*base->numbers("segmentation/crop_min_m"), std::vector<double>({0.1, -0.2, 0.3}));
  EXPECT_EQ(*base->text("strategy"), "atlas_poke");
  EXPECT_EQ(*base->text("model/type"), "gpis");
}

TEST(YamlParameters, OverridesAndBadInputSayWhatIsWrong) {
  std::string error;
  auto params = YamlParameters::fromString("exploration: {v_max: 0.1}\nstrategy: atlas_poke\n", &error);
  ASSERT_TRUE(params);
  ASSERT_TRUE(params->set("exploration/v_max=0.02", &error)) << error;
  ASSERT_TRUE(params->set("planner/rho_max_m=0.03", &error)) << error;  // a new section
  ASSERT_TRUE(params->set("strategy=atlas_slide", &error)) << error;
  EXPECT_DOUBLE_EQ(*params->number("exploration/v_max"), 0.02);
  EXPECT_DOUBLE_EQ(*params->number("planner/rho_max_m"), 0.03);
  EXPECT_EQ(*params->text("strategy"), "atlas_slide");
  EXPECT_FALSE(params->set("no_equals_sign", &error));
  EXPECT_NE(error.find("key=value"), std::string::npos) << error;

  // Wrong types and out-of-range values are errors with the parameter's name; defaults stay.
  ParamReader reader(*params);
  gpatlas_core::Explorer::Config loop;
  ASSERT_TRUE(params->set("exploration/v_max=-1", &error));
  ASSERT_TRUE(params->set("exploration/max_actions=many", &error));
  gpatlas_core::readExplorer(reader, &loop);
  EXPECT_FALSE(reader.ok());
  EXPECT_NE(reader.errors().find("exploration/v_max"), std::string::npos) << reader.errors();
  EXPECT_NE(reader.errors().find("exploration/max_actions"), std::string::npos) << reader.errors();
  EXPECT_DOUBLE_EQ(loop.v_max, gpatlas_core::Explorer::Config().v_max);

  EXPECT_FALSE(YamlParameters::fromFile("/nonexistent/pipeline.yaml", &error));
  EXPECT_NE(error.find("cannot read"), std::string::npos) << error;
  EXPECT_FALSE(YamlParameters::fromString("a: [1, 2", &error));
  EXPECT_FALSE(YamlParameters::fromString("- just\n- a list\n", &error));
}

// exploration/v_max has one reader: the loop's section reader and the nodes that need the
// threshold alone read the same value with the same checks.
TEST(Readers, VMaxHasOneReader) {
  std::string error;
  auto params = YamlParameters::fromString("exploration: {v_max: 0.02, max_actions: 7}\n", &error);
  ASSERT_TRUE(params) << error;
  ParamReader reader(*params);
  gpatlas_core::Explorer::Config loop;
  gpatlas_core::readExplorer(reader, &loop);
  EXPECT_DOUBLE_EQ(loop.v_max, 0.02);
  EXPECT_DOUBLE_EQ(gpatlas_core::readVMax(reader), 0.02);
  ASSERT_TRUE(params->set("exploration/v_max=0", &error)) << error;
  ParamReader strict(*params);
  EXPECT_DOUBLE_EQ(gpatlas_core::readVMax(strict), gpatlas_core::Explorer::Config().v_max);
  EXPECT_NE(strict.errors().find("exploration/v_max"), std::string::npos) << strict.errors();
}

// An optional limit is a positive value or `off`, whichever reader reads it; 0 and negatives,
// which meant "off" for some keys and themselves for others, are refused with the key, the value
// and the word to write, and the default stays.
TEST(Readers, AnOptionalLimitIsPositiveOrOff) {
  std::string error;
  auto params = YamlParameters::fromString(
      "exploration: {max_position_sd_m: off}\n"
      "evidence: {max_distance: 0.2, surprise_distance_m: off}\n"
      "touch: {max_contacts_per_touch: off, max_free_space_per_touch: 7, max_touch_observations: off,\n"
      "        contact_tangent_noise_sigma: off, gate: {max_contact_distance_m: off}}\n",
      &error);
  ASSERT_TRUE(params) << error;
  ParamReader reader(*params);
  gpatlas_core::Explorer::Config loop;
  gpatlas_core::EvidenceRule evidence;
  gpatlas_core::TouchObservationConfig touch;
  gpatlas_core::readExplorer(reader, &loop);
  gpatlas_core::readEvidence(reader, &evidence);
  gpatlas_core::readTouchObservations(reader, &touch);
  EXPECT_TRUE(reader.ok()) << reader.errors();
  EXPECT_FALSE(loop.max_position_sd_m.has_value());
  EXPECT_FALSE(gpatlas_core::readMaxPositionSd(reader).has_value());
  EXPECT_EQ(evidence.max_distance, std::optional<double>(0.2));
  EXPECT_FALSE(evidence.surprise_distance_m.has_value());
  EXPECT_FALSE(touch.max_contacts_per_touch.has_value());
  EXPECT_EQ(touch.max_free_space_per_touch, std::optional<std::size_t>(7));
  EXPECT_FALSE(touch.max_touch_observations.has_value());
  EXPECT_FALSE(touch.contact_tangent_noise_sigma.has_value());
  EXPECT_FALSE(touch.gate.max_contact_distance_m.has_value());

  // rosparam reads a bare off as YAML 1.1's false: the same.
  ASSERT_TRUE(params->set("exploration/max_position_sd_m=false", &error)) << error;
  ParamReader as_ros(*params);
  EXPECT_FALSE(gpatlas_core::readMaxPositionSd(as_ros, 0.005).has_value());
  EXPECT_TRUE(as_ros.ok()) << as_ros.errors();

  // Absent: the code's default, which a Config states as a value or as empty.
  auto empty = YamlParameters::fromString("{}", &error);
  ASSERT_TRUE(empty) << error;
  ParamReader defaults(*empty);
  EXPECT_EQ(gpatlas_core::readMaxPositionSd(defaults), std::optional<double>(0.005));
  EXPECT_FALSE(gpatlas_core::readMaxPositionSd(defaults, std::nullopt).has_value());
  EXPECT_EQ(defaults.defaults().back(), std::make_pair(std::string("exploration/max_position_sd_m"), std::string("off")));

  // 0, negatives, a word other than off and true are refused, each with its key and value.
  for (const char* bad : {"0", "-0.005", "none", "true", "0.0"}) {
    ASSERT_TRUE(params->set(std::string("exploration/max_position_sd_m=") + bad, &error)) << error;
    ASSERT_TRUE(params->set(std::string("touch/max_contacts_per_touch=") + bad, &error)) << error;
    ParamReader strict(*params);
    gpatlas_core::Explorer::Config refused;
    gpatlas_core::TouchObservationConfig refused_touch;
    gpatlas_core::readExplorer(strict, &refused);
    gpatlas_core::readTouchObservations(strict, &refused_touch);
    EXPECT_FALSE(strict.ok()) << bad;
    EXPECT_EQ(refused.max_position_sd_m, gpatlas_core::Explorer::Config().max_position_sd_m) << bad;
    EXPECT_EQ(refused_touch.max_contacts_per_touch, gpatlas_core::TouchObservationConfig().max_contacts_per_touch);
    EXPECT_NE(strict.errors().find("exploration/max_position_sd_m"), std::string::npos) << strict.errors();
    EXPECT_NE(strict.errors().find("touch/max_contacts_per_touch"), std::string::npos) << strict.errors();
  }
  ASSERT_TRUE(params->set("exploration/max_position_sd_m=0", &error)) << error;
  ASSERT_TRUE(params->set("touch/max_contacts_per_touch=-3", &error)) << error;
  ParamReader zero(*params);
  gpatlas_core::readExplorer(zero, &loop);
  gpatlas_core::readTouchObservations(zero, &touch);
  EXPECT_NE(zero.errors().find("exploration/max_position_sd_m: = 0 is not a limit (it must be > 0): write off for none"),
            std::string::npos)
      << zero.errors();
  EXPECT_NE(zero.errors().find("touch/max_contacts_per_touch: = -3 is not a limit (it must be > 0): write off for none"),
            std::string::npos)
      << zero.errors();
  // Above the range: refused like any number.
  ASSERT_TRUE(params->set("evidence/surprise_distance_m=5", &error)) << error;
  ParamReader high(*params);
  gpatlas_core::readEvidence(high, &evidence);
  EXPECT_NE(high.errors().find("evidence/surprise_distance_m: = 5 is outside (0, 1]"), std::string::npos)
      << high.errors();
}

// The part of a 5 cm sphere at (0.7, 0, 0.05) that a camera at `eye` sees (on a convex
// shape: the points whose normal faces the camera).
std::vector<Vector3> sphereView(int n, const Vector3& eye) {
  std::vector<Vector3> points;
  for (int i = 0; i < n; ++i) {
    const double z = -1.0 + 2.0 * (i + 0.5) / n, phi = 2.399963 * i;
    const Vector3 u(std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z);
    const Vector3 p = Vector3(0.7, 0.0, 0.05) + 0.05 * u;
    if ((eye - p).dot(u) > 0.0) points.push_back(p);
  }
  return points;
}

TEST(ViewTraining, OneSeedGivesOneTrainingSetWithEveryPart) {
  const Vector3 eye(1.3, 0.0, 0.3);
  const std::vector<Vector3> view = sphereView(4000, eye);
  const gpatlas_core::SupportPlane table;  // z = 0
  gpatlas_core::ViewTrainingConfig config;
  config.max_surface_points = 600;  // fewer than the view's: a random subset
  config.near_surface_free_space.max_points = 500;
  // Beside a ball the camera never sees a side down to the table; with a loose bound the table
  // beside it is sampled as well.
  config.support_free_space.max_bound_gap_m = 0.1;
  const auto a = gpatlas_core::buildViewTraining(view, eye, table, config, 3);
  ASSERT_TRUE(a.ok) << a.message;
  EXPECT_EQ(a.surface, 600u);
  EXPECT_GT(a.free_space, 0u);
  EXPECT_EQ(a.near_surface_free_space, 500u);
  EXPECT_GT(a.below_support, 0u);
  EXPECT_GT(a.support_free_space, 0u);
  EXPECT_EQ(a.points.size(), a.surface + a.free_space + a.near_surface_free_space + a.occluded_interior +
                                 a.below_support + a.support_free_space);
  for (std::size_t i = a.points.size() - a.support_free_space; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].source, gpatlas_core::PointSource::kViewSupport);
    EXPECT_NEAR(a.points[i].position.z(), config.support_free_space.height_m, 1e-12);  // on the table
    EXPECT_GT((a.points[i].position - Vector3(0.7, 0.0, 0.05)).norm(), 0.05);            // beside the sphere
  }
  for (std::size_t i = 0; i < a.surface; ++i) {
    EXPECT_EQ(a.points[i].label, gpatlas_core::PointLabel::kSurface);
    EXPECT_NEAR((a.points[i].position - Vector3(0.7, 0.0, 0.05)).norm(), 0.05, 1e-12);  // a view point
  }
  for (std::size_t i = a.surface; i < a.surface + a.free_space; ++i)
    EXPECT_GT((a.points[i].position - Vector3(0.7, 0.0, 0.05)).norm(), 0.05);  // in front of the sphere
  const auto again = gpatlas_core::buildViewTraining(view, eye, table, config, 3);
  ASSERT_EQ(again.points.size(), a.points.size());
  for (std::size_t i = 0; i < a.points.size(); ++i) EXPECT_EQ(again.points[i].position, a.points[i].position);
  const auto other = gpatlas_core::buildViewTraining(view, eye, table, config, 4);
  EXPECT_NE(other.points.front().position, a.points.front().position);

  // Without a sensor origin: the subset alone (and the table's points).
  const auto blind = gpatlas_core::buildViewTraining(view, std::nullopt, std::nullopt, config, 3);
  ASSERT_TRUE(blind.ok);
  EXPECT_EQ(blind.points.size(), 600u);

  // Too few finite points: an error that says so.
  std::vector<Vector3> bad(10, Vector3::Constant(std::nan("")));
  bad.push_back(Vector3::Zero());
  const auto refused = gpatlas_core::buildViewTraining(bad, eye, std::nullopt, config, 3);
  EXPECT_FALSE(refused.ok);
  EXPECT_NE(refused.message.find("10 not finite"), std::string::npos) << refused.message;
}

TEST(RunStatus, NoSurfaceIsAnErrorWhateverTheLoopSaid) {
  gpatlas_core::ExplorationResult converged;
  converged.converged = true;
  converged.stop_reason = "converged";
  EXPECT_EQ(gpatlas_core::runStatus(converged, true, ""), "converged");
  EXPECT_EQ(gpatlas_core::runStatus(converged, false, "grid too large"), "error: no predicted surface: grid too large");
  gpatlas_core::ExplorationResult capped;
  capped.stop_reason = "max_actions";
  EXPECT_EQ(gpatlas_core::runStatus(capped, true, ""), "stopped: max_actions");
  capped.stop_reason = "error: probe did not answer";
  // One "error: ", not two: the loop's reason already has it.
  EXPECT_EQ(gpatlas_core::runStatus(capped, true, ""), "error: probe did not answer");
  capped.stop_reason = "planner_error: no model: the GP is not fitted";
  EXPECT_EQ(gpatlas_core::runStatus(capped, true, ""), "error: planner_error: no model: the GP is not fitted");
}

TEST(ReportJson, TheCurveHasEveryTouchAndNullWhereNotMeasured) {
  gpatlas_core::ExplorationReport report;
  report.initial.index = -1;
  report.initial.rmse_pred_to_gt_m = 0.01;
  report.initial.rmse_gt_to_pred_m = 0.008;
  report.initial.fscore_5mm = 0.5;
  for (int i = 0; i < 3; ++i) {
    gpatlas_core::ExplorationRecord r;
    r.index = i;
    r.contacts_total = i;  // the first touch found nothing, each other one contact
    if (i > 0) r.contact_positions.push_back(Vector3(0.5 + 0.01 * i, -0.1, 0.25));
    if (i != 1) {  // the second's model was not measured (skipped, or no truth)
      r.rmse_pred_to_gt_m = 0.004 - 0.001 * i;
      r.rmse_gt_to_pred_m = 0.003 - 0.001 * i;
      r.fscore_5mm = 0.8 + 0.05 * i;
    }
    report.result.records.push_back(r);
  }
  const std::string json = gpatlas_core::toJson(report);
  const std::string curve =
      "  \"curve\": [\n"
      "    {\"touches\": 0, \"contacts_total\": 0, \"rmse_pred_to_gt_m\": 0.01, \"rmse_gt_to_pred_m\": 0.008, \"fscore_5mm\": 0.5},\n"
      "    {\"touches\": 1, \"contacts_total\": 0, \"rmse_pred_to_gt_m\": 0.004, \"rmse_gt_to_pred_m\": 0.003, \"fscore_5mm\": 0.8},\n"
      "    {\"touches\": 2, \"contacts_total\": 1, \"rmse_pred_to_gt_m\": null, \"rmse_gt_to_pred_m\": null, \"fscore_5mm\": null},\n"
      "    {\"touches\": 3, \"contacts_total\": 2, \"rmse_pred_to_gt_m\": 0.002, \"rmse_gt_to_pred_m\": 0.001, \"fscore_5mm\": 0.9}\n"
      "  ]\n}\n";
  ASSERT_GE(json.size(), curve.size());
  EXPECT_EQ(json.substr(json.size() - curve.size()), curve) << json;
  // Each action's record and the initial model carry the F-score too.
  EXPECT_NE(json.find("\"fscore_5mm\": 0.8, \"contact_points\": []},\n    {\"action\": 2"), std::string::npos) << json;
  // and the positions of its contacts, in metres.
  EXPECT_NE(json.find("\"contact_points\": [[0.51, -0.1, 0.25]]},\n    {\"action\": 3"), std::string::npos) << json;
  EXPECT_NE(json.find("\"contact_points\": [[0.52, -0.1, 0.25]]}\n  ]"), std::string::npos) << json;
  EXPECT_NE(json.find("\"rmse_gt_to_pred_m\": 0.008, \"fscore_5mm\": 0.5}"), std::string::npos) << json;
}

}  // namespace

// The status line's note on what the last plan left out of reach: nothing without candidates,
// their count, and for an atlas their share of its area.
TEST(ExplorationReport, OutOfReachNoteSaysTheCountAndTheAtlasShare) {
  gpatlas_core::ExplorationResult result;
  EXPECT_EQ(gpatlas_core::outOfReachNote(result), "");
  result.final_unreachable_candidates = 3;
  EXPECT_EQ(gpatlas_core::outOfReachNote(result), " (3 candidates left out of reach)");
  result.final_unreachable_candidates = 12;
  result.final_unreachable_area_fraction = 0.083;
  EXPECT_EQ(gpatlas_core::outOfReachNote(result), " (12 candidates left out of reach: 8.30% of the atlas's area)");
  // report.json carries the share.
  gpatlas_core::ExplorationReport report;
  report.result = result;
  EXPECT_NE(gpatlas_core::toJson(report).find("\"final_unreachable_area_fraction\": 0.083"), std::string::npos);
}
