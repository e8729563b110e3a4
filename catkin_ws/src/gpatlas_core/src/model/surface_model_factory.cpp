#include "gpatlas_core/model/surface_model_factory.h"

#include "gpatlas_core/common/named_factories.h"

#include <cmath>
#include <stdexcept>

namespace gpatlas_core {

namespace {

NamedFactories<SurfaceModelFactory>& registry() {
  static NamedFactories<SurfaceModelFactory> instance({
      {GpisModel::kName,
       [](ParamReader& settings) -> SurfaceModelMaker {
         GpisModelConfig gpis;
         readGpis(settings, &gpis);
         return [gpis] { return std::make_unique<GpisModel>(gpis); };
       }},
      {MultiscaleGpisModel::kName,
       [](ParamReader& settings) -> SurfaceModelMaker {
         GpisModelConfig coarse;
         readGpis(settings, &coarse);
         MultiscaleGpisConfig multiscale;
         readMultiscale(settings, &multiscale);
         return [multiscale, coarse] { return std::make_unique<MultiscaleGpisModel>(multiscale, coarse); };
       }},
  });
  return instance;
}

}  // namespace

SurfaceModelMaker surfaceModelMaker(const std::string& name, ParamReader& settings, const std::string& ns) {
  const SurfaceModelFactory factory = registry().find(name);
  if (!factory) throw std::invalid_argument("unknown surface model '" + name + "'; known: " + registry().namesJoined());
  const ParamReader::Scope section(settings, ns);
  return factory(settings);
}

std::unique_ptr<SurfaceModel> makeSurfaceModel(const SurfaceModelConfig& config) {
  if (const auto read = config.makers.find(config.type); read != config.makers.end()) return read->second();
  const NoParameters none;
  ParamReader defaults(none);
  return surfaceModelMaker(config.type, defaults)();
}

bool registerSurfaceModel(const std::string& name, SurfaceModelFactory factory) {
  return registry().add(name, std::move(factory));
}

std::vector<std::string> surfaceModelNames() { return registry().names(); }

void readGpis(ParamReader& r, GpisModelConfig* c) {
  c->kernel = r.text("gpis/kernel", c->kernel);
  // Kernel parameters in natural units (Wendland and thin plate: R); empty: the kernel's own.
  const std::vector<double> params = r.numbers("gpis/kernel_params", {});
  c->initial_params.clear();
  for (double p : params) {
    if (!(p > 0.0)) {
      r.invalid("gpis/kernel_params", "must be positive");
      c->initial_params.clear();
      break;
    }
    c->initial_params.push_back(std::log(p));
  }
  // The fixed renormalise_radius lies between them (data < renormalise <= domain); the kernel's
  // range is checked by the model.
  c->data_radius = r.number("gpis/data_radius", c->data_radius, 1e-3, std::nextafter(c->renormalise_radius, 0.0));
  c->domain_radius = r.number("gpis/domain_radius", c->domain_radius, c->renormalise_radius, 100.0);
  c->inside_point_at_centroid = r.flag("gpis/inside_point_at_centroid", c->inside_point_at_centroid);
  // The model checks what no single parameter can (kernel name, radii ordering, the kernel's
  // valid range): every reader falls back to the same defaults, so replicas stay exact.
  try {
    GpisModel check(*c);
  } catch (const std::exception& e) {
    r.invalid("gpis", std::string(e.what()) + " (all gpis/ defaults used)");
    *c = GpisModelConfig();
  }
}

void readMultiscale(ParamReader& r, MultiscaleGpisConfig* c) {
  const MultiscaleGpisConfig defaults;
  c->coarse_max_surface_points = static_cast<std::size_t>(r.integer(
      "multiscale/coarse_max_surface_points", static_cast<int>(c->coarse_max_surface_points), 4, 100000));
  c->coarse_probe_voxel_m = r.number("multiscale/coarse_probe_voxel_m", c->coarse_probe_voxel_m, 1e-4, 1.0);
  c->cell_size_m = r.number("multiscale/cell_size_m", c->cell_size_m, 1e-3, 1.0);
  c->overlap_m = r.number("multiscale/overlap_m", c->overlap_m, 0.0, 0.5);
  c->sigma = r.number("multiscale/sigma", c->sigma, 1e-6, 100.0);
  c->length_m = r.number("multiscale/length_m", c->length_m, 1e-5, 1.0);
  c->noise_m = r.number("multiscale/noise_m", c->noise_m, 1e-7, 1.0);
  c->tune_on_fit = r.flag("multiscale/tune_on_fit", c->tune_on_fit);
  // The model checks what no single parameter can (the overlap against the cell, the bounds'
  // order): every reader falls back to the same defaults, so replicas stay exact.
  try {
    MultiscaleGpisModel check(*c);
  } catch (const std::exception& e) {
    r.invalid("multiscale", std::string(e.what()) + " (all multiscale/ defaults used)");
    *c = defaults;
  }
}

}  // namespace gpatlas_core
