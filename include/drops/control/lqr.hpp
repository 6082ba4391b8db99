#pragma once
/// \file The discrete-time linear-quadratic regulator: the discrete algebraic Riccati equation
/// (DARE) and the linearisation of a learned model's mean one-step map at a goal.

#include <string>

#include "drops/core/types.hpp"
#include "drops/model/dynamics_model.hpp"

namespace drops::control {

/// Options of solve_dare.
struct DareOptions {
  /// Doubling steps at most (>= 1); each squares the horizon covered, so 60 steps cover 2^60
  /// Riccati iterations: a solution that has not converged by then does not exist (the pair
  /// (A, B) is not stabilisable) or is ill-conditioned.
  int max_iterations = 60;
  /// Converged when ||P_{k+1} - P_k||_F <= tolerance * max(1, ||P_{k+1}||_F), > 0.
  double tolerance = 1e-12;
  /// Returns true when every field is in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// The solution of a DARE and its LQR gain.
struct DareResult {
  MatrixXd P;              ///< the stabilising solution (n x n, symmetric positive semi-definite)
  MatrixXd K;              ///< the gain (m x n): u = -K x minimises sum x'Qx + u'Ru
  int iterations = 0;      ///< doubling steps performed
  bool converged = false;  ///< the tolerance was met and P, K are finite
  /// The relative residual ||A'PA - P - A'PB (R + B'PB)^-1 B'PA + Q||_F / max(1, ||P||_F).
  double residual = 0;
  /// The spectral radius of the closed loop A - B K (< 1: stable).
  double closed_loop_radius = 0;
};

/// Solves P = A'PA - A'PB (R + B'PB)^-1 B'PA + Q for the stabilising P, and returns
/// K = (R + B'PB)^-1 B'PA, by the structured doubling algorithm (SDA; E. K.-W. Chu, H.-Y. Fan,
/// W.-W. Lin, "A structure-preserving doubling algorithm for continuous-time algebraic Riccati
/// equations", and its discrete form, Linear Algebra Appl. 396 (2005) 55-80):
///   A_0 = A, G_0 = B R^-1 B', H_0 = Q; W = I + G_k H_k;
///   A_{k+1} = A_k W^-1 A_k, G_{k+1} = G_k + A_k W^-1 G_k A_k', H_{k+1} = H_k + A_k' H_k W^-1 A_k,
/// H_k -> P quadratically when (A, B) is stabilisable and (A, Q^1/2) detectable. Debian's
/// libslicot-dev (SB02OD) solves DAREs but is Fortran 77 only (hand-declared prototypes,
/// caller-sized workspaces) and would be a new build dependency for what is 40 lines of Eigen
/// here; the tests check this solver against the plain Riccati iteration and a closed form.
/// A: n x n, B: n x m, Q: n x n symmetric positive semi-definite, R: m x m symmetric positive
/// definite. Returns converged = false (never throws for it) when the iteration does not
/// converge or produces non-finite values. Throws InvalidArgument on mismatched sizes,
/// non-finite inputs or invalid options. Thread-safe (pure).
DareResult solve_dare(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q, const MatrixXd& R,
                      const DareOptions& options = {});

/// A discrete linear system x_{t+1} - x* = A (x_t - x*) + B (u_t - u*) + c.
struct Linearization {
  MatrixXd A;  ///< E x E
  MatrixXd B;  ///< E x U
  /// The model's mean step at the goal, g(x*, u*) - x* (dim E): 0 at an equilibrium of the
  /// model; LQR ignores it (reported to tell how far the model's goal is from rest).
  VectorXd drift;
};

/// Linearises the model's mean one-step map g(x, u) = x + mean f(x, u) (DynamicsModel::predict)
/// at (x_goal, u_goal) by central finite differences with step h on every entry (in the entry's
/// units): column j of A is (g(x* + h e_j, u*) - g(x* - h e_j, u*)) / 2h, truncation error
/// O(h^2) for a smooth mean (a GP's with a smooth kernel and prior). x_goal: dim E, u_goal:
/// dim U. Throws InvalidArgument on h <= 0 or sizes the model rejects; Error when a prediction
/// is non-finite. Thread-safe when the model's predict is (after learn()).
Linearization linearize(const model::DynamicsModel& model, const VectorXd& x_goal,
                        const VectorXd& u_goal, double h = 1e-4);

}  // namespace drops::control
