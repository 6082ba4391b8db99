// PILCO's one-step propagation (propagate.m / propagated.m) and policy objective (value.m),
// baselines.md §1a: a joint Gaussian over a growing vector, carried with its derivatives with
// respect to a set of "seed" variables (forward mode).
#include "drops/pilco/propagate.hpp"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <utility>

#include "detail.hpp"
#include "drops/core/errors.hpp"
#include "drops/pilco/trig.hpp"

namespace drops::pilco {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

// A Gaussian over a growing vector z (dim n) and the derivatives of its moments with respect to K
// seed variables: dm (n x K), dS (n^2 x K, column-major vec of each dS/dseed). K = 0: no
// derivatives.
struct JointGaussian {
  VectorXd m;
  MatrixXd S;
  MatrixXd dm;
  MatrixXd dS;

  Index size() const { return m.size(); }
  Index seeds() const { return dm.cols(); }

  VectorXd sub_mean(const std::vector<int>& idx) const {
    VectorXd r(idx.size());
    for (std::size_t k = 0; k < idx.size(); ++k) r[k] = m[idx[k]];
    return r;
  }
  MatrixXd sub_cov(const std::vector<int>& idx) const {
    const Index p = static_cast<Index>(idx.size());
    MatrixXd r(p, p);
    for (Index l = 0; l < p; ++l)
      for (Index k = 0; k < p; ++k) r(k, l) = S(idx[k], idx[l]);
    return r;
  }

  // Appends y = f(z[idx]) whose moments (computed from sub_mean(idx), sub_cov(idx)) are `b`, with
  // Cov[z, y] = S[:, idx] b.cross. output_seeds >= 0: b's own moments (mean q, cov q^2, cross p q)
  // are also seed variables, at columns output_seeds.. (how the policy parameters enter: see step).
  void append(const std::vector<int>& idx, const Moments& b, Index output_seeds) {
    const Index n = size(), p = static_cast<Index>(idx.size()), q = b.mean.size();
    const Index n2 = n + q, K = seeds();
    MatrixXd Si(n, p);
    for (Index l = 0; l < p; ++l) Si.col(l) = S.col(idx[l]);
    const MatrixXd X = Si * b.cross;  // Cov[z, y], n x q

    VectorXd m2(n2);
    m2 << m, b.mean;
    MatrixXd S2(n2, n2);
    S2.topLeftCorner(n, n) = S;
    S2.topRightCorner(n, q) = X;
    S2.bottomLeftCorner(q, n) = X.transpose();
    S2.bottomRightCorner(q, q) = b.cov;

    if (K > 0) {
      MatrixXd dmi(p, K), dSi(p * p, K);
      for (Index k = 0; k < p; ++k) dmi.row(k) = dm.row(idx[k]);
      for (Index l = 0; l < p; ++l)
        for (Index k = 0; k < p; ++k) dSi.row(k + p * l) = dS.row(idx[k] + n * idx[l]);
      MatrixXd dM = b.dmean_dmu * dmi + b.dmean_dsigma * dSi;
      MatrixXd dC = b.dcross_dmu * dmi + b.dcross_dsigma * dSi;
      MatrixXd dSkk = b.dcov_dmu * dmi + b.dcov_dsigma * dSi;
      if (output_seeds >= 0) {
        dM.middleCols(output_seeds, q).diagonal().array() += 1.0;
        dSkk.middleCols(output_seeds + q, q * q).diagonal().array() += 1.0;
        dC.middleCols(output_seeds + q + q * q, p * q).diagonal().array() += 1.0;
      }
      MatrixXd dm2(n2, K);
      dm2.topRows(n) = dm;
      dm2.bottomRows(q) = dM;
      MatrixXd dS2(n2 * n2, K);
      MatrixXd dSik(n, p), dX(n, q);
      for (Index c = 0; c < K; ++c) {
        Eigen::Map<const MatrixXd> dSc(dS.col(c).data(), n, n);
        for (Index l = 0; l < p; ++l) dSik.col(l) = dSc.col(idx[l]);
        Eigen::Map<const MatrixXd> dCc(dC.col(c).data(), p, q);
        dX.noalias() = dSik * b.cross;
        dX.noalias() += Si * dCc;
        Eigen::Map<MatrixXd> out(dS2.col(c).data(), n2, n2);
        out.topLeftCorner(n, n) = dSc;
        out.topRightCorner(n, q) = dX;
        out.bottomLeftCorner(q, n) = dX.transpose();
        out.bottomRightCorner(q, q) = Eigen::Map<const MatrixXd>(dSkk.col(c).data(), q, q);
      }
      dm = std::move(dm2);
      dS = std::move(dS2);
    }
    m = std::move(m2);
    S = std::move(S2);
  }

