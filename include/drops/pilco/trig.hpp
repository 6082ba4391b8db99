#pragma once
/// \file Exact moments of sums of sines of a Gaussian vector: PILCO's sin/cos augmentation of
/// angles (gTrig) and sine squashing of controls (gSat), baselines.md §1a.

#include <Eigen/Core>
#include <vector>

#include "drops/pilco/moments.hpp"

namespace drops::pilco {

/// One term amplitude * sin(direction^T x + phase) of a SineFeature.
struct SineTerm {
  Eigen::VectorXd direction;  ///< g (dim D)
  double phase = 0.0;         ///< phi (rad)
  double amplitude = 1.0;     ///< a
};

/// y(x) = sum_t a_t sin(g_t^T x + phi_t). gTrig's sin x_i and cos x_i = sin(x_i + pi/2) and gSat's
/// maxU (9 sin x + sin 3x) / 8 are such features.
struct SineFeature {
  std::vector<SineTerm> terms;
};

/// Exact moments of y = (y_1 .. y_E) (features) for x ~ N(mu, Sigma) (dim D), from
/// E[cos(h^T x + psi)] = exp(-1/2 h^T Sigma h) cos(h^T mu + psi) and sin a sin b =
/// (cos(a - b) - cos(a + b)) / 2; cross = E[dy/dx] (D x E), which equals Sigma^-1 Cov[x, y] by
/// Stein's lemma. With derivatives, all six input derivatives (conventions: Moments).
/// Throws InvalidArgument on sizes (a direction not of dim D) or non-finite/asymmetric input.
/// Cost O(E^2 T^2 D^2) for T terms per feature. Thread-safe.
Moments sine_moments(const std::vector<SineFeature>& features, const Eigen::VectorXd& mu,
                     const Eigen::MatrixXd& sigma, bool derivatives = false);

/// gTrig: the moments of [sin x_i1, cos x_i1, sin x_i2, cos x_i2, ...] (dim 2 |angles|) for
/// x ~ N(mu, Sigma) (dim D), `angles` being indices into x (each in [0, D); InvalidArgument
/// otherwise). Note the order sin, cos per angle (PILCO's; drops' Task::observe uses cos, sin).
/// cross has E[cos x_i] at (i, sin x_i), -E[sin x_i] at (i, cos x_i) and zeros elsewhere.
/// Thread-safe.
Moments trig_moments(const std::vector<int>& angles, const Eigen::VectorXd& mu,
                     const Eigen::MatrixXd& sigma, bool derivatives = false);

/// gSat: the moments of u_k = max_u_k (9 sin x_k + sin 3 x_k) / 8 (k < U) for x ~ N(mu, Sigma)
/// (dim U = max_u.size(); max_u > 0, InvalidArgument otherwise). Thread-safe.
Moments squash_moments(const Eigen::VectorXd& max_u, const Eigen::VectorXd& mu,
                       const Eigen::MatrixXd& sigma, bool derivatives = false);

/// The squashing itself at a deterministic point: max_u (9 sin x + sin 3x) / 8, in [-max_u, max_u].
double squash(double x, double max_u);

}  // namespace drops::pilco
