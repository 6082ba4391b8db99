#pragma once
/// \file Covariance functions behind one interface (limbo's hyper-parameter protocol: h_params() /
/// set_h_params() in log space): the squared-exponential ARD kernel of the paper (§IV-A) and the
/// isotropic Matern 5/2 kernel of IT&E's M-BOA (drops/ite/mboa.hpp).

#include <Eigen/Core>
#include <memory>
#include <string>

namespace drops::gp {

/// A stationary covariance function k(a, b) on inputs of dimension D, with hyper-parameters h
/// (log space, dim h_dim()) that a Gp fits by maximum likelihood. Implementations are value-like:
/// const members are thread-safe; clone() gives an independent copy (one per GP).
class Kernel {
 public:
  virtual ~Kernel() = default;
  /// Independent copy.
  virtual std::unique_ptr<Kernel> clone() const = 0;
  /// Short name, e.g. "squared_exp_ard".
  virtual std::string name() const = 0;
  /// D, the input dimension.
  virtual int input_dim() const = 0;
  /// Number of hyper-parameters.
  virtual int h_dim() const = 0;
  /// Hyper-parameters h (dim h_dim(), log space).
  virtual Eigen::VectorXd h_params() const = 0;
  /// Sets h (dim h_dim(), finite). Throws InvalidArgument on a wrong size or a non-finite value.
  virtual void set_h_params(const Eigen::VectorXd& h) = 0;
  /// k(x, x), the prior variance (the same for every x: stationary kernels).
  virtual double variance() const = 0;
  /// k(a, b); a, b: dim D (InvalidArgument otherwise).
  virtual double operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const = 0;
  /// Gram matrix K_ij = k(A_i, B_j); A: n x D, B: m x D (one input per row); returns n x m.
  /// The default calls operator() n m times. Throws InvalidArgument on a column count != D.
  virtual Eigen::MatrixXd gram(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) const;
  /// The likelihood-gradient contraction g_j = 1/2 sum_ik W_ik dK_ik / dh_j for K = gram(X, X)
  /// (X: n x D, W: n x n symmetric); returns dim h_dim(). With W = alpha alpha^T - K^-1 this is
  /// d log p(y | X) / dh_j (Rasmussen & Williams 2006, eq. 5.9).
  virtual Eigen::VectorXd gram_gradient(const Eigen::MatrixXd& X,
                                        const Eigen::MatrixXd& W) const = 0;
};

/// Squared-exponential ARD kernel (Rasmussen & Williams 2006, eq. 5.1; paper §IV-A)
///   k(a, b) = sigma_f^2 exp(-1/2 sum_d (a_d - b_d)^2 / l_d^2).
/// Hyper-parameters live in log space, h = [log l_1 .. log l_D, log sigma_f] (dim D + 1).
/// Value type; thread-safe for concurrent const use. Gp has a fast path for this kernel.
struct SquaredExpArd final : Kernel {
  /// length_scales: l (dim D, > 0), in the units of the inputs.
  Eigen::VectorXd length_scales;
  /// signal_variance: sigma_f^2 (> 0), in squared output units.
  double signal_variance = 1.0;

  /// Kernel of dimension `input_dim` with l = 1 and sigma_f^2 = 1 (settings.md §3).
  explicit SquaredExpArd(int input_dim = 0)
      : length_scales(Eigen::VectorXd::Ones(input_dim)) {}
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<SquaredExpArd>(*this); }
  std::string name() const override { return "squared_exp_ard"; }
  int input_dim() const override { return static_cast<int>(length_scales.size()); }
  int h_dim() const override { return input_dim() + 1; }
  Eigen::VectorXd h_params() const override;
  /// l_d = exp(h_d), sigma_f^2 = exp(2 h_D).
  void set_h_params(const Eigen::VectorXd& h) override;
  double variance() const override { return signal_variance; }
  double operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const override;
  Eigen::MatrixXd gram(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B) const override;
  Eigen::VectorXd gram_gradient(const Eigen::MatrixXd& X, const Eigen::MatrixXd& W) const override;
};

/// Isotropic Matern kernel with nu = 5/2 on the Euclidean distance d = |a - b|
/// (Rasmussen & Williams 2006, eq. 4.17; Cully et al. 2015, Methods; baselines.md §3a):
///   k(d) = sigma_f^2 (1 + sqrt(5) d / l + 5 d^2 / (3 l^2)) exp(-sqrt(5) d / l).
/// k(0) = sigma_f^2, k(l) = 0.52399 sigma_f^2; twice differentiable in d (k'(0) = 0).
/// Hyper-parameters h = [log l, log sigma_f] (dim 2). Value type; thread-safe for concurrent const
/// use.
struct Matern52 final : Kernel {
  /// length_scale: l (> 0), in the units of the inputs (M-BOA: descriptor units, 0.4 there).
  double length_scale = 1.0;
  /// signal_variance: sigma_f^2 (> 0), in squared output units.
  double signal_variance = 1.0;
  /// D, the input dimension; 0 = any (operator() and of_distance accept inputs of any equal
  /// size; a Gp needs D >= 1).
  int dim = 0;

  explicit Matern52(double length_scale = 1.0, double signal_variance = 1.0, int input_dim = 0)
      : length_scale(length_scale), signal_variance(signal_variance), dim(input_dim) {}
  /// k(d) for a distance d >= 0 (in the units of the inputs). Pure; no argument checks.
  double of_distance(double d) const;
  std::unique_ptr<Kernel> clone() const override { return std::make_unique<Matern52>(*this); }
  std::string name() const override { return "matern52"; }
  int input_dim() const override { return dim; }
  int h_dim() const override { return 2; }
  Eigen::VectorXd h_params() const override;
  /// l = exp(h_0), sigma_f^2 = exp(2 h_1).
  void set_h_params(const Eigen::VectorXd& h) override;
  double variance() const override { return signal_variance; }
  /// k(a, b) = of_distance(|a - b|_2); a, b: the same dim (and D when D > 0; InvalidArgument
  /// otherwise).
  double operator()(const Eigen::VectorXd& a, const Eigen::VectorXd& b) const override;
  Eigen::VectorXd gram_gradient(const Eigen::MatrixXd& X, const Eigen::MatrixXd& W) const override;
};

}  // namespace drops::gp
