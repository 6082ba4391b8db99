// The hexapod's open-loop periodic gait controller (controller.hpp). No DART.

#include "drops/hexapod/controller.hpp"

#include <cmath>
#include <sstream>

#include "drops/core/errors.hpp"
#include "drops/hexapod/robot.hpp"

namespace drops::hexapod {
namespace {

std::string str(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

void check_unit(const char* what, double v) {
  if (!(std::isfinite(v) && v >= 0.0 && v <= 1.0)) {
    throw InvalidArgument(std::string("periodic_signal: ") + what + " must be in [0, 1], got " +
                          str(v));
  }
}

void check_options(const GaitOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument(why);
}

}  // namespace

bool GaitOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (samples < 2) return fail("GaitOptions.samples must be >= 2, got " + std::to_string(samples));
  if (!(std::isfinite(period) && period > 0))
    return fail("GaitOptions.period must be > 0, got " + str(period));
  if (!(std::isfinite(sigma) && sigma > 0))
    return fail("GaitOptions.sigma must be > 0, got " + str(sigma));
  if (half_width < 0 || half_width >= samples) {
    return fail("GaitOptions.half_width must be in [0, samples), got " +
                std::to_string(half_width));
  }
  if (!std::isfinite(hip_scale) || !std::isfinite(knee_scale)) {
    return fail("GaitOptions.hip_scale and knee_scale must be finite");
  }
  return true;
}

Eigen::VectorXd smoothing_kernel(const GaitOptions& options) {
  check_options(options);
  const int h = options.half_width;
  Eigen::VectorXd g(2 * h + 1);
  for (int j = -h; j <= h; ++j) {
    g[j + h] = std::exp(-double(j) * j / (2.0 * options.sigma * options.sigma));
  }
  g /= g.sum();
  return g;
}

Eigen::VectorXd periodic_signal(double amplitude, double phase, double duty,
                                const GaitOptions& options) {
  check_unit("amplitude", amplitude);
  check_unit("phase", phase);
  check_unit("duty", duty);
  const Eigen::VectorXd g = smoothing_kernel(options);
  const int n = options.samples;
  const int h = options.half_width;
  Eigen::VectorXd square(n);
  for (int i = 0; i < n; ++i) square[i] = (i < duty * n) ? amplitude : -amplitude;
  Eigen::VectorXd smooth(n);
  for (int i = 0; i < n; ++i) {
    double acc = 0.0;
    for (int j = -h; j <= h; ++j) acc += g[j + h] * square[((i + j) % n + n) % n];
    smooth[i] = acc;
  }
  const int shift = static_cast<int>(std::floor(phase * n)) % n;
  Eigen::VectorXd out(n);
  for (int i = 0; i < n; ++i) out[i] = smooth[((i - shift) % n + n) % n];
  return out;
}

GaitController::GaitController(const GaitOptions& options) : options_(options) {
  check_options(options_);
  set_params(Eigen::VectorXd::Zero(kParamDim));
}

void GaitController::set_params(const Eigen::VectorXd& theta) {
  check_size("GaitController::set_params theta", kParamDim, theta.size());
  for (int i = 0; i < kParamDim; ++i) {
    if (!(std::isfinite(theta[i]) && theta[i] >= 0.0 && theta[i] <= 1.0)) {
      throw InvalidArgument("GaitController::set_params: theta[" + std::to_string(i) +
                            "] must be in [0, 1], got " + str(theta[i]));
    }
  }
  theta_ = theta;
  for (int k = 0; k < kNumLegs; ++k) {
    for (int which = 0; which < 2; ++which) {
      const int b = 6 * k + 3 * which;
      signals_[2 * k + which] = periodic_signal(theta[b], theta[b + 1], theta[b + 2], options_);
    }
  }
}

int GaitController::sample_index(double t) const {
  if (!(std::isfinite(t) && t >= 0.0)) {
    throw InvalidArgument("GaitController: time must be finite and >= 0, got " + str(t));
  }
  const double x = t * options_.samples / options_.period + 1e-9;
  const double cycles = std::floor(x / options_.samples);
  return static_cast<int>(std::floor(x - cycles * options_.samples)) % options_.samples;
}

void GaitController::targets(double t, Eigen::Ref<Eigen::VectorXd> out) const {
  check_size("GaitController::targets out", kNumJoints, out.size());
  const int i = sample_index(t);
  for (int k = 0; k < kNumLegs; ++k) {
    const double hip = signals_[2 * k][i];
    const double knee = signals_[2 * k + 1][i];
    out[3 * k + 0] = options_.hip_scale * hip;
    out[3 * k + 1] = options_.knee_scale * knee;
    out[3 * k + 2] = -options_.knee_scale * knee;
  }
}

Eigen::VectorXd GaitController::targets(double t) const {
  Eigen::VectorXd out(kNumJoints);
  targets(t, out);
  return out;
}

const Eigen::VectorXd& GaitController::signal(int leg, int which) const {
  if (leg < 0 || leg >= kNumLegs || which < 0 || which > 1) {
    throw InvalidArgument("GaitController::signal: leg must be in 0..5 and which in {0, 1}, got " +
                          std::to_string(leg) + ", " + std::to_string(which));
  }
  return signals_[2 * leg + which];
}

Eigen::VectorXd tripod_gait(double lift_lag) {
  Eigen::VectorXd theta(GaitController::kParamDim);
  for (int k = 0; k < kNumLegs; ++k) {
    const double phase = (k % 2 == 0) ? 0.0 : 0.5;
    theta.segment<6>(6 * k) << 1.0, phase, 0.5, 0.5, std::fmod(phase + lift_lag, 1.0), 0.5;
  }
  return theta;
}

}  // namespace drops::hexapod
