#include "gpatlas_core/model/kernel.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <mutex>
#include <sstream>
#include <stdexcept>

namespace gpatlas_core {

double Kernel::maxValidDistance() const { return std::numeric_limits<double>::infinity(); }

Eigen::Vector3d Kernel::gradient(const Eigen::Vector3d& x, const Eigen::Vector3d& y) const {
  const Eigen::Vector3d d = x - y;
  const double r = d.norm();
  if (r <= 0.0) return Eigen::Vector3d::Zero();
  return derivative(r) / r * d;
}

void Kernel::values(const Eigen::ArrayXd& r, Eigen::ArrayXd* k) const {
  k->resize(r.size());
  for (Eigen::Index i = 0; i < r.size(); ++i) (*k)[i] = value(r[i]);
}

void Kernel::derivativesOverDistance(const Eigen::ArrayXd& r, Eigen::ArrayXd* dk_over_r) const {
  dk_over_r->resize(r.size());
  for (Eigen::Index i = 0; i < r.size(); ++i) (*dk_over_r)[i] = r[i] > 0.0 ? derivative(r[i]) / r[i] : 0.0;
}

double Kernel::secondDerivative(double r) const {
  // dk/dr vanishes at 0 for every kernel here, so one-sided there; central elsewhere.
  const double h = 1e-6 * std::max(1.0, r);
  if (r < h) return (derivative(r + h) - derivative(r)) / h;
  return (derivative(r + h) - derivative(r - h)) / (2.0 * h);
}

// ------------------------------------------------------------------ thin plate
Eigen::VectorXd RadiusKernel::logParams() const {
  Eigen::VectorXd p(1);
  p << std::log(radius_);
  return p;
}

void RadiusKernel::setLogParams(const Eigen::VectorXd& log_params) {
  if (log_params.size() != 1) throw std::invalid_argument(name() + " kernel takes 1 parameter (log R)");
  radius_ = std::exp(log_params[0]);
}

double ThinPlateKernel::value(double r) const { return 2.0 * r * r * r - 3.0 * radius_ * r * r + radius_ * radius_ * radius_; }

double ThinPlateKernel::derivative(double r) const { return 6.0 * r * (r - radius_); }

void ThinPlateKernel::paramGradient(double r, double* out) const {
  // dk/dlogR = R * dk/dR = R * (3 R^2 - 3 r^2)
  out[0] = 3.0 * radius_ * (radius_ * radius_ - r * r);
}

double ThinPlateKernel::secondDerivative(double r) const { return 12.0 * r - 6.0 * radius_; }

// ------------------------------------------------------------------ Wendland psi_{3,1}

double WendlandKernel::value(double r) const {
  const double t = r / radius_;
  if (t >= 1.0) return 0.0;
  const double u = 1.0 - t;
  return radius_ * radius_ * radius_ * u * u * u * u * (4.0 * t + 1.0);
}

double WendlandKernel::derivative(double r) const {
  // d/dt [(1 - t)^4 (4t + 1)] = -20 t (1 - t)^3, dt/dr = 1/R
  const double t = r / radius_;
  if (t >= 1.0) return 0.0;
  const double u = 1.0 - t;
  return -20.0 * radius_ * radius_ * t * u * u * u;
}

double WendlandKernel::secondDerivative(double r) const {
  // d/dt [-20 t (1 - t)^3] = -20 (1 - t)^2 (1 - 4t)
  const double t = r / radius_;
  if (t >= 1.0) return 0.0;
  const double u = 1.0 - t;
  return -20.0 * radius_ * u * u * (1.0 - 4.0 * t);
}

// The array forms repeat value() and derivative() operation for operation, so they give the same
// bits, with the same branch for t >= 1 (infinite distances included) and NaN for NaN.
void WendlandKernel::values(const Eigen::ArrayXd& r, Eigen::ArrayXd* k) const {
  const double cube = radius_ * radius_ * radius_;
  const Eigen::ArrayXd t = r / radius_;
  const Eigen::ArrayXd u = 1.0 - t;
  *k = (t >= 1.0).select(0.0, cube * u * u * u * u * (4.0 * t + 1.0));
}

void WendlandKernel::derivativesOverDistance(const Eigen::ArrayXd& r, Eigen::ArrayXd* dk_over_r) const {
  const double scale = -20.0 * radius_ * radius_;
  const Eigen::ArrayXd t = r / radius_;
  const Eigen::ArrayXd u = 1.0 - t;
  *dk_over_r = (t >= 1.0).select(0.0, (r > 0.0).select(scale * t * u * u * u / r, 0.0));
}

void WendlandKernel::paramGradient(double r, double* out) const {
  // k = R^3 g(r/R): dk/dlogR = R^3 (3 g(t) - t g'(t)) = R^3 (3 g(t) + 20 t^2 (1 - t)^3)
  const double t = r / radius_;
  if (t >= 1.0) {
    out[0] = 0.0;
    return;
  }
  const double u = 1.0 - t;
  const double g = u * u * u * u * (4.0 * t + 1.0);
  out[0] = radius_ * radius_ * radius_ * (3.0 * g + 20.0 * t * t * u * u * u);
}

// ------------------------------------------------------------------ scaled kernels
Eigen::VectorXd ScaledKernel::logParams() const {
  Eigen::VectorXd p(2);
  p << std::log(sigma_), std::log(length_);
  return p;
}

void ScaledKernel::setLogParams(const Eigen::VectorXd& log_params) {
  if (log_params.size() != 2)
    throw std::invalid_argument(name() + " kernel takes 2 parameters (log sigma, log length)");
  sigma_ = std::exp(log_params[0]);
  length_ = std::exp(log_params[1]);
}

double SquaredExponentialKernel::value(double r) const {
  return sigma_ * sigma_ * std::exp(-0.5 * r * r / (length_ * length_));
}

double SquaredExponentialKernel::derivative(double r) const { return -value(r) * r / (length_ * length_); }

void SquaredExponentialKernel::paramGradient(double r, double* out) const {
  const double k = value(r);
  out[0] = 2.0 * k;
  out[1] = k * r * r / (length_ * length_);
}

double SquaredExponentialKernel::secondDerivative(double r) const {
  const double inv_l2 = 1.0 / (length_ * length_);
  return value(r) * inv_l2 * (r * r * inv_l2 - 1.0);
}

namespace {
constexpr double kSqrt3 = 1.7320508075688772;
}  // namespace

double Matern32Kernel::value(double r) const {
  const double a = kSqrt3 * r / length_;
  return sigma_ * sigma_ * (1.0 + a) * std::exp(-a);
}

double Matern32Kernel::derivative(double r) const {
  const double a = kSqrt3 * r / length_;
  // dk/da = -s^2 a e^-a, da/dr = sqrt(3)/l
  return -sigma_ * sigma_ * a * std::exp(-a) * kSqrt3 / length_;
}

double Matern32Kernel::secondDerivative(double r) const {
  const double a = kSqrt3 * r / length_;
  const double c = kSqrt3 / length_;
  return -sigma_ * sigma_ * c * c * (1.0 - a) * std::exp(-a);
}

void Matern32Kernel::paramGradient(double r, double* out) const {
  const double a = kSqrt3 * r / length_;
  out[0] = 2.0 * value(r);
  out[1] = sigma_ * sigma_ * a * a * std::exp(-a);  // dk/da * da/dlog(l), da/dlog(l) = -a
}

double Matern52Kernel::derivative(double r) const {
  const double a = kSqrt5 * r / length_;
  const double dk_da = -sigma_ * sigma_ * a * (1.0 + a) / 3.0 * std::exp(-a);
  return dk_da * kSqrt5 / length_;
}

double Matern52Kernel::secondDerivative(double r) const {
  const double a = kSqrt5 * r / length_;
  const double c = kSqrt5 / length_;
  return -sigma_ * sigma_ * c * c * (1.0 + a - a * a) / 3.0 * std::exp(-a);
}

void Matern52Kernel::paramGradient(double r, double* out) const {
  const double a = kSqrt5 * r / length_;
  const double dk_da = -sigma_ * sigma_ * a * (1.0 + a) / 3.0 * std::exp(-a);
  out[0] = 2.0 * value(r);
  out[1] = -a * dk_da;
}

// ------------------------------------------------------------------ registry
namespace {
using KernelFactory = std::function<std::unique_ptr<Kernel>()>;

std::map<std::string, KernelFactory>& registry() {
  static std::map<std::string, KernelFactory> factories = {
      {"thin_plate", [] { return std::make_unique<ThinPlateKernel>(); }},
      {"wendland", [] { return std::make_unique<WendlandKernel>(); }},
      {"squared_exponential", [] { return std::make_unique<SquaredExponentialKernel>(); }},
      {"matern32", [] { return std::make_unique<Matern32Kernel>(); }},
      {"matern52", [] { return std::make_unique<Matern52Kernel>(); }},
  };
  return factories;
}

std::mutex& registryMutex() {
  static std::mutex mutex;
  return mutex;
}
}  // namespace

std::unique_ptr<Kernel> makeKernel(const std::string& name) {
  std::lock_guard<std::mutex> lock(registryMutex());
  const auto it = registry().find(name);
  if (it == registry().end()) {
    std::ostringstream msg;
    msg << "unknown kernel '" << name << "'; known kernels:";
    for (const auto& entry : registry()) msg << " " << entry.first;
    throw std::invalid_argument(msg.str());
  }
  return it->second();
}

std::vector<std::string> kernelNames() {
  std::lock_guard<std::mutex> lock(registryMutex());
  std::vector<std::string> names;
  for (const auto& entry : registry()) names.push_back(entry.first);
  return names;
}

bool registerKernel(const std::string& name, std::function<std::unique_ptr<Kernel>()> factory) {
  std::lock_guard<std::mutex> lock(registryMutex());
  return registry().emplace(name, std::move(factory)).second;
}

}  // namespace gpatlas_core
