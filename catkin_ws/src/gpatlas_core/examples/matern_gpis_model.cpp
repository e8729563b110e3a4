// A surface model of your own, built as a shared library and loaded like a strategy library
// (`strategy_libraries: [libgpatlas_example_models.so]`, `model/type: gpis_matern52`): the global
// GPIS with a Matern 5/2 kernel in place of its default. Its name() is the registered name, by
// which the planner's and the collision map's replicas are rebuilt.
#include <gpatlas_core/model/gpis_model.h>
#include <gpatlas_core/model/surface_model_factory.h>

#include <memory>

namespace {

class MaternGpisModel : public gpatlas_core::GpisModel {
 public:
  static constexpr const char* kName = "gpis_matern52";

  explicit MaternGpisModel(gpatlas_core::GpisModelConfig config) : GpisModel(withMatern(std::move(config))) {}
  std::string name() const override { return kName; }
  std::unique_ptr<gpatlas_core::SurfaceModel> clone() const override { return std::make_unique<MaternGpisModel>(*this); }

 private:
  static gpatlas_core::GpisModelConfig withMatern(gpatlas_core::GpisModelConfig config) {
    config.kernel = "matern52";
    config.initial_params.clear();
    return config;
  }
};

}  // namespace

GPATLAS_REGISTER_SURFACE_MODEL(MaternGpisModel::kName, [](const gpatlas_core::SurfaceModelConfig& config) {
  return std::make_unique<MaternGpisModel>(config.gpis);
});
