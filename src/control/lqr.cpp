#include "drops/control/lqr.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>

#include "drops/core/errors.hpp"

namespace drops::control {

bool DareOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  if (!(tolerance > 0)) return fail("tolerance must be > 0");
  return true;
}

DareResult solve_dare(const MatrixXd& A, const MatrixXd& B, const MatrixXd& Q, const MatrixXd& R,
                      const DareOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw InvalidArgument("solve_dare options: " + why);
  const Eigen::Index n = A.rows(), m = B.cols();
  check_size("solve_dare: A columns vs rows", n, A.cols());
  check_size("solve_dare: B rows vs A", n, B.rows());
  check_size("solve_dare: Q rows vs A", n, Q.rows());
  check_size("solve_dare: Q columns vs A", n, Q.cols());
  check_size("solve_dare: R rows vs B columns", m, R.rows());
  check_size("solve_dare: R columns vs B columns", m, R.cols());
  if (n < 1 || m < 1) throw InvalidArgument("solve_dare: A and B must not be empty");
  if (!A.allFinite() || !B.allFinite() || !Q.allFinite() || !R.allFinite())
    throw InvalidArgument("solve_dare: A, B, Q and R must be finite");
  const Eigen::LLT<MatrixXd> r_llt(0.5 * (R + R.transpose()));
  if (r_llt.info() != Eigen::Success)
    throw InvalidArgument("solve_dare: R must be symmetric positive definite");

  DareResult res;
  const MatrixXd I = MatrixXd::Identity(n, n);
  MatrixXd Ak = A, G = B * r_llt.solve(B.transpose()), H = 0.5 * (Q + Q.transpose());
  G = 0.5 * (G + G.transpose());
  for (int k = 1; k <= options.max_iterations; ++k) {
    res.iterations = k;
    const Eigen::PartialPivLU<MatrixXd> W(I + G * H);
    const MatrixXd WA = W.solve(Ak);  // W^-1 A_k
    const MatrixXd WG = W.solve(G);   // W^-1 G_k
    MatrixXd H1 = H + Ak.transpose() * H * WA;
    MatrixXd G1 = G + Ak * WG * Ak.transpose();
    Ak = Ak * WA;
    H1 = 0.5 * (H1 + H1.transpose());
    G = 0.5 * (G1 + G1.transpose());
    if (!H1.allFinite() || !G.allFinite() || !Ak.allFinite()) {
      res.P = H1;
      return res;  // diverged: converged stays false
    }
    const double change = (H1 - H).norm(), scale = std::max(1.0, H1.norm());
    H = std::move(H1);
    if (change <= options.tolerance * scale) {
      res.converged = true;
      break;
    }
  }
  res.P = H;
  const MatrixXd S = R + B.transpose() * H * B;
  res.K = S.ldlt().solve(B.transpose() * H * A);
  const MatrixXd resid = A.transpose() * H * A - H - A.transpose() * H * B * res.K + Q;
  res.residual = resid.norm() / std::max(1.0, H.norm());
  const Eigen::VectorXcd ev = Eigen::EigenSolver<MatrixXd>(A - B * res.K, false).eigenvalues();
  res.closed_loop_radius = ev.cwiseAbs().maxCoeff();
  res.converged = res.converged && res.K.allFinite() && std::isfinite(res.residual);
  return res;
}

Linearization linearize(const model::DynamicsModel& model, const VectorXd& x_goal,
                        const VectorXd& u_goal, double h) {
  if (!(h > 0) || !std::isfinite(h))
    throw InvalidArgument("linearize: the finite-difference step h must be > 0");
  const Eigen::Index E = x_goal.size(), U = u_goal.size();
  // All 2 (E + U) + 1 points in one batch: the centre, then +-h on each state and action entry.
  const Eigen::Index rows = 2 * (E + U) + 1;
  MatrixXd X = x_goal.transpose().replicate(rows, 1), Uc = u_goal.transpose().replicate(rows, 1);
  for (Eigen::Index j = 0; j < E; ++j) {
    X(1 + 2 * j, j) += h;
    X(2 + 2 * j, j) -= h;
  }
  for (Eigen::Index j = 0; j < U; ++j) {
    Uc(1 + 2 * (E + j), j) += h;
    Uc(2 + 2 * (E + j), j) -= h;
  }
  MatrixXd mean, var;
  model.predict_batch(X, Uc, mean, var);
  check_size("linearize: model predictions", rows, mean.rows());
  check_size("linearize: model prediction size vs goal state", E, mean.cols());
  if (!mean.allFinite())
    throw Error("linearize: the model's mean is not finite near the goal state");
  const MatrixXd g = X + mean;  // the one-step map x + mean f(x, u), row by row
  Linearization lin;
  lin.A.resize(E, E);
  lin.B.resize(E, U);
  for (Eigen::Index j = 0; j < E; ++j)
    lin.A.col(j) = (g.row(1 + 2 * j) - g.row(2 + 2 * j)).transpose() / (2 * h);
  for (Eigen::Index j = 0; j < U; ++j)
    lin.B.col(j) = (g.row(1 + 2 * (E + j)) - g.row(2 + 2 * (E + j))).transpose() / (2 * h);
  lin.drift = mean.row(0).transpose();
  return lin;
}

}  // namespace drops::control