  // z <- A z (A: r x n), exactly symmetric covariance.
  void linear(const MatrixXd& A) {
    const Index n = size(), r = A.rows(), K = seeds();
    m = A * m;
    MatrixXd S2 = A * S * A.transpose();
    S = 0.5 * (S2 + S2.transpose());
    if (K > 0) {
      dm = A * dm;
      MatrixXd dS2(r * r, K);
      for (Index c = 0; c < K; ++c) {
        Eigen::Map<const MatrixXd> dSc(dS.col(c).data(), n, n);
        Eigen::Map<MatrixXd> out(dS2.col(c).data(), r, r);
        const MatrixXd t = A * dSc * A.transpose();
        out = 0.5 * (t + t.transpose());
      }
      dS = std::move(dS2);
    }
  }
};

// A joint Gaussian over the state (dim D) with seeds [mu (D), Sigma (D^2)] and `extra` more
// (zero) seed columns. The Sigma seed of column D + k + D l is the symmetric perturbation
// (E_kl + E_lk) / 2, which yields derivatives in the convention of Moments.
JointGaussian seeded(const VectorXd& mu, const MatrixXd& sigma, Index extra) {
  const Index D = mu.size();
  JointGaussian j;
  j.m = mu;
  j.S = sigma;
  j.dm = MatrixXd::Zero(D, D + D * D + extra);
  j.dS = MatrixXd::Zero(D * D, D + D * D + extra);
  j.dm.leftCols(D).setIdentity();
  for (Index l = 0; l < D; ++l) {
    for (Index k = 0; k < D; ++k) {
      j.dS(k + D * l, D + k + D * l) += 0.5;
      j.dS(l + D * k, D + k + D * l) += 0.5;
    }
  }
  return j;
}

std::vector<int> range(Index begin, Index count) {
  std::vector<int> r(count);
  for (Index k = 0; k < count; ++k) r[k] = static_cast<int>(begin + k);
  return r;
}

// Appends trig(x) to a joint whose first D entries are the state.
void augment(const PropagationConfig& c, bool derivs, JointGaussian& j) {
  if (c.angles.empty()) return;
  const std::vector<int> x = range(0, c.state_dim);
  j.append(x, trig_moments(c.angles, j.sub_mean(x), j.sub_cov(x), derivs), -1);
}

// Number of scalars in the policy block's moments (mean U, cov U^2, cross |policy_inputs| U).
Index policy_outputs(const PropagationConfig& c) {
  const Index U = c.control_dim();
  return U + U * U + static_cast<Index>(c.policy_inputs.size()) * U;
}

// The blocks of one step on a joint that holds the state only; leaves the next state, and the
// joint before the final map in `joint_mean`, `joint_cov`. With policy_seeds >= 0, the policy
// block's moments are seed variables at columns policy_seeds.. (policy_outputs(c) of them) and
// `policy_jacobian` receives their derivatives with respect to theta (rows [mean | cov | cross]).
// theta enters the step only through that block, so d(anything)/dtheta = d(anything)/d(policy
// moments) * policy_jacobian: 8 seed columns instead of 1406 parameters (paper §V-A's swing-up).
void step(const PropagationConfig& c, const SeModel& dynamics, const RbfPolicy& policy,
          Index policy_seeds, JointGaussian& j, VectorXd& joint_mean, MatrixXd& joint_cov,
          MatrixXd* policy_jacobian) {
  const bool derivs = j.seeds() > 0;
  const Index D = c.state_dim, A = static_cast<Index>(c.angles.size()), U = c.control_dim();
  augment(c, derivs, j);
  const Moments pm = policy.moments(j.sub_mean(c.policy_inputs), j.sub_cov(c.policy_inputs), derivs,
                                    derivs && policy_seeds >= 0);
  j.append(c.policy_inputs, pm, policy_seeds);
  if (policy_seeds >= 0 && policy_jacobian != nullptr) {
    policy_jacobian->resize(policy_outputs(c), pm.dmean_dtheta.cols());
    *policy_jacobian << pm.dmean_dtheta, pm.dcov_dtheta, pm.dcross_dtheta;
  }
  const std::vector<int> ut = range(D + 2 * A, U);
  j.append(ut, squash_moments(c.max_u, j.sub_mean(ut), j.sub_cov(ut), derivs), -1);
  std::vector<int> gin = c.dynamics_inputs;
  for (int k : range(D + 2 * A + U, U)) gin.push_back(k);
  j.append(gin, se_moments(dynamics, j.sub_mean(gin), j.sub_cov(gin), derivs), -1);
  joint_mean = j.m;
  joint_cov = j.S;
  // x' = x + Delta.
  MatrixXd P = MatrixXd::Zero(D, j.size());
  P.leftCols(D).setIdentity();
  P.rightCols(D) += MatrixXd::Identity(D, D);
  j.linear(P);
}

bool indices_ok(const std::vector<int>& idx, int bound, const char* name, std::string* why) {
  std::set<int> seen;
  for (int i : idx) {
    if (i < 0 || i >= bound || !seen.insert(i).second) {
      if (why != nullptr) {
        std::ostringstream os;
        os << "PropagationConfig: " << name << ": expected distinct indices in [0, " << bound
           << "), got " << i;
        *why = os.str();
      }
      return false;
    }
  }
  return true;
}

}  // namespace

