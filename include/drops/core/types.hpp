#pragma once
/// \file Shared value types: Eigen aliases and named records used across drops.

#include <Eigen/Core>
#include <vector>

namespace drops {

using Eigen::MatrixXd;
using Eigen::VectorXd;

/// One recorded step of interaction (paper §IV-A).
/// x: state before the step (dim E, the system's raw state, e.g. angles not wrapped);
/// u: action applied over the step (dim U); dx: x_{t+1} - x_t (dim E).
struct Transition {
  VectorXd x;
  VectorXd u;
  VectorXd dx;
};

/// Gaussian predictive distribution of a state difference, per output independent (paper eq. 3-4).
/// mean: dim E; var: dim E, variance without observation noise.
struct Prediction {
  VectorXd mean;
  VectorXd var;
};

}  // namespace drops
