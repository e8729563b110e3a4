// Planner benchmarks, linked into gpatlas_core_benchmark (BENCHMARK_MAIN is in core_benchmark.cpp).
//   BM_PlanNextTouch/N     one GPAtlasRRT plan (atlas_poke) on a GP of N observations of the top
//                          of a 10 cm sphere; the time includes growing the atlas until a chart
//                          above V_max is found.
//   BM_PlanBaseline/N/S    one plan of a baseline (S: 0 random, 1 max_variance) on the same GP:
//                          600 seeds projected onto the surface, their variance and evidence.
//   BM_ExploreSphere/S     whole explorations of the analytic sphere with strategy S (0 atlas_poke,
//                          1 atlas_slide, 2 random, 3 max_variance) over 5 seeds; the counters
//                          give the mean actions to converge and the final shape RMSE.
//   BM_PlanAtlas/N/M/R     one plan of the default model (multi-scale GPIS) on N view points of the
//                          upper half of the sphere, stop rule 5 mm: M 0 atlas_poke, 1 atlas_slide;
//                          R 0 from scratch, 1 right after a poke with the previous plan's atlas
//                          (what each plan of an exploration but the first does).
//   BM_TouchUpdate/N/M     one touch added to that model by the loop's update (applyTouch): M 0 a
//                          poke (one contact, its approach's free space), 1 a slide (300 contacts
//                          along a 10 cm arc, thinned by touch/min_point_spacing_m).
// V_max = 0.1 in the model's reported units, which are the paper's whatever the kernel (posterior
// variance x 8 / k(0)); noise variance 0.1 on every point as in the paper's reference code.
#include "gpatlas_core/planning/strategy_registry.h"
#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"
#include "gpatlas_core/observations/touch_training.h"
#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_geometry/shape_metrics.h"
#include "gpatlas_geometry/surface_mesher.h"

#include "gpatlas_core/testing/analytic_sphere.h"

#include <benchmark/benchmark.h>

#include <cmath>
#include <map>

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
  const auto strategy = gpatlas_core::makeStrategy("atlas_poke");
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
  const auto strategy = gpatlas_core::makeStrategy(name);
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
      gpatlas_core::Explorer::Config config;
      config.v_max = kVMax;
      config.max_actions = 200;
      config.seed = static_cast<std::uint64_t>(seed);
      const gpatlas_core::ExplorationResult result =
          gpatlas_core::Explorer(config).run(model, *gpatlas_core::makeStrategy(name, static_cast<std::uint64_t>(seed)), prober);
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

// The view of the sphere's upper half (N points), fitted once per size and shared by the runs.
const gpatlas_core::MultiscaleGpisModel& viewedSphere(int n) {
  static std::map<int, gpatlas_core::MultiscaleGpisModel> models;
  auto found = models.find(n);
  if (found == models.end()) {
    gpatlas_core::MultiscaleGpisModel model;
    model.fit(AnalyticSphere().view(n, 0.0, 0.1, 1));
    found = models.emplace(n, std::move(model)).first;
  }
  return found->second;
}

// A poke's measurements at the sphere's point in `direction`: the contact, and free space along
// the last 5 cm of its approach.
gpatlas_core::ProbeResult pokeAt(const AnalyticSphere& sphere, const Eigen::Vector3d& direction) {
  gpatlas_core::ProbeResult probed;
  const Eigen::Vector3d normal = direction.normalized();
  const Eigen::Vector3d point = sphere.centre + sphere.radius * normal;
  probed.contacts.push_back({point, normal});
  for (int k = 1; k <= 10; ++k) probed.free_space.push_back(point + 0.005 * k * normal);
  return probed;
}