bool PropagationConfig::IsValid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why != nullptr) *why = "PropagationConfig: " + w;
    return false;
  };
  if (state_dim < 1) return fail("state_dim: expected >= 1, got " + std::to_string(state_dim));
  if (!indices_ok(angles, state_dim, "angles", why)) return false;
  if (policy_inputs.empty()) return fail("policy_inputs: expected at least one index, got none");
  if (!indices_ok(policy_inputs, augmented_dim(), "policy_inputs", why)) return false;
  if (!indices_ok(dynamics_inputs, augmented_dim(), "dynamics_inputs", why)) return false;
  if (max_u.size() < 1) return fail("max_u: expected at least one control, got none");
  if (!(max_u.array() > 0.0).all() || !max_u.allFinite()) {
    return fail("max_u: expected finite values > 0");
  }
  return true;
}

void PropagationConfig::check(const SeModel& dynamics, const RbfPolicy& policy) const {
  std::string why;
  if (!IsValid(&why)) throw InvalidArgument(why);
  check_size("PropagationConfig: dynamics input dimension (|dynamics_inputs| + U)",
             static_cast<long>(dynamics_inputs.size()) + control_dim(), dynamics.input_dim);
  check_size("PropagationConfig: dynamics outputs (state_dim)", state_dim, dynamics.output_dim());
  check_size("PropagationConfig: policy input dimension (|policy_inputs|)",
             static_cast<long>(policy_inputs.size()), policy.input_dim());
  check_size("PropagationConfig: policy outputs (U)", control_dim(), policy.output_dim());
}

StepMoments propagate(const PropagationConfig& config, const SeModel& dynamics,
                      const RbfPolicy& policy, const VectorXd& mu, const MatrixXd& sigma,
                      StepDerivatives derivatives) {
  config.check(dynamics, policy);
  const Index D = config.state_dim;
  detail::check_gaussian("propagate", D, mu, sigma);
  StepMoments out;
  if (derivatives == StepDerivatives::kNone) {
    JointGaussian j{mu, sigma, MatrixXd(D, 0), MatrixXd(D * D, 0)};
    step(config, dynamics, policy, -1, j, out.joint_mean, out.joint_cov, nullptr);
    out.mean = j.m;
    out.cov = j.S;
    return out;
  }
  const bool with_policy = derivatives == StepDerivatives::kStateAndPolicy;
  const Index F = with_policy ? policy_outputs(config) : 0;
  JointGaussian j = seeded(mu, sigma, F);
  MatrixXd policy_jacobian;
  step(config, dynamics, policy, with_policy ? D + D * D : -1, j, out.joint_mean, out.joint_cov,
       &policy_jacobian);
  out.mean = j.m;
  out.cov = j.S;
  out.dmean_dmu = j.dm.leftCols(D);
  out.dmean_dsigma = j.dm.middleCols(D, D * D);
  out.dcov_dmu = j.dS.leftCols(D);
  out.dcov_dsigma = j.dS.middleCols(D, D * D);
  if (with_policy) {
    out.dmean_dtheta = j.dm.rightCols(F) * policy_jacobian;
    out.dcov_dtheta = j.dS.rightCols(F) * policy_jacobian;
  }
  return out;
}

CostMoments state_cost(const PropagationConfig& config, const SaturatingCost& cost,
                       const VectorXd& mu, const MatrixXd& sigma, bool derivatives) {
  std::string why;
  if (!config.IsValid(&why)) throw InvalidArgument(why);
  const Index D = config.state_dim;
  detail::check_gaussian("state_cost", D, mu, sigma);
  cost.validate(config.augmented_dim());
  if (!derivatives) {
    JointGaussian j{mu, sigma, MatrixXd(D, 0), MatrixXd(D * D, 0)};
    augment(config, false, j);
    return expected_cost(cost, j.m, j.S, false);
  }
  JointGaussian j = seeded(mu, sigma, 0);
  augment(config, true, j);
  CostMoments c = expected_cost(cost, j.m, j.S, true);
  const VectorXd g =
      (c.dmean_dmu.transpose() * j.dm + detail::as_row(c.dmean_dsigma) * j.dS).transpose();
  c.dmean_dmu = g.head(D);
  c.dmean_dsigma = Eigen::Map<const MatrixXd>(g.data() + D, D, D);
  return c;
}

