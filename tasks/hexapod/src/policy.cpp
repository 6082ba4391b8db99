// HexapodGaitPolicy (policy.hpp). No DART include here.

#include "drops/hexapod/policy.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "drops/core/errors.hpp"

namespace drops::hexapod {

bool HexapodGaitPolicyOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why != nullptr) *why = m;
    return false;
  };
  if (observation_dim < 0) {
    return fail("HexapodGaitPolicyOptions.observation_dim must be >= 0, got " +
                std::to_string(observation_dim));
  }
  if (!(std::isfinite(theta_bound) && theta_bound > 0.0)) {
    std::ostringstream s;
    s << "HexapodGaitPolicyOptions.theta_bound must be > 0, got " << theta_bound;
    return fail(s.str());
  }
  return gait.IsValid(why);
}

HexapodGaitPolicy::HexapodGaitPolicy(const HexapodGaitPolicyOptions& options)
    : options_(options), controller_(options.gait) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument(why);
  set_params(VectorXd::Zero(GaitController::kParamDim));
}

void HexapodGaitPolicy::set_params(const VectorXd& theta) {
  check_size("HexapodGaitPolicy theta", GaitController::kParamDim, theta.size());
  const double b = options_.theta_bound;
  VectorXd p(theta.size());
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    const double v = theta[i];
    if (!std::isfinite(v) || std::abs(v) > b * (1.0 + 1e-12)) {
      std::ostringstream s;
      s << "HexapodGaitPolicy: theta[" << i << "] = " << v << " is outside [-" << b << ", " << b
        << "] (set the search bound policy.bound / theta_bound to " << b << ")";
      throw InvalidArgument(s.str());
    }
    p[i] = std::clamp((v + b) / (2.0 * b), 0.0, 1.0);
  }
  controller_.set_params(p);
  theta_ = theta;
}

void HexapodGaitPolicy::act(const VectorXd& obs, double t, Eigen::Ref<VectorXd> u) const {
  check_size("HexapodGaitPolicy::act obs", options_.observation_dim, obs.size());
  check_size("HexapodGaitPolicy::act u", kNumJoints, u.size());
  controller_.targets(t, u);
}

std::unique_ptr<policy::Policy> HexapodGaitPolicy::clone() const {
  return std::make_unique<HexapodGaitPolicy>(*this);
}

VectorXd HexapodGaitPolicy::theta_of(const VectorXd& gait_params) const {
  check_size("HexapodGaitPolicy::theta_of gait_params", GaitController::kParamDim,
             gait_params.size());
  const double b = options_.theta_bound;
  return (2.0 * b * gait_params.array() - b).matrix();
}

}  // namespace drops::hexapod
