#pragma once
/// \file The exact GP on N points and their mirror images, fitted at the cost of two GPs of N.
///
/// Data made of N inputs X and their reflections X P (P = diag(flip), flip_d = +1 or -1), with
/// targets y and sign * y (sign = +1 or -1: the output is even or odd under the reflection).
/// The squared-exponential ARD kernel is unchanged by the reflection, so the 2N x 2N covariance
/// is [[A, B], [B, A]] with A = k(X, X) + sigma_n^2 I and B = k(X, X P). In the basis of sums and
/// differences it is block diagonal, C+ = A + B and C- = A - B, and the targets lie in the block
/// of `sign` alone:
///   log p = -y^T C_s^-1 y - 1/2 log|C+| - 1/2 log|C-| - N log(2 pi),
/// the 2N GP's log marginal likelihood (Rasmussen & Williams 2006, eq. 5.8) exactly, at two
/// factorisations of N instead of one of 2N (a quarter of the cubic cost).
#include <Eigen/Core>

#include "drops/gp/gp.hpp"

namespace drops::gp {

/// The 2N GP's log marginal likelihood at hyper-parameters h (SE-ARD: [log l_1 .. log l_D,
/// log sigma_f, log sigma_n], as Gp::h_params) for the data above, and its gradient in *grad
/// (dim D + 2) when grad is not null. X: N x D (N >= 1), flip: D entries of +1 or -1, y: N,
/// sign: +1 or -1. Throws InvalidArgument on sizes or values out of range, NumericalError when a
/// factorisation fails. Thread-safe (no shared state). Cost O(N^3 + N^2 D).
double reflected_pairs_log_likelihood(const Eigen::VectorXd& h, const Eigen::MatrixXd& X,
                                      const Eigen::VectorXd& flip, const Eigen::VectorXd& y,
                                      double sign, Eigen::VectorXd* grad = nullptr);

/// Gp::optimize_h_params (iRprop-, the same box, tolerance and soft walls) of the 2N GP above,
/// computed with reflected_pairs_log_likelihood: the same search as gp.compute([X; X P],
/// [y; sign y]) then gp.optimize_h_params(options), up to round-off. Starts from h (dim D + 2,
/// as Gp::h_params of an SE-ARD GP) and returns the best iterate in h. The soft walls take the
/// input spread of all 2N points. Throws as reflected_pairs_log_likelihood (NumericalError when
/// the start cannot be factorised) and InvalidArgument on invalid options. Thread-safe.
RpropSummary fit_reflected_pairs(Eigen::VectorXd& h, const Eigen::MatrixXd& X,
                                 const Eigen::VectorXd& flip, const Eigen::VectorXd& y,
                                 double sign, const RpropOptions& options = {});

}  // namespace drops::gp
