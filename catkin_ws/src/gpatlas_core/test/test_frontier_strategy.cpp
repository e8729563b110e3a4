// atlas_frontier on analytic scenes: a sphere seen from one side, with or without a small second
// sphere hidden in its shadow, on a table; the view ray-cast from a camera, the probe ray-cast
// against the exact spheres.

#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/observations/view_shadow.h"
#include "gpatlas_core/observations/view_training.h"
#include "gpatlas_core/observations/view_update.h"
#include "gpatlas_core/planning/frontier_strategy.h"
#include "gpatlas_core/planning/strategy_registry.h"
#include "gpatlas_core/testing/strategy_settings.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <limits>
#include <optional>
#include <vector>

using namespace gpatlas_core;
using gpatlas_core::testing::strategyWith;

namespace {

struct Ball {
  Vector3 centre;
  double radius;
};

// Two balls on the table z = 0 (the big one resting on it), a camera in front of and above the
// big one, the small one behind it.
struct Scene {
  Ball body{{0.6, 0.0, 0.1}, 0.1};
  std::optional<Ball> hidden;
  Vector3 camera{0.1, 0.0, 0.4};
  SupportPlane table{Vector3::UnitZ(), 0.0};

  // The first hit of the ray from `from` along unit `d` within `length`: its distance, and the
  // ball it hit (nullptr for the table); nullopt when it hits nothing.
  std::optional<std::pair<double, const Ball*>> cast(const Vector3& from, const Vector3& d, double length) const {
    std::optional<std::pair<double, const Ball*>> first;
    auto consider = [&](double t, const Ball* ball) {
      if (t >= 0.0 && t <= length && (!first || t < first->first)) first = std::make_pair(t, ball);
    };
    for (const Ball* ball : {&body, hidden ? &*hidden : nullptr}) {
      if (!ball) continue;
      const Vector3 o = from - ball->centre;
      const double b = o.dot(d), c = o.squaredNorm() - ball->radius * ball->radius, disc = b * b - c;
      if (disc >= 0.0) consider(-b - std::sqrt(disc), ball);
    }
    if (d.z() < 0.0) consider(-from.z() / d.z(), nullptr);
    return first;
  }

  // What the camera sees of the balls (the table is segmented away): one ray per direction of a
  // grid over the body's silhouette.
  std::vector<Vector3> view() const {
    std::vector<Vector3> points;
    const Vector3 axis = (body.centre - camera).normalized();
    const Vector3 u = axis.unitOrthogonal(), v = axis.cross(u);
    const double half = 1.3 * body.radius / (body.centre - camera).norm();
    for (int i = -60; i <= 60; ++i)
      for (int j = -60; j <= 60; ++j) {
        const Vector3 d = (axis + half * (i / 60.0) * u + half * (j / 60.0) * v).normalized();
        const auto hit = cast(camera, d, 2.0);
        if (hit && hit->second) points.push_back(camera + hit->first * d);
      }
    return points;
  }
};

// A ray probe: from 0.1 m out along the touch's normal through the target to 0.1 m past it; free
// space every 1 cm up to 5 mm before what it hits; a ball is a contact, the table is not.
class SceneProber : public Prober {
 public:
  explicit SceneProber(const Scene& scene) : scene_(scene) {}
  ProbeResult probe(const Touch& touch) override {
    ProbeResult result;
    const Vector3 n = touch.normals.back().normalized();
    const Vector3 start = touch.points.back() + 0.1 * n;
    const auto hit = scene_.cast(start, -n, 0.2);
    const double free_length = hit ? hit->first - 0.005 : 0.2;
    for (double s = 0.0; s <= free_length; s += 0.01) result.free_space.push_back(start - s * n);
    if (hit && hit->second) {
      Contact contact;
      contact.position = start - hit->first * n;
      contact.normal = (contact.position - hit->second->centre).normalized();
      result.contacts.push_back(contact);
      if (scene_.hidden && hit->second == &*scene_.hidden) ++hidden_contacts;
    }
    result.success = !result.contacts.empty();
    if (!result.success) result.reason = "no contact";
    return result;
  }
  int hidden_contacts{0};

