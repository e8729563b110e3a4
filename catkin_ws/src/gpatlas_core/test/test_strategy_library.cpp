#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/planning/strategy_library.h"
#include "gpatlas_core/model/surface_model_factory.h"
#include "gpatlas_core/config/config_readers.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace {

using gpatlas_core::loadStrategyLibrary;
using gpatlas_core::testing::AnalyticSphere;
using gpatlas_core::testing::AnalyticSphereProber;

constexpr const char* kStrategy = "farthest_from_evidence";

bool known(const std::string& name) {
  const auto names = gpatlas_core::strategyNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

// A library that registers a surface model: built by name like the built-in ones, and rebuilt
// exactly from its state (what the nodelets' replicas do).
TEST(StrategyLibrary, LoadsASurfaceModelThatFitsAndRebuildsFromItsState) {
  const auto load = loadStrategyLibrary(GPATLAS_EXAMPLE_MODEL_LIBRARY);
  ASSERT_TRUE(load.ok) << load.message;
  EXPECT_TRUE(load.added.empty());
  EXPECT_EQ(load.added_models, std::vector<std::string>{"gpis_matern52"});
  gpatlas_core::SurfaceModelConfig config;
  config.type = "gpis_matern52";
  const std::unique_ptr<gpatlas_core::SurfaceModel> model = gpatlas_core::makeSurfaceModel(config);
  EXPECT_EQ(model->name(), "gpis_matern52");
  const AnalyticSphere sphere;
  ASSERT_TRUE(model->fit(sphere.view(200, -1.0, 0.1, 2)).ok);
  // The kernel is the library's, not the default's: its parameters are a sigma and a length.
  EXPECT_EQ(model->hyperparameterNames(), (std::vector<std::string>{"log_sigma", "log_length", "log_noise_scale"}));
  const gpatlas_core::Vector3 on_surface = sphere.centre + sphere.radius * gpatlas_core::Vector3(0.6, 0.0, 0.8);
  EXPECT_NEAR(model->mean(on_surface), 0.0, 0.05);
  const std::unique_ptr<gpatlas_core::SurfaceModel> replica = gpatlas_core::makeSurfaceModel(config);
  ASSERT_TRUE(replica->restore(model->state()).ok);
  EXPECT_EQ(replica->mean(sphere.centre), model->mean(sphere.centre));
  EXPECT_EQ(replica->variance(on_surface), model->variance(on_surface));
  EXPECT_EQ(replica->clone()->name(), "gpis_matern52");
}

// The library's model reads gpis/ and a setting of its own under the namespace it is made in,
// through the registry as the nodes and the bench make it, and a refused value is reported by
// its full name (its default applies).
TEST(StrategyLibrary, ALibrarysSurfaceModelReadsItsSettingsUnderItsNamespace) {
  ASSERT_TRUE(loadStrategyLibrary(GPATLAS_EXAMPLE_MODEL_LIBRARY).ok);
  std::string error;
  const auto settings = gpatlas_core::YamlParameters::fromString(
      "plugins: {gpis_matern52: {length: 0.5}, gpis: {data_radius: 0.8}}\n"
      "gpis_matern52: {length: 0.05}\n"
      "refused: {gpis_matern52: {length: -1}}\n",
      &error);
  ASSERT_TRUE(settings) << error;
  gpatlas_core::ParamReader reader(*settings);
  const std::unique_ptr<gpatlas_core::SurfaceModel> model =
      gpatlas_core::surfaceModelMaker("gpis_matern52", reader, "plugins")();
  EXPECT_TRUE(reader.ok()) << reader.errors();
  EXPECT_NEAR(model->hyperparameters()[1], std::log(0.5), 1e-12);  // log sigma, log length, ...
  EXPECT_EQ(dynamic_cast<const gpatlas_core::GpisModel&>(*model).config().data_radius, 0.8);
  const auto& read = reader.readNames();
  EXPECT_TRUE(std::count(read.begin(), read.end(), "plugins/gpis_matern52/length"));
  EXPECT_FALSE(std::count(read.begin(), read.end(), "gpis_matern52/length"));

  // The nodes' path: readSurfaceModel has every registered model read its settings.
  const auto nodes = gpatlas_core::YamlParameters::fromString(
      "model: {type: gpis_matern52}\ngpis_matern52: {length: 0.05}\n", &error);
  ASSERT_TRUE(nodes) << error;
  gpatlas_core::ParamReader node_reader(*nodes);
  gpatlas_core::SurfaceModelConfig config;
  gpatlas_core::readSurfaceModel(node_reader, &config);
  EXPECT_TRUE(node_reader.ok()) << node_reader.errors();
  EXPECT_NEAR(gpatlas_core::makeSurfaceModel(config)->hyperparameters()[1], std::log(0.05), 1e-12);

  gpatlas_core::ParamReader refused_reader(*settings);
  const std::unique_ptr<gpatlas_core::SurfaceModel> refused =
      gpatlas_core::surfaceModelMaker("gpis_matern52", refused_reader, "refused")();
  EXPECT_FALSE(refused_reader.ok());
  EXPECT_NE(refused_reader.errors().find("refused/gpis_matern52/length"), std::string::npos) << refused_reader.errors();
  EXPECT_NEAR(refused->hyperparameters()[1], std::log(0.3), 1e-12);  // Matern52Kernel's default
}

TEST(StrategyLibrary, LoadsTheExampleOnceAndItsStrategyPlans) {
  ASSERT_FALSE(known(kStrategy));
  const auto load = loadStrategyLibrary(GPATLAS_EXAMPLE_STRATEGY_LIBRARY);
  ASSERT_TRUE(load.ok) << load.message;
  EXPECT_EQ(load.added, std::vector<std::string>{kStrategy});
  EXPECT_TRUE(known(kStrategy));
  const auto again = loadStrategyLibrary(GPATLAS_EXAMPLE_STRATEGY_LIBRARY);
  ASSERT_TRUE(again.ok) << again.message;
  EXPECT_EQ(again.added, load.added);
  // The same file under another name (a relative path through its own directory) is the same library.
  const std::string path = GPATLAS_EXAMPLE_STRATEGY_LIBRARY;
  const std::string slash_dot = path.substr(0, path.rfind('/')) + "/./" + path.substr(path.rfind('/') + 1);
  const auto renamed = loadStrategyLibrary(slash_dot);
  ASSERT_TRUE(renamed.ok) << renamed.message;
  EXPECT_EQ(renamed.added, load.added);

  // A sphere seen from above (the cap z >= 0.3 r): the predicted surface farthest from every view
  // point is the unseen bottom, more than a radius from the cap's rim (a point on the equator
  // would be 0.3 r from it).
  const AnalyticSphere sphere;
  const auto view = sphere.view(200, 0.3, 0.316, 1);
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(view).ok);
  const auto strategy = gpatlas_core::makeStrategy(kStrategy);
  EXPECT_EQ(strategy->name(), kStrategy);
  gpatlas_core::PlanRequest request;
  request.v_max = 0.1;
  const gpatlas_core::PlanResult plan = strategy->plan(model, request);
  ASSERT_EQ(plan.status, gpatlas_core::PlanStatus::kTouch) << plan.message;
  ASSERT_EQ(plan.touch.points.size(), 1u);
  const gpatlas_core::Vector3 chosen = plan.touch.points[0];
  double nearest_view = std::numeric_limits<double>::infinity();
  for (const auto& point : view) nearest_view = std::min(nearest_view, (point.position - chosen).norm());
  EXPECT_LT(chosen.z(), sphere.centre.z() - 0.3 * sphere.radius) << chosen.transpose();
  EXPECT_GT(nearest_view, 0.8 * sphere.radius) << chosen.transpose();
  EXPECT_GT(plan.touch.variances[0], request.v_max);

  // Its stopping rule ends an exploration, and the touches are what brought the variance down.
  AnalyticSphereProber prober(sphere);
  gpatlas_core::Explorer::Config config;
  config.v_max = 0.1;
  config.max_actions = 60;
  const auto run = gpatlas_core::Explorer(config).run(model, *strategy, prober);
  EXPECT_TRUE(run.converged) << run.stop_reason << " after " << run.actions << " actions";
  EXPECT_GT(run.actions, 0);
  EXPECT_LE(run.final_max_evaluated_variance, config.v_max);
}

