#include <cmath>

#include "drops/core/errors.hpp"
#include "drops/policy/policy.hpp"

namespace drops::policy {

bool NeuralNetPolicyOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (observation_dim < 1) return fail("observation_dim must be >= 1");
  if (hidden_units < 1) return fail("hidden_units must be >= 1");
  if (action_dim < 1) return fail("action_dim must be >= 1");
  if (input_scale.size() != 0 && input_scale.size() != observation_dim)
    return fail("input_scale: expected size " + std::to_string(observation_dim) + ", got " +
                std::to_string(input_scale.size()));
  for (Eigen::Index i = 0; i < input_scale.size(); ++i)
    if (!std::isfinite(input_scale[i]) || input_scale[i] == 0)
      return fail("input_scale entries must be finite and non-zero");
  if (!(max_action > 0)) return fail("max_action must be > 0");
  return true;
}

NeuralNetPolicy::NeuralNetPolicy(const NeuralNetPolicyOptions& options) : options_(options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("NeuralNetPolicy: " + why);
  inv_scale_ = options.input_scale.size() ? VectorXd(options.input_scale.cwiseInverse())
                                          : VectorXd::Ones(options.observation_dim);
  w1_ = MatrixXd::Zero(options.hidden_units, options.observation_dim + 1);
  w2_ = MatrixXd::Zero(options.action_dim, options.hidden_units + 1);
  theta_ = VectorXd::Zero(param_dim());
}

int NeuralNetPolicy::param_dim() const {
  return options_.hidden_units * (options_.observation_dim + 1) +
         options_.action_dim * (options_.hidden_units + 1);
}

void NeuralNetPolicy::set_params(const VectorXd& theta) {
  check_size("NeuralNetPolicy theta", param_dim(), theta.size());
  if (!theta.allFinite()) throw InvalidArgument("NeuralNetPolicy theta has non-finite entries");
  theta_ = theta;
  int k = 0;
  for (int r = 0; r < w1_.rows(); ++r)
    for (int c = 0; c < w1_.cols(); ++c) w1_(r, c) = theta[k++];
  for (int r = 0; r < w2_.rows(); ++r)
    for (int c = 0; c < w2_.cols(); ++c) w2_(r, c) = theta[k++];
}

void NeuralNetPolicy::act(const VectorXd& obs, double /*t*/, Eigen::Ref<VectorXd> u) const {
  const int O = options_.observation_dim, H = options_.hidden_units;
  constexpr int kStack = 64;
  double stack_h[kStack];
  std::vector<double> heap_h;
  double* h = stack_h;
  if (H > kStack) {
    heap_h.resize(H);
    h = heap_h.data();
  }
  for (int j = 0; j < H; ++j) {
    double a = w1_(j, O);  // bias
    for (int i = 0; i < O; ++i) a += w1_(j, i) * obs[i] * inv_scale_[i];
    h[j] = std::tanh(options_.hidden_gain * a);
  }
  for (int k = 0; k < options_.action_dim; ++k) {
    double a = w2_(k, H);
    for (int j = 0; j < H; ++j) a += w2_(k, j) * h[j];
    u[k] = options_.max_action * std::tanh(options_.output_gain * a);
  }
}

std::unique_ptr<Policy> NeuralNetPolicy::clone() const {
  return std::make_unique<NeuralNetPolicy>(*this);
}

}  // namespace drops::policy
