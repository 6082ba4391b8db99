#pragma once
// Internal helpers of drops::pilco (not installed): argument checks and the SE moment-matching
// kernel with derivatives with respect to each block's parameters (used by RbfPolicy).

#include <Eigen/Core>
#include <vector>

#include "drops/pilco/moments.hpp"
#include "drops/pilco/se_model.hpp"

namespace drops::pilco::detail {

// Throws InvalidArgument unless mu has size dim, sigma is dim x dim, both finite and sigma
// symmetric to 1e-9 relative to its largest entry. `who` prefixes the message.
void check_gaussian(const char* who, Eigen::Index dim, const Eigen::VectorXd& mu,
                    const Eigen::MatrixXd& sigma);

// A D x D matrix as a row vector of its column-major entries (dF/dSigma as one Jacobian row).
inline Eigen::Map<const Eigen::RowVectorXd> as_row(const Eigen::MatrixXd& m) {
  return Eigen::Map<const Eigen::RowVectorXd>(m.data(), m.size());
}

// Derivatives of every scalar of an SeModel's moments with respect to one block's parameters.
// Rows: the quantities in the order [mean (E) | cov (E^2, a + E b) | cross (D E, r + D a)].
// Columns: centres (n D, entry (i, d) at i + n d), weights (n), log length scales (D).
// The block's signal variance is held fixed. Only for blocks without gp_variance.
struct BlockParamGradient {
  Eigen::MatrixXd d_centres;
  Eigen::MatrixXd d_weights;
  Eigen::MatrixXd d_log_length_scales;
};

// se_moments with, when params != nullptr, the parameter derivatives of every block (in the order
// outputs[0].blocks..., outputs[1].blocks...). Throws InvalidArgument when params is requested for
// a model with a gp_variance block.
Moments se_moments_impl(const SeModel& model, const Eigen::VectorXd& mu,
                        const Eigen::MatrixXd& sigma, bool input_derivatives,
                        std::vector<BlockParamGradient>* params);

}  // namespace drops::pilco::detail
