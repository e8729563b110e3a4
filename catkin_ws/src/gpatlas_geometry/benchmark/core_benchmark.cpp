// Micro-benchmarks of the GPIS core. Run: make bench-core (or the binary in the devel space).
#include "gpatlas_core/exploration/explorer.h"
#include "gpatlas_core/model/gpis_model.h"
#include "gpatlas_core/model/multiscale_gpis_model.h"

#include <benchmark/benchmark.h>

#include <random>

namespace {

using gpatlas_core::GpisModel;
using gpatlas_core::TrainingPoint;

// Noisy points on the upper part of a 10 cm sphere: the shape of a partial camera view.
std::vector<TrainingPoint> viewOfSphere(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<TrainingPoint> pts;
  while (static_cast<int>(pts.size()) < count) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    if (d.z() < -0.3) continue;
    TrainingPoint p;
    p.position = Eigen::Vector3d(0.7, 0.0, 0.1) + 0.1 * d;
    p.noise_sigma = 0.1;
    pts.push_back(p);
  }
  return pts;
}

gpatlas_core::Points3 queryPoints(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  gpatlas_core::Points3 q(3, count);
  for (int j = 0; j < count; ++j) q.col(j) = Eigen::Vector3d(0.7 + u(rng), u(rng), 0.1 + u(rng));
  return q;
}

void BM_FullFit(benchmark::State& state) {
  const auto pts = viewOfSphere(static_cast<int>(state.range(0)), 1);
  for (auto _ : state) {
    GpisModel model;
    benchmark::DoNotOptimize(model.fit(pts).ok);
  }
}

void BM_AddPoints(benchmark::State& state) {
  const auto pts = viewOfSphere(static_cast<int>(state.range(0)), 1);
  const auto extra = viewOfSphere(64, 2);
  GpisModel base;
  base.fit(pts);
  std::size_t next = 0;
  for (auto _ : state) {
    state.PauseTiming();
    GpisModel model(base);  // every iteration adds to a model of exactly N points
    state.ResumeTiming();
    benchmark::DoNotOptimize(model.addPoints({extra[next++ % extra.size()]}).ok);
  }
}

void BM_PredictMeanVariance(benchmark::State& state) {
  GpisModel model;
  model.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  const auto q = queryPoints(1000, 3);
  for (auto _ : state) benchmark::DoNotOptimize(model.predictBatch(q, true, false).variance.sum());
  state.SetItemsProcessed(state.iterations() * q.cols());
}

// The mean alone (what the mesher asks for at every grid node).
void BM_PredictMean(benchmark::State& state) {
  GpisModel model;
  model.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  const auto q = queryPoints(1000, 3);
  for (auto _ : state) benchmark::DoNotOptimize(model.predictBatch(q, false, false, false).mean.sum());
  state.SetItemsProcessed(state.iterations() * q.cols());
}

void BM_PredictLoop(benchmark::State& state) {
  GpisModel model;
  model.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  const auto q = queryPoints(1000, 3);
  for (auto _ : state) {
    double sum = 0.0;
    // The same quantities as the batch (mean, variance, mean gradient), one point at a time.
    for (int j = 0; j < q.cols(); ++j) sum += model.predictBatch(q.col(j), true, false).variance[0];
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * q.cols());
}

// ---- MultiscaleGpisModel at the sizes it is for (a 2 mm voxel grid of a view: 10,000-40,000
// points), tuning on fit included (its default).
using gpatlas_core::MultiscaleGpisModel;

void BM_MultiscaleFit(benchmark::State& state) {
  const auto pts = viewOfSphere(static_cast<int>(state.range(0)), 1);
  for (auto _ : state) {
    MultiscaleGpisModel model;
    benchmark::DoNotOptimize(model.fit(pts).ok);
  }
}

// Contacts (with their measured normals' positions on the unseen underside) added in one call to
// a model of N view points.
void BM_MultiscaleAddContacts(benchmark::State& state) {
  MultiscaleGpisModel base;
  base.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  std::vector<TrainingPoint> contacts;
  std::mt19937 rng(4);
  std::normal_distribution<double> g;
  while (static_cast<int>(contacts.size()) < state.range(1)) {
    Eigen::Vector3d d(g(rng), g(rng), g(rng));
    d.normalize();
    TrainingPoint p;
    p.position = Eigen::Vector3d(0.7, 0.0, 0.1) + 0.1 * d;
    p.noise_sigma = 0.1;
    p.source = gpatlas_core::PointSource::kTouch;
    contacts.push_back(p);
  }
  for (auto _ : state) {
    state.PauseTiming();
    MultiscaleGpisModel model(base);
    state.ResumeTiming();
    benchmark::DoNotOptimize(model.addPoints(contacts).ok);
  }
}