// A slide's: `count` contacts along an arc of 10 cm over the unseen side, free space above each.
gpatlas_core::ProbeResult slideOver(const AnalyticSphere& sphere, int count) {
  gpatlas_core::ProbeResult probed;
  for (int k = 0; k < count; ++k) {
    const double angle = -0.2 - 1.0 * k / count;  // radians below the equator, 10 cm of arc
    const Eigen::Vector3d normal(std::cos(angle), 0.2, std::sin(angle));
    const Eigen::Vector3d point = sphere.centre + sphere.radius * normal.normalized();
    probed.contacts.push_back({point, normal.normalized()});
    probed.free_space.push_back(point + 0.01 * normal.normalized());
  }
  return probed;
}

void BM_PlanAtlas(benchmark::State& state) {
  const char* const name = state.range(1) == 0 ? "atlas_poke" : "atlas_slide";
  const bool after_touch = state.range(2) == 1;
  state.SetLabel(std::string(name) + (after_touch ? ", after a poke" : ", from scratch"));
  const AnalyticSphere sphere;
  const gpatlas_core::MultiscaleGpisModel& before = viewedSphere(static_cast<int>(state.range(0)));
  gpatlas_core::MultiscaleGpisModel touched(before);
  const gpatlas_core::TouchObservationConfig touch;
  gpatlas_core::applyTouch(touched, pokeAt(sphere, Eigen::Vector3d(0.5, 0.3, -0.8)).contacts,
                           pokeAt(sphere, Eigen::Vector3d(0.5, 0.3, -0.8)).free_space, touch);
  const auto strategy = gpatlas_core::makeStrategy(name);
  gpatlas_core::PlanRequest request;
  request.v_max = kVMax;
  request.max_position_sd_m = 0.005;
  request.touch_observations = touch;
  double charts = 0.0, queries = 0.0, exhausted = 0.0;
  for (auto _ : state) {
    if (after_touch) {
      state.PauseTiming();
      strategy->plan(before, request);  // the previous plan, whose atlas the next one reuses
      state.ResumeTiming();
    }
    const gpatlas_core::PlanResult result = strategy->plan(after_touch ? touched : before, request);
    if (result.status == gpatlas_core::PlanStatus::kError) {
      state.SkipWithError(result.message.c_str());
      return;
    }
    charts += static_cast<double>(result.atlas->atlas.size());
    queries += static_cast<double>(result.atlas->queries);
    exhausted += result.budget_exhausted ? 1.0 : 0.0;
  }
  state.counters["charts"] = benchmark::Counter(charts, benchmark::Counter::kAvgIterations);
  state.counters["queries"] = benchmark::Counter(queries, benchmark::Counter::kAvgIterations);
  state.counters["budget_ended"] = benchmark::Counter(exhausted, benchmark::Counter::kAvgIterations);
}

void BM_TouchUpdate(benchmark::State& state) {
  const bool slide = state.range(1) == 1;
  state.SetLabel(slide ? "slide (300 contacts)" : "poke");
  const AnalyticSphere sphere;
  const gpatlas_core::MultiscaleGpisModel& base = viewedSphere(static_cast<int>(state.range(0)));
  const gpatlas_core::ProbeResult probed = slide ? slideOver(sphere, 300) : pokeAt(sphere, Eigen::Vector3d(0.5, 0.3, -0.8));
  double added = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    gpatlas_core::MultiscaleGpisModel model(base);
    state.ResumeTiming();
    const gpatlas_core::TouchUpdate update =
        gpatlas_core::applyTouch(model, probed.contacts, probed.free_space, gpatlas_core::TouchObservationConfig());
    if (!update.ok) {
      state.SkipWithError(update.message.c_str());
      return;
    }
    added += update.points_added;
  }
  state.counters["points_added"] = benchmark::Counter(added, benchmark::Counter::kAvgIterations);
}

}  // namespace

BENCHMARK(BM_PlanAtlas)->ArgsProduct({{2000, 8000, 20000}, {0, 1}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_TouchUpdate)->ArgsProduct({{2000, 8000, 20000}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlanNextTouch)->Arg(250)->Arg(1000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PlanBaseline)->ArgsProduct({{250, 1000}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ExploreSphere)->DenseRange(0, 3)->Unit(benchmark::kSecond)->Iterations(1);
