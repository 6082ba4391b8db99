#pragma once
/// \file The recorded transitions in the matrix form the models learn from, and the simulator
/// prior evaluated on them (the residual targets of paper eq. 4 are dx - M(x, u; phi)).

#include <vector>

#include "drops/core/problem.hpp"
#include "drops/core/types.hpp"
#include "drops/model/mean_function.hpp"

namespace drops::model {

/// The layout of a dataset that holds n transitions and then their mirror images (a task's
/// reflection, ModelOptions::reflect_transitions): row n + i is row i reflected, its GP inputs
/// flipped in sign column by column (flip, D entries of +1 or -1) and output e's residual target
/// multiplied by sign[e]. The exact GPs' kernel fits then run on the n recorded rows
/// (gp::fit_reflected_pairs): the same fits as on all 2n rows, up to round-off, at a quarter of
/// the cubic cost. n = 0: no such layout.
struct ReflectedPairs {
  int n = 0;
  VectorXd flip;  ///< dim D: the GP inputs' signs under the reflection
  VectorXd sign;  ///< dim E: the outputs' signs under the reflection
};

/// N transitions as matrices, one transition per row.
struct Dataset {
  MatrixXd x;      ///< N x E raw states
  MatrixXd u;      ///< N x U actions
  MatrixXd dx;     ///< N x E state differences (the GP targets before subtracting the prior)
  MatrixXd gp_in;  ///< N x (O + U) GP inputs [task.observe(x), u]; 0 columns without a task
  /// Set by the model when the rows are n transitions and then their reflections (n = 0
  /// otherwise); rows() keeps it only when it takes every row in order.
  ReflectedPairs pairs;
  int size() const { return static_cast<int>(x.rows()); }
  /// The rows `idx` of every matrix (indices in [0, N), not checked).
  Dataset rows(const std::vector<int>& idx) const;
};

/// Builds the dataset of `data` (x dim E, u dim U, dx dim E each). With a task, gp_in holds the
/// task's observation of x followed by u. Throws InvalidArgument naming the transition on a size
/// mismatch or a non-finite value. Thread-safe.
Dataset make_dataset(const std::vector<Transition>& data, const Task* task, int E, int U);

/// Indices of an evenly spaced subset of at most max_points of N rows (floor(k N / max_points));
/// every row when max_points <= 0 or N <= max_points. Thread-safe.
std::vector<int> subsample(int N, int max_points);

/// M(x_n, u_n; phi) for every row of X (N x E) and U (N x U), in parallel (drops::parallel_for);
/// returns N x E. Outputs that are not finite are kept and counted in *nonfinite (when not
/// null). phi must have been checked by prior.check_phi. Deterministic.
MatrixXd prior_outputs(const MeanFunction& prior, const MatrixXd& X, const MatrixXd& U,
                       const VectorXd& phi, long* nonfinite);

}  // namespace drops::model