// A tactile pad's press on the unseen underside of a model of N view points: a patch of P contacts
// with their normals over a 1 cm disc, through the loop's update (applyTouch: the gate, the
// thinning, the normals' slopes, the model's update). Third argument: 1 the default thinning
// (touch/min_point_spacing_m, 4 mm), 0 every point (no spacing, no per-touch cap).
void BM_MultiscaleApplyPatch(benchmark::State& state) {
  MultiscaleGpisModel base;
  base.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  const Eigen::Vector3d centre(0.7, 0.0, 0.1), axis = Eigen::Vector3d(0.6, 0.0, -0.8).normalized();
  const Eigen::Vector3d a = axis.unitOrthogonal(), b = axis.cross(a);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-0.1, 0.1);
  std::vector<gpatlas_core::Contact> patch;
  while (static_cast<int>(patch.size()) < state.range(1)) {
    const double s = u(rng), t = u(rng);
    if (s * s + t * t > 0.01) continue;
    const Eigen::Vector3d d = (axis + s * a + t * b).normalized();
    patch.push_back({centre + 0.1 * d, d});
  }
  gpatlas_core::TouchObservationConfig config;
  if (state.range(2) == 0) {
    config.min_point_spacing_m = 0.0;
    config.max_contacts_per_touch = std::nullopt;
  }
  int added = 0;
  for (auto _ : state) {
    state.PauseTiming();
    MultiscaleGpisModel model(base);
    state.ResumeTiming();
    const gpatlas_core::TouchUpdate update = gpatlas_core::applyTouch(model, patch, {}, config);
    added = update.points_added;
    benchmark::DoNotOptimize(update.ok);
  }
  state.counters["training_points_added"] = added;
}

// Queries within 5 mm of the surface (where the planner and the mesher ask, and where the cells
// are): the expensive case, unlike queryPoints' box.
gpatlas_core::Points3 nearSurfaceQueries(int count, unsigned seed) {
  const auto on = viewOfSphere(count, seed);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-0.005, 0.005);
  gpatlas_core::Points3 q(3, count);
  for (int j = 0; j < count; ++j) q.col(j) = on[static_cast<std::size_t>(j)].position + Eigen::Vector3d(u(rng), u(rng), u(rng));
  return q;
}

void BM_MultiscalePredictMeanVariance(benchmark::State& state) {
  MultiscaleGpisModel model;
  model.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  const auto q = state.range(1) ? nearSurfaceQueries(1000, 3) : queryPoints(1000, 3);
  for (auto _ : state) benchmark::DoNotOptimize(model.predictBatch(q, true, false).variance.sum());
  state.SetItemsProcessed(state.iterations() * q.cols());
}

void BM_MultiscalePredictMean(benchmark::State& state) {
  MultiscaleGpisModel model;
  model.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  const auto q = state.range(1) ? nearSurfaceQueries(1000, 3) : queryPoints(1000, 3);
  for (auto _ : state) benchmark::DoNotOptimize(model.predictBatch(q, false, false, false).mean.sum());
  state.SetItemsProcessed(state.iterations() * q.cols());
}

// One query per call near the surface (mean, variance, mean gradient), as a planner's loop asks.
void BM_MultiscalePredictLoop(benchmark::State& state) {
  MultiscaleGpisModel model;
  model.fit(viewOfSphere(static_cast<int>(state.range(0)), 1));
  const auto q = nearSurfaceQueries(1000, 3);
  for (auto _ : state) {
    double sum = 0.0;
    for (int j = 0; j < q.cols(); ++j) sum += model.predictBatch(q.col(j), true, false).variance[0];
    benchmark::DoNotOptimize(sum);
  }
  state.SetItemsProcessed(state.iterations() * q.cols());
}

}  // namespace

BENCHMARK(BM_MultiscalePredictLoop)->Arg(10000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MultiscaleFit)->Arg(2000)->Arg(10000)->Arg(40000)->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_MultiscaleAddContacts)->Args({10000, 300})->Args({40000, 300})->Unit(benchmark::kMillisecond)->Iterations(2);
BENCHMARK(BM_MultiscaleApplyPatch)->Args({10000, 2000, 1})->Args({10000, 2000, 0})->Unit(benchmark::kMillisecond)->Iterations(3);
// Second argument: 0 queries in the object's bounding box, 1 within 5 mm of the surface.
BENCHMARK(BM_MultiscalePredictMeanVariance)->ArgsProduct({{10000, 40000}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_MultiscalePredictMean)->ArgsProduct({{10000, 40000}, {0, 1}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_FullFit)->Arg(250)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_AddPoints)->Arg(250)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PredictMeanVariance)->Arg(250)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PredictMean)->Arg(250)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PredictLoop)->Arg(250)->Arg(500)->Arg(1000)->Arg(2000)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
