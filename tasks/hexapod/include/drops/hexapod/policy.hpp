#pragma once
/// \file The hexapod's open-loop periodic gait (controller.hpp) as a drops policy::Policy.
/// No DART in this header.

#include <memory>
#include <string>

#include "drops/policy/policy.hpp"
#include "drops/hexapod/controller.hpp"
#include "drops/hexapod/robot.hpp"

namespace drops::hexapod {

/// Options of HexapodGaitPolicy.
struct HexapodGaitPolicyOptions {
  /// O, the task's observation dimension (the policy ignores the observation); HexapodTask: 45.
  int observation_dim = 45;
  /// b: drops searches theta in [-b, b]^36 (BlackDropsOptions::theta_bound, config policy.bound);
  /// the gait parameters are p = (theta + b) / (2 b) in [0, 1]^36. Set the search bound to the
  /// same b (the default b = 0.5 makes p = theta + 0.5). > 0.
  double theta_bound = 0.5;
  GaitOptions gait;  ///< the periodic signals (settings.md §6 defaults)
  /// True when every field is in range; otherwise false with the reason in *why (if not null).
  bool IsValid(std::string* why = nullptr) const;
};

/// u = the 18 target joint angles (rad, order 3 k + j, robot.hpp) of the GaitController with
/// parameters p = (theta + b) / (2 b) at time t (s since the start of the episode):
/// act(obs, t, u) = GaitController::targets(t); the observation is ignored (open loop). u is the
/// action HexapodPrior and HexapodRealSystem expect. theta: dim 36, each entry in [-b, b] (values
/// outside by at most 1e-12 b are rounded onto the bound). After set_params, act() is const and
/// thread-safe.
class HexapodGaitPolicy final : public policy::Policy {
 public:
  /// Throws InvalidArgument when options are invalid. theta starts at 0 (p = 0.5 everywhere).
  explicit HexapodGaitPolicy(const HexapodGaitPolicyOptions& options = {});
  int observation_dim() const override { return options_.observation_dim; }
  int action_dim() const override { return kNumJoints; }
  int param_dim() const override { return GaitController::kParamDim; }
  /// Throws InvalidArgument on a wrong size, a non-finite entry or one outside [-b, b] (naming
  /// its index).
  void set_params(const VectorXd& theta) override;
  const VectorXd& params() const override { return theta_; }
  /// obs: dim O (ignored), t: s >= 0, u: dim 18. Throws InvalidArgument on wrong sizes or a
  /// negative / non-finite t.
  void act(const VectorXd& obs, double t, Eigen::Ref<VectorXd> u) const override;
  std::unique_ptr<policy::Policy> clone() const override;
  /// The gait parameters p = (theta + b) / (2 b) (dim 36, in [0, 1]).
  const VectorXd& gait_params() const { return controller_.params(); }
  /// theta (dim 36) of the gait parameters p (dim 36, in [0, 1]): theta = 2 b p - b.
  VectorXd theta_of(const VectorXd& gait_params) const;
  const GaitController& controller() const { return controller_; }

 private:
  HexapodGaitPolicyOptions options_;
  GaitController controller_;
  VectorXd theta_;
};

}  // namespace drops::hexapod
