// Planner benchmarks, linked into gpatlas_core_benchmark (BENCHMARK_MAIN is in core_benchmark.cpp).
//   BM_PlanNextTouch/N     one GPAtlasRRT plan (atlas_poke) on a GP of N observations of the top
//                          of a 10 cm sphere; the time includes growing the atlas until a chart
//                          above V_max is found.
//   BM_PlanBaseline/N/S    one plan of a baseline (S: 0 random, 1 max_variance) on the same GP:
//                          600 seeds projected onto the surface, their variance and evidence.
//   BM_ExploreSphere/S     whole explorations of the analytic sphere with strategy S (0 atlas_poke,
//                          1 atlas_slide, 2 random, 3 max_variance) over 5 seeds; the counters
//                          give the mean actions to converge and the final shape RMSE.
// V_max = 0.1 in the model's reported units, which are the paper's whatever the kernel (posterior
// variance x 8 / k(0)); noise variance 0.1 on every point as in the paper's reference code.
#include "gpatlas_core/planning/strategy_registry.h"
#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_geometry/shape_metrics.h"
#include "gpatlas_geometry/surface_mesher.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <benchmark/benchmark.h>

namespace {

using gpatlas_core::testing::AnalyticSphere;
using gpatlas_core::testing::AnalyticSphereProber;

constexpr double kNoiseSigma = 0.316;
constexpr double kVMax = 0.1;

void BM_PlanNextTouch(benchmark::State& state) {
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  if (!model.fit(sphere.view(static_cast<int>(state.range(0)), 0.3, kNoiseSigma, 1)).ok) {
    state.SkipWithError("fit failed");
    return;
  }
  gpatlas_core::StrategyConfig config;
  const auto strategy = gpatlas_core::makeStrategy("atlas_poke", config);
  gpatlas_core::PlanRequest request;
  request.v_max = kVMax;
  std::uint64_t plan_index = 0;
  double charts = 0.0;
  for (auto _ : state) {
    request.seed = plan_index++;  // a fresh random root each time, as in an exploration
    const gpatlas_core::PlanResult result = strategy->plan(model, request);
    if (result.status != gpatlas_core::PlanStatus::kTouch) {
      state.SkipWithError(result.message.c_str());
      return;
    }
    charts += static_cast<double>(result.atlas->atlas.size());
  }
  state.counters["charts"] = benchmark::Counter(charts, benchmark::Counter::kAvgIterations);
}

void BM_PlanBaseline(benchmark::State& state) {
  static const char* const kStrategies[] = {"random", "max_variance"};
  const std::string name = kStrategies[state.range(1)];
  state.SetLabel(name);
  const AnalyticSphere sphere;
  gpatlas_core::GpisModel model;
  if (!model.fit(sphere.view(static_cast<int>(state.range(0)), 0.3, kNoiseSigma, 1)).ok) {
    state.SkipWithError("fit failed");
    return;
  }
  const auto strategy = gpatlas_core::makeStrategy(name, gpatlas_core::StrategyConfig());
  gpatlas_core::PlanRequest request;
  request.v_max = kVMax;
  std::uint64_t plan_index = 0;
  for (auto _ : state) {
    request.seed = plan_index++;
    const gpatlas_core::PlanResult result = strategy->plan(model, request);
    if (result.status != gpatlas_core::PlanStatus::kTouch) {
      state.SkipWithError(result.message.c_str());
      return;
    }
  }
}

void BM_ExploreSphere(benchmark::State& state) {
  static const char* const kStrategies[] = {"atlas_poke", "atlas_slide", "random", "max_variance"};
  const std::string name = kStrategies[state.range(0)];
  state.SetLabel(name);
  constexpr int kSeeds = 5;
  double actions = 0.0, converged = 0.0, rmse = 0.0;
  for (auto _ : state) {
    for (int seed = 1; seed <= kSeeds; ++seed) {
      const AnalyticSphere sphere;
      gpatlas_core::GpisModel model;
      if (!model.fit(sphere.view(150, 0.3, kNoiseSigma, static_cast<unsigned>(seed))).ok) {
        state.SkipWithError("fit failed");
        return;
      }
      AnalyticSphereProber prober(sphere);
      gpatlas_core::StrategyConfig strategy_config;
      strategy_config.seed = static_cast<std::uint64_t>(seed);
      gpatlas_core::Explorer::Config config;
      config.v_max = kVMax;
      config.max_actions = 200;
      config.seed = static_cast<std::uint64_t>(seed);
      const gpatlas_core::ExplorationResult result =
          gpatlas_core::Explorer(config).run(model, *gpatlas_core::makeStrategy(name, strategy_config), prober);
      actions += result.actions;
      converged += result.converged ? 1.0 : 0.0;
      gpatlas_geometry::SurfaceMesher::Config mesher;
      mesher.resolution_m = 0.005;
      const auto meshed = gpatlas_geometry::SurfaceMesher(mesher).mesh(model);
      const auto metrics = gpatlas_geometry::ShapeMetrics().compare(
          meshed.mesh, gpatlas_core::makeIcosphere(sphere.centre, sphere.radius, 4));
      rmse += 0.5 * (metrics.rmse_predicted_to_truth + metrics.rmse_truth_to_predicted);
    }
  }
  const double runs = static_cast<double>(kSeeds) * static_cast<double>(state.iterations());
  state.counters["actions"] = actions / runs;
  state.counters["converged"] = converged / runs;
  state.counters["rmse_mm"] = 1000.0 * rmse / runs;
}

}  // namespace

BENCHMARK(BM_PlanNextTouch)->Arg(250)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlanBaseline)->ArgsProduct({{250, 1000}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ExploreSphere)->DenseRange(0, 3)->Unit(benchmark::kSecond)->Iterations(1);
