#pragma once

#include <Eigen/Core>

#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace gpatlas_core {

// A stationary isotropic covariance function k(r), r = |x - x'|, in the model's normalised
// frame. Hyperparameters are exposed as natural logarithms so that optimisers work on an
// unbounded, scale-free parameterisation.
class Kernel {
 public:
  virtual ~Kernel() = default;

  virtual std::string name() const = 0;
  virtual std::unique_ptr<Kernel> clone() const = 0;

  virtual int numParams() const = 0;
  virtual std::vector<std::string> paramNames() const = 0;
  virtual Eigen::VectorXd logParams() const = 0;
  virtual void setLogParams(const Eigen::VectorXd& log_params) = 0;

  // k(r).
  virtual double value(double r) const = 0;
  // dk/dr; zero at r = 0 for every kernel here (they are all differentiable at the origin).
  virtual double derivative(double r) const = 0;
  // d2k/dr2, for observations of f's slope (their covariances hold the kernel's second
  // derivatives). The default differentiates derivative() numerically; the kernels here override
  // it with the exact form.
  virtual double secondDerivative(double r) const;
  // k(r) and dk/dr / r for many distances at once: the inner loop of every prediction, where a
  // virtual call per training point costs more than the kernel itself. dk/dr / r is 0 at r = 0
  // (the direction (x - x') / r it multiplies vanishes there). The defaults call value() and
  // derivative(); a kernel overrides them with array code giving the same numbers.
  virtual void values(const Eigen::ArrayXd& r, Eigen::ArrayXd* k) const;
  virtual void derivativesOverDistance(const Eigen::ArrayXd& r, Eigen::ArrayXd* dk_over_r) const;
  // dk/d(log theta_j) for every hyperparameter, written into out (size numParams()).
  virtual void paramGradient(double r, double* out) const = 0;

  // Largest distance for which the kernel is a valid (positive definite) covariance;
  // infinity for the kernels that are valid everywhere.
  virtual double maxValidDistance() const;

  // Gradient of k(|x - y|) with respect to x.
  Eigen::Vector3d gradient(const Eigen::Vector3d& x, const Eigen::Vector3d& y) const;
  double priorVariance() const { return value(0.0); }
};

// Creates a kernel by name: "thin_plate", "wendland" (parameter: R), "squared_exponential",
// "matern32", "matern52" (parameters: signal sigma, length scale). Throws
// std::invalid_argument with the list of known names for an unknown name.
std::unique_ptr<Kernel> makeKernel(const std::string& name);
std::vector<std::string> kernelNames();
// Adds a kernel to the registry so that configs can name it; returns false if the name is taken.
bool registerKernel(const std::string& name, std::function<std::unique_ptr<Kernel>()> factory);

// Shared base of the kernels whose single parameter is a radius R (prior variance R^3).
class RadiusKernel : public Kernel {
 public:
  explicit RadiusKernel(double radius) : radius_(radius) {}
  int numParams() const override { return 1; }
  std::vector<std::string> paramNames() const override { return {"R"}; }
  Eigen::VectorXd logParams() const override;
  void setLogParams(const Eigen::VectorXd& log_params) override;
  double radius() const { return radius_; }

 protected:
  double radius_;
};

// Thin-plate covariance of Williams and Fitzgibbon (paper eq. 6):
// k(r) = 2 r^3 - 3 R r^2 + R^3, a valid covariance for r <= R.
class ThinPlateKernel : public RadiusKernel {
 public:
  explicit ThinPlateKernel(double radius = 2.0) : RadiusKernel(radius) {}
  std::string name() const override { return "thin_plate"; }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<ThinPlateKernel>(*this); }
  double value(double r) const override;
  double derivative(double r) const override;
  double secondDerivative(double r) const override;
  void paramGradient(double r, double* out) const override;
  double maxValidDistance() const override { return radius_; }
};