// The example reads its own setting (farthest_from_evidence/surface_samples) and the shared
// evidence/ from the settings it is made with, under the namespace it is given, and a value it
// refuses is reported with its full name.
TEST(StrategyLibrary, TheExampleReadsItsOwnSettings) {
  ASSERT_TRUE(loadStrategyLibrary(GPATLAS_EXAMPLE_STRATEGY_LIBRARY).ok);
  std::string error;
  const auto settings = gpatlas_core::YamlParameters::fromString(
      "plugins: {farthest_from_evidence: {surface_samples: 50}, evidence: {max_distance: off}}", &error);
  ASSERT_TRUE(settings) << error;
  gpatlas_core::ParamReader reader(*settings);
  const auto strategy = gpatlas_core::makeStrategy(kStrategy, reader, 0, "plugins");
  EXPECT_TRUE(reader.ok()) << reader.errors();
  EXPECT_TRUE(reader.defaultedNames() ==
              (std::vector<std::string>{"plugins/evidence/view_max_distance", "plugins/evidence/approach_distance_m",
                                        "plugins/evidence/retouch_radius_m", "plugins/evidence/surprise_distance_m"}))
      << reader.defaulted();
  EXPECT_EQ(reader.scope(), "");  // the namespace ends with the strategy's making
  // Its setting is used: a plan samples 50 surface points (the default is 600).
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  ASSERT_TRUE(model.fit(sphere.view(200, -1.0, 0.1, 1)).ok);
  gpatlas_core::PlanRequest request;
  request.v_max = 1e6;
  const gpatlas_core::PlanResult plan = strategy->plan(model, request);
  EXPECT_EQ(plan.status, gpatlas_core::PlanStatus::kConverged) << plan.message;
  EXPECT_NE(plan.message.find("(50 surface samples)"), std::string::npos) << plan.message;
  EXPECT_NE(gpatlas_core::makeStrategy(kStrategy)->plan(model, request).message.find("(600 surface samples)"),
            std::string::npos);

  const auto refused_settings =
      gpatlas_core::YamlParameters::fromString("farthest_from_evidence: {surface_samples: 0}", &error);
  gpatlas_core::ParamReader refused(*refused_settings);
  gpatlas_core::makeStrategy(kStrategy, refused, 0);
  EXPECT_FALSE(refused.ok());
  EXPECT_NE(refused.errors().find("farthest_from_evidence/surface_samples"), std::string::npos) << refused.errors();
}

