#pragma once
// The iRprop- loop shared by the exact GP (Gp::optimize_h_params) and the sparse GP
// (SparseGp::optimize_h_params): internal, not installed.
#include <Eigen/Core>
#include <functional>

#include "drops/gp/gp.hpp"

namespace drops::gp::detail {

/// What the loop needs from a GP. apply: refactorise at h (throws NumericalError on failure);
/// evaluate: the log-likelihood (or bound) at the h last applied, its gradient into grad;
/// value: the same value alone; keep: the final refactorisation at the best h.
struct RpropTarget {
  std::function<void(const Eigen::VectorXd& h)> apply;
  std::function<double(Eigen::VectorXd& grad)> evaluate;
  std::function<double()> value;
  std::function<void(const Eigen::VectorXd& h)> keep;
};

/// iRprop- (Igel & Huesken 2000) from h0 (already applied), in the box of Gp::optimize_h_params
/// (h's last entry is log sigma_n), with options' soft walls computed from the inputs X.
/// Continues `state` when it has started. Documented at Gp::optimize_h_params.
RpropSummary run_irprop(const RpropOptions& options, const Eigen::MatrixXd& X,
                        const Eigen::VectorXd& h0, RpropState* state, const RpropTarget& target);

}  // namespace drops::gp::detail
