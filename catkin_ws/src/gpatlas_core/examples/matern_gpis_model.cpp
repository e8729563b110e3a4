// A surface model of your own, built as a shared library and loaded like a strategy library
// (`strategy_libraries: [libgpatlas_example_models.so]`, `model/type: gpis_matern52`): the global
// GPIS with a Matern 5/2 kernel in place of its default. Its name() is the registered name, by
// which the planner's and the collision map's replicas are rebuilt. It reads gpis/ as the
// built-in model does, and a setting of its own, gpis_matern52/length (the kernel's initial
// length, in the model's normalised frame where the data lie within gpis/data_radius).
#include <gpatlas_core/model/gpis_model.h>
#include <gpatlas_core/model/surface_model_factory.h>

#include <cmath>
#include <memory>

namespace {

class MaternGpisModel : public gpatlas_core::GpisModel {
 public:
  static constexpr const char* kName = "gpis_matern52";
  // Matern52Kernel's own default.
  static constexpr double kDefaultLength = 0.3;

  MaternGpisModel(gpatlas_core::GpisModelConfig config, double length)
      : GpisModel(withMatern(std::move(config), length)) {}
  std::string name() const override { return kName; }
  std::unique_ptr<gpatlas_core::SurfaceModel> clone() const override { return std::make_unique<MaternGpisModel>(*this); }

 private:
  static gpatlas_core::GpisModelConfig withMatern(gpatlas_core::GpisModelConfig config, double length) {
    config.kernel = "matern52";
    config.initial_params = {std::log(1.0), std::log(length)};  // log sigma, log length
    return config;
  }
};

}  // namespace

GPATLAS_REGISTER_SURFACE_MODEL(MaternGpisModel::kName, [](gpatlas_core::ParamReader& settings) -> gpatlas_core::SurfaceModelMaker {
  gpatlas_core::GpisModelConfig gpis;
  gpatlas_core::readGpis(settings, &gpis);
  const double length = settings.number("gpis_matern52/length", MaternGpisModel::kDefaultLength, 1e-3, 10.0);
  return [gpis, length] { return std::make_unique<MaternGpisModel>(gpis, length); };
});