// Wendland's compactly supported C2 function for three dimensions (psi_{3,1}), scaled like the
// thin-plate kernel: k(r) = R^3 (1 - r/R)^4 (4 r/R + 1) for r < R, 0 beyond.
// The paper's thin-plate kernel is R^3 (1 - t)^2 (2t + 1), t = r/R: the member psi_{1,1} of the
// same Wendland family, which is positive definite only in one dimension. In 3-D its Gram
// matrices have negative eigenvalues (about -0.2 for 400 points in the unit ball with R = 2),
// which a noise variance of 0.1 per point has to hide: such noise blurs the surface by about a
// centimetre on a 15 cm object, and with less noise dense touches make the matrix singular.
// psi_{3,1} is the lowest-degree C2 member that is positive definite in R^3 for every R, so
// it is a valid covariance at any distance (no domain limit), with the same single parameter
// and prior variance R^3. Near 0 it falls as R^3 (1 - 10 t^2): with R = 2 sqrt(10/3) = 3.65 (the
// default) its correlation k(r)/k(0) has the thin-plate's (R = 2) curvature at the origin.
class WendlandKernel : public RadiusKernel {
 public:
  explicit WendlandKernel(double radius = 3.65) : RadiusKernel(radius) {}
  std::string name() const override { return "wendland"; }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<WendlandKernel>(*this); }
  double value(double r) const override;
  double derivative(double r) const override;
  double secondDerivative(double r) const override;
  void values(const Eigen::ArrayXd& r, Eigen::ArrayXd* k) const override;
  void derivativesOverDistance(const Eigen::ArrayXd& r, Eigen::ArrayXd* dk_over_r) const override;
  void paramGradient(double r, double* out) const override;
};

// Shared base of the kernels with a signal standard deviation and a length scale.
class ScaledKernel : public Kernel {
 public:
  ScaledKernel(double sigma, double length) : sigma_(sigma), length_(length) {}
  int numParams() const override { return 2; }
  std::vector<std::string> paramNames() const override { return {"sigma", "length"}; }
  Eigen::VectorXd logParams() const override;
  void setLogParams(const Eigen::VectorXd& log_params) override;
  double sigma() const { return sigma_; }
  double length() const { return length_; }

 protected:
  double sigma_;
  double length_;
};

class SquaredExponentialKernel : public ScaledKernel {
 public:
  explicit SquaredExponentialKernel(double sigma = 1.0, double length = 0.3) : ScaledKernel(sigma, length) {}
  std::string name() const override { return "squared_exponential"; }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<SquaredExponentialKernel>(*this); }
  double value(double r) const override;
  double derivative(double r) const override;
  double secondDerivative(double r) const override;
  void paramGradient(double r, double* out) const override;
};

class Matern32Kernel : public ScaledKernel {
 public:
  explicit Matern32Kernel(double sigma = 1.0, double length = 0.3) : ScaledKernel(sigma, length) {}
  std::string name() const override { return "matern32"; }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<Matern32Kernel>(*this); }
  double value(double r) const override;
  double derivative(double r) const override;
  double secondDerivative(double r) const override;
  void paramGradient(double r, double* out) const override;
};

// k(r) = sigma^2 (1 + a + a^2 / 3) e^-a, a = sqrt(5) r / length. Final, with value() and
// derivativeOverDistance() inline: the multiscale model's local cells call them in their inner
// loops through this type.
class Matern52Kernel final : public ScaledKernel {
 public:
  explicit Matern52Kernel(double sigma = 1.0, double length = 0.3) : ScaledKernel(sigma, length) {}
  std::string name() const override { return "matern52"; }
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<Matern52Kernel>(*this); }
  double value(double r) const override {
    const double a = kSqrt5 * r / length_;
    return sigma_ * sigma_ * (1.0 + a + a * a / 3.0) * std::exp(-a);
  }
  // (dk/dr) / r = -sigma^2 (5 / (3 length^2)) (1 + a) e^-a, finite at r = 0.
  double derivativeOverDistance(double r) const {
    const double a = kSqrt5 * r / length_;
    return -sigma_ * sigma_ * (5.0 / (3.0 * length_ * length_)) * (1.0 + a) * std::exp(-a);
  }
  double derivative(double r) const override;
  double secondDerivative(double r) const override;
  void paramGradient(double r, double* out) const override;

 private:
  static constexpr double kSqrt5 = 2.23606797749979;
};

}  // namespace gpatlas_core
