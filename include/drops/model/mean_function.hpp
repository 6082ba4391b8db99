#pragma once
/// \file Simulator priors M(x, u; phi) with tunable parameters phi (paper §IV-B, eq. 6).

#include <memory>
#include <string>
#include <vector>

#include "drops/core/types.hpp"

namespace drops::model {

/// A black-box simulator used as the mean of the GP dynamics model: given a raw state x and an
/// action u, predicts the state difference dx = x_{t+1} - x_t under parameters phi.
/// Implementations must be thread-safe for concurrent const calls (a simulator with mutable state
/// keeps per-thread copies internally). clone() gives an independent copy.
class MeanFunction {
 public:
  virtual ~MeanFunction() = default;
  /// E, the dimension of x and dx.
  virtual int state_dim() const = 0;
  /// U, the dimension of u.
  virtual int action_dim() const = 0;
  /// Names of the full parameter vector phi (dim P), e.g. {"m1","m2","l1","l2","b1","b2"}.
  virtual std::vector<std::string> parameter_names() const = 0;
  /// Throws InvalidArgument when phi (dim P) is outside the simulator's domain (e.g. a mass <= 0
  /// that makes the inertia matrix singular), with a message naming the parameter.
  virtual void check_phi(const VectorXd& phi) const = 0;
  /// dx = M(x, u; phi). x: dim E (raw state), u: dim U, phi: dim P (assumed checked), dx: dim E.
  /// May return non-finite values for invalid states; callers count and handle them.
  virtual void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                        Eigen::Ref<VectorXd> dx) const = 0;
  /// dX.row(b) = M(X.row(b), U.row(b); phi) for every row b: X is B x E (raw states), U is B x U,
  /// phi dim P (assumed checked); dX is resized to B x E. One call serves a batch of rollouts at
  /// one step (the model's predict_batch) or a block of recorded transitions (prior_outputs), so
  /// a simulator that is costly to enter (a Python prior: one interpreter lock per call) or that
  /// vectorises overrides it. Default: evaluate() row by row (the same numbers). May return
  /// non-finite rows, as evaluate(). Thread-safe for concurrent calls, as evaluate().
  virtual void evaluate_batch(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                              MatrixXd& dX) const {
    const int E = state_dim();
    dX.resize(X.rows(), E);
    VectorXd x(X.cols()), u(U.cols()), dx(E);
    for (Eigen::Index b = 0; b < X.rows(); ++b) {
      x = X.row(b).transpose();
      u = U.row(b).transpose();
      evaluate(x, u, phi, dx);
      dX.row(b) = dx.transpose();
    }
  }
  /// Independent copy.
  virtual std::unique_ptr<MeanFunction> clone() const = 0;
};

/// Which parameters of a MeanFunction GP-MI and MI may tune, within which bounds (paper §IV-B).
/// values: the full phi (dim P), the starting point and the fixed values of non-tunable entries.
/// tunable: indices into phi; lower/upper: bounds of the tunable entries (dim = tunable.size()).
/// choices: per tunable entry, an empty vector for a continuous parameter (searched by Subplex) or
/// the list of allowed values of a discrete one (searched exhaustively).
struct PriorParameters {
  std::vector<std::string> names;
  VectorXd values;
  std::vector<int> tunable;
  VectorXd lower;
  VectorXd upper;
  std::vector<std::vector<double>> choices;
  /// Throws InvalidArgument when sizes disagree, bounds are inverted or values lie outside them.
  void check() const;
  /// Full phi with the tunable entries replaced by `tuned` (dim tunable.size()).
  VectorXd with_tuned(const VectorXd& tuned) const;
  /// Tunable entries of values (dim tunable.size()).
  VectorXd tuned() const;
};

}  // namespace drops::model