// The macro, twice in one file, with a factory whose capture list has a comma.
class FixedAnswerStrategy : public gpatlas_core::ExplorationStrategy {
 public:
  FixedAnswerStrategy(std::string name, gpatlas_core::PlanStatus status) : name_(std::move(name)), status_(status) {}
  std::string name() const override { return name_; }
  gpatlas_core::PlanResult plan(const gpatlas_core::SurfaceModel&, const gpatlas_core::PlanRequest&) const override {
    gpatlas_core::PlanResult result;
    result.status = status_;
    return result;
  }

 private:
  std::string name_;
  gpatlas_core::PlanStatus status_;
};

const std::string kFirstName = "test_macro_first";
const gpatlas_core::PlanStatus kFirstStatus = gpatlas_core::PlanStatus::kConverged;
GPATLAS_REGISTER_STRATEGY("test_macro_first", [name = kFirstName, status = kFirstStatus](gpatlas_core::ParamReader&,
                                                                                          std::uint64_t) {
  return std::make_unique<FixedAnswerStrategy>(name, status);
});
GPATLAS_REGISTER_STRATEGY("test_macro_second", [](gpatlas_core::ParamReader&, std::uint64_t) {
  return std::make_unique<FixedAnswerStrategy>("test_macro_second", gpatlas_core::PlanStatus::kError);
});

TEST(StrategyLibrary, TheMacroRegistersEachUse) {
  ASSERT_TRUE(known("test_macro_first"));
  ASSERT_TRUE(known("test_macro_second"));
  const gpatlas_core::GpisModel unfitted;
  EXPECT_EQ(gpatlas_core::makeStrategy("test_macro_first")->plan(unfitted, {}).status,
            gpatlas_core::PlanStatus::kConverged);
  EXPECT_EQ(gpatlas_core::makeStrategy("test_macro_second")->plan(unfitted, {}).status,
            gpatlas_core::PlanStatus::kError);
}

TEST(StrategyLibrary, ReportsWhatWentWrong) {
  const auto missing = loadStrategyLibrary("/nonexistent/libno_strategies.so");
  EXPECT_FALSE(missing.ok);
  EXPECT_NE(missing.message.find("/nonexistent/libno_strategies.so"), std::string::npos) << missing.message;
  const auto unknown_name = loadStrategyLibrary("libno_such_strategy_library.so");
  EXPECT_FALSE(unknown_name.ok);
  EXPECT_NE(unknown_name.message.find("libno_such_strategy_library.so"), std::string::npos) << unknown_name.message;
  // A real library that registers nothing new (the core is already loaded).
  const auto nothing = loadStrategyLibrary(GPATLAS_CORE_LIBRARY);
  EXPECT_FALSE(nothing.ok);
  EXPECT_NE(nothing.message.find("registered no new strategy"), std::string::npos) << nothing.message;
  EXPECT_FALSE(loadStrategyLibrary("").ok);
}

}  // namespace