ExpectedCost::ExpectedCost(PropagationConfig config, SeModel dynamics, RbfPolicy policy,
                           SaturatingCost cost, VectorXd initial_mean, MatrixXd initial_cov,
                           int horizon, double discount)
    : config_(std::move(config)),
      dynamics_(std::move(dynamics)),
      policy_(std::move(policy)),
      cost_(std::move(cost)),
      initial_mean_(std::move(initial_mean)),
      initial_cov_(std::move(initial_cov)),
      horizon_(horizon),
      discount_(discount) {
  config_.check(dynamics_, policy_);
  dynamics_.validate();
  cost_.validate(config_.augmented_dim());
  detail::check_gaussian("ExpectedCost: initial state", config_.state_dim, initial_mean_,
                         initial_cov_);
  if (horizon < 1) {
    throw InvalidArgument("ExpectedCost: horizon: expected >= 1, got " + std::to_string(horizon));
  }
  if (!(discount > 0.0 && discount <= 1.0)) {
    throw InvalidArgument("ExpectedCost: discount: expected in (0, 1], got " +
                          std::to_string(discount));
  }
}

double ExpectedCost::operator()(const VectorXd& theta, VectorXd* gradient) const {
  RbfPolicy policy = policy_;
  policy.set_params(theta);
  const Index D = config_.state_dim, P = policy.num_params();
  VectorXd m = initial_mean_;
  MatrixXd S = initial_cov_;
  MatrixXd dm, dS;  // dm_t/dtheta (D x P), dSigma_t/dtheta (D^2 x P)
  VectorXd g;
  if (gradient != nullptr) {
    dm = MatrixXd::Zero(D, P);
    dS = MatrixXd::Zero(D * D, P);
    g = VectorXd::Zero(P);
  }
  double J = 0.0, weight = 1.0;
  for (int t = 1; t <= horizon_; ++t) {
    weight *= discount_;
    if (gradient == nullptr) {
      const StepMoments s = propagate(config_, dynamics_, policy, m, S, StepDerivatives::kNone);
      m = s.mean;
      S = s.cov;
      J += weight * state_cost(config_, cost_, m, S, false).mean;
      continue;
    }
    const StepMoments s =
        propagate(config_, dynamics_, policy, m, S, StepDerivatives::kStateAndPolicy);
    MatrixXd dm2 = s.dmean_dmu * dm + s.dmean_dsigma * dS + s.dmean_dtheta;
    MatrixXd dS2 = s.dcov_dmu * dm + s.dcov_dsigma * dS + s.dcov_dtheta;
    dm = std::move(dm2);
    dS = std::move(dS2);
    m = s.mean;
    S = s.cov;
    const CostMoments c = state_cost(config_, cost_, m, S, true);
    J += weight * c.mean;
    g += weight * (c.dmean_dmu.transpose() * dm + detail::as_row(c.dmean_dsigma) * dS).transpose();
  }
  if (gradient != nullptr) *gradient = std::move(g);
  return J;
}

PredictedTrajectory ExpectedCost::predict(const VectorXd& theta) const {
  RbfPolicy policy = policy_;
  policy.set_params(theta);
  PredictedTrajectory tr;
  tr.means.push_back(initial_mean_);
  tr.covs.push_back(initial_cov_);
  tr.expected_costs.resize(horizon_);
  tr.cost_variances.resize(horizon_);
  double weight = 1.0;
  for (int t = 1; t <= horizon_; ++t) {
    weight *= discount_;
    const StepMoments s = propagate(config_, dynamics_, policy, tr.means.back(), tr.covs.back());
    // The joint is [x (D), trig (2 |angles|), u~ (U), u (U), Delta (D)].
    const Index U = config_.control_dim();
    tr.action_means.push_back(s.joint_mean.segment(config_.augmented_dim() + U, U));
    tr.means.push_back(s.mean);
    tr.covs.push_back(s.cov);
    const CostMoments c = state_cost(config_, cost_, s.mean, s.cov, false);
    tr.expected_costs[t - 1] = c.mean;
    tr.cost_variances[t - 1] = c.variance;
    tr.total += weight * c.mean;
  }
  return tr;
}

double ExpectedCost::nlopt_objective(unsigned n, const double* x, double* grad, void* data) {
  const auto* self = static_cast<const ExpectedCost*>(data);
  check_size("ExpectedCost::nlopt_objective: n (num_params)", self->num_params(), n);
  const Eigen::Map<const VectorXd> theta(x, n);
  if (grad == nullptr) return (*self)(theta, nullptr);
  VectorXd g;
  const double J = (*self)(theta, &g);
  Eigen::Map<VectorXd>(grad, n) = g;
  return J;
}

}  // namespace drops::pilco