 private:
  const Scene& scene_;
};

// The global GPIS fitted to the scene's view as the pipeline builds it (free space, guessed
// interior, the table), then touched where the atlas would have touched it: contacts on the
// body's part the camera did not see, so that the predicted surface is settled there (the body
// only: the hidden part is what the frontier has to find).
GpisModel settledModel(const Scene& scene, const std::vector<Vector3>& view) {
  ViewTrainingConfig config;
  config.max_surface_points = 400;  // the global GPIS's fit is cubic in its points
  config.near_surface_free_space.max_points = 0;
  config.support_free_space.max_points = 0;
  const ViewTraining training = buildViewTraining(view, scene.camera, scene.table, config, 1);
  EXPECT_TRUE(training.ok) << training.message;
  GpisModel model;
  const ViewUpdate update = applyView(model, training.points, TouchObservationConfig());
  EXPECT_TRUE(update.ok) << update.fit.message;
  const ViewShadow shadow({CameraView{scene.camera, view}}, ViewShadow::Config());
  std::vector<Contact> contacts;
  for (const Vector3& n : fibonacciSphere(60)) {
    const Vector3 p = scene.body.centre + scene.body.radius * n;
    if (p.z() < 0.02 || !shadow.hidden(p + 0.006 * n)) continue;
    if (scene.hidden && (p - scene.hidden->centre).norm() < scene.hidden->radius + 0.02) continue;
    contacts.push_back(Contact{p, n});
  }
  const TouchUpdate touched = applyTouch(model, contacts, {}, TouchObservationConfig());
  EXPECT_TRUE(touched.ok) << touched.message;
  return model;
}

EvidenceState stateOf(const Scene& scene, const std::vector<Vector3>& view) {
  EvidenceState state;
  state.support_plane = scene.table;
  state.views = {CameraView{scene.camera, view}};
  return state;
}

// A V_max no variance reaches and no evidence rule: the predicted surface needs no touch, so
// every plan is about the unknown space.
PlanRequest surfaceSettled(const EvidenceState& state) {
  PlanRequest request;
  request.v_max = 1e6;
  request.evidence_state = state;
  return request;
}

// atlas_frontier's atlas: V_max alone (no evidence distance).
AtlasPlanner::Config varianceAlone() {
  AtlasPlanner::Config atlas;
  atlas.evidence.max_distance = std::nullopt;
  return atlas;
}
const char* const kVarianceAlone = "evidence/max_distance=off";

TEST(ViewShadow, HidesWhatLiesBehindTheSeenSurfaceOnly) {
  Scene scene;
  const std::vector<Vector3> view = scene.view();
  ASSERT_GT(view.size(), 1000u);
  const ViewShadow shadow({CameraView{scene.camera, view}}, ViewShadow::Config());
  const Vector3 away = (scene.body.centre - scene.camera).normalized();
  // Behind the ball along the camera's line of sight, and its centre: hidden. In front of it,
  // beside it (the ray passes the silhouette), and above it: seen.
  EXPECT_TRUE(shadow.hidden(scene.body.centre));
  EXPECT_TRUE(shadow.hidden(scene.body.centre + 0.15 * away));
  EXPECT_FALSE(shadow.hidden(scene.body.centre - 0.15 * away));
  EXPECT_FALSE(shadow.hidden(scene.body.centre + Vector3(0.0, 0.2, 0.0)));
  EXPECT_FALSE(shadow.hidden(scene.body.centre + Vector3(0.0, 0.0, 0.15)));
  // Every view must hide a point: a second camera behind the ball sees the far side.
  const Vector3 behind = scene.body.centre + (scene.body.centre - scene.camera);
  Scene back = scene;
  back.camera = behind;
  const ViewShadow both({CameraView{scene.camera, view}, CameraView{behind, back.view()}}, ViewShadow::Config());
  EXPECT_FALSE(both.hidden(scene.body.centre + 0.15 * away));
  EXPECT_TRUE(both.hidden(scene.body.centre));
  EXPECT_FALSE(ViewShadow().hidden(scene.body.centre));
}

TEST(FrontierStrategy, FirstPokeTargetsTheShadowAndFindsTheHiddenPart) {
  Scene scene;
  scene.hidden = Ball{{0.725, 0.0, 0.06}, 0.02};
  const std::vector<Vector3> view = scene.view();
  for (const Vector3& p : view)  // the small ball is wholly in the shadow
    ASSERT_GT((p - scene.hidden->centre).norm(), scene.hidden->radius + 1e-3);
  GpisModel model = settledModel(scene, view);
  const EvidenceState state = stateOf(scene, view);
  // The model does not predict the small ball.
  EXPECT_GT(model.mean(scene.hidden->centre), 0.0);

  const std::unique_ptr<ExplorationStrategy> strategy = strategyWith("atlas_frontier", {kVarianceAlone});
  const PlanResult first = strategy->plan(model, surfaceSettled(state));
  ASSERT_EQ(first.status, PlanStatus::kTouch) << first.message;
  ASSERT_EQ(first.touch.points.size(), 1u);
  const Vector3 target = first.touch.points[0], outward = first.touch.normals[0];
  EXPECT_TRUE(first.touch.explores_unknown);
  EXPECT_EQ(first.touch.strategy, "atlas_frontier");
  const ViewShadow shadow(state.views, ViewShadow::Config());
  EXPECT_TRUE(shadow.hidden(target));
  EXPECT_GT(model.mean(target), 0.0);
  EXPECT_GT(scene.table.height(target), 0.0);
  // Approached from space the camera saw (the line reaches it within observed_within_m), not
  // through the predicted object.
  bool from_seen_space = false;
  for (double s = 0.1; s <= FrontierStrategy::Config().observed_within_m; s += 0.01)
    from_seen_space = from_seen_space || !shadow.hidden(target + s * outward);
  EXPECT_TRUE(from_seen_space);
  for (double s = 0.0; s <= 0.1; s += 0.002) EXPECT_GT(model.mean(target + s * outward), 0.0) << s;

  // The loop with the analytic probe finds the small ball.
  SceneProber prober(scene);
  Explorer::Config loop;
  loop.v_max = 1e6;
  loop.max_position_sd_m = std::nullopt;  // the atlas's part converges at once: the shadow's part is under test
  loop.max_actions = 20;
  const ExplorationResult run = Explorer(loop).run(model, *strategy, prober, TouchObservationConfig(), state);
  std::cout << "hidden part: " << prober.hidden_contacts << " contacts on it in " << run.actions << " touches, stop "
            << run.stop_reason << std::endl;
  EXPECT_GE(prober.hidden_contacts, 1);
  EXPECT_NE(run.stop_reason.rfind("error", 0), 0u) << run.stop_reason;
}

TEST(FrontierStrategy, AnEmptyPokeClearsItsPathAndTheStrategyConverges) {
  Scene scene;  // nothing hidden
  const std::vector<Vector3> view = scene.view();
  GpisModel model = settledModel(scene, view);
  EvidenceState state = stateOf(scene, view);
  FrontierStrategy::Config config;
  config.max_empty_pokes = 1000;  // converge by clearing, not by the budget
  // A coarse grid over a thin band: a few dozen pokes clear it.
  config.cell_m = 0.02;
  config.reach_m = 0.04;
  config.clear_radius_m = 0.015;
  const FrontierStrategy frontier(config, varianceAlone(), 0);
  const std::unique_ptr<ExplorationStrategy> strategy = std::make_unique<FrontierStrategy>(config, varianceAlone(), 0);

  const UnknownSpace before = frontier.unknownSpace(model, state);
  ASSERT_GT(before.unknown_cells, 0);
  const PlanResult first = strategy->plan(model, surfaceSettled(state));
  ASSERT_EQ(first.status, PlanStatus::kTouch) << first.message;
  SceneProber prober(scene);
  const ProbeResult probed = prober.probe(first.touch);
  ASSERT_TRUE(probed.contacts.empty() || (probed.contacts[0].position - first.touch.points[0]).norm() > 0.005);
  const TouchUpdate update = applyTouch(model, probed.contacts, probed.free_space, TouchObservationConfig());
  ASSERT_TRUE(update.ok) << update.message;
  state.attempted_targets.push_back(first.touch.points[0]);
  state.empty_unknown_pokes += probed.contacts.empty() ? 1 : 0;

  // The unknown cells its path crossed (to the probe's end, or what it hit) are cleared, and the
  // next poke goes elsewhere.
  const UnknownSpace after = frontier.unknownSpace(model, state);
  const Vector3 target = first.touch.points[0], outward = first.touch.normals[0].normalized();
  const double end =
      probed.contacts.empty() ? 0.1 : (probed.contacts[0].position - (target + 0.1 * outward)).norm() - 0.1;
  int crossed = 0;
  for (double s = 0.1; s >= -end + 0.006; s -= 0.002) {
    const long before_cell = before.index(target + s * outward), after_cell = after.index(target + s * outward);
    if (before_cell < 0) continue;
    if (before.cells[static_cast<std::size_t>(before_cell)] != UnknownSpace::Cell::kUnknown) continue;
    ++crossed;
    EXPECT_NE(after.cells[static_cast<std::size_t>(after_cell)], UnknownSpace::Cell::kUnknown) << s;
  }
  EXPECT_GT(crossed, 0);
  std::cout << "unknown cells " << before.unknown_cells << " before the poke, " << after.unknown_cells << " after"
            << std::endl;
  const PlanResult second = strategy->plan(model, surfaceSettled(state));
  ASSERT_EQ(second.status, PlanStatus::kTouch) << second.message;
  EXPECT_GT((second.touch.points[0] - first.touch.points[0]).norm(), 0.005);

  // Poking on clears the band until no poke can reach what is left.
  Explorer::Config loop;
  loop.v_max = 1e6;
  loop.max_position_sd_m = std::nullopt;  // the atlas's part converges at once: the shadow's part is under test
  loop.max_actions = 60;
  SceneProber loop_prober(scene);
  GpisModel fresh = settledModel(scene, view);
  const ExplorationResult run =
      Explorer(loop).run(fresh, *strategy, loop_prober, TouchObservationConfig(), stateOf(scene, view));
  std::cout << "empty scene: " << run.actions << " touches, " << run.contacts << " contacts, stop " << run.stop_reason
            << std::endl;
  EXPECT_TRUE(run.converged) << run.stop_reason;
}

TEST(FrontierStrategy, TheBudgetOfEmptyPokesEndsTheSearch) {
  Scene scene;
  const std::vector<Vector3> view = scene.view();
  const GpisModel model = settledModel(scene, view);
  EvidenceState state = stateOf(scene, view);
  const std::unique_ptr<ExplorationStrategy> strategy =
      strategyWith("atlas_frontier", {kVarianceAlone, "frontier/max_empty_pokes=2"});
  EXPECT_EQ(strategy->plan(model, surfaceSettled(state)).status, PlanStatus::kTouch);
  state.empty_unknown_pokes = 2;
  EXPECT_EQ(strategy->plan(model, surfaceSettled(state)).status, PlanStatus::kConverged);
  // Without a view it is atlas_poke: the settled surface has converged.
  state = EvidenceState();
  EXPECT_EQ(strategy->plan(model, surfaceSettled(state)).status, PlanStatus::kConverged);
}

TEST(FrontierStrategy, RefusesABadConfig) {
  FrontierStrategy::Config config;
  EXPECT_EQ(validate(config), "");
  config.min_gap_m = config.reach_m;
  EXPECT_NE(validate(config), "");
  EXPECT_THROW(FrontierStrategy(config, AtlasPlanner::Config(), 0), std::invalid_argument);
  EvidenceState state;
  state.views = {CameraView{Vector3(std::nan(""), 0.0, 0.0), {}}};
  EXPECT_NE(validate(state), "");
}

}  // namespace
