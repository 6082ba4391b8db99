// PILCO and PILCO with priors (baselines.md §1-2), read top-down in run_pilco() at the end of the
// file; the pieces it runs come first.
#include "drops/algo/pilco.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <optional>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/core/rng.hpp"
#include "drops/pilco/propagate.hpp"
#include "drops/pilco/trig.hpp"

namespace drops::algo {

using Eigen::Index;

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Stream tags: each random stream is derive_seed(base, {episode, tag}) or derive_seed(base, {tag}),
// base being the run's seed for the real phase and derive_seed(seed, {kSimulation}) for the
// simulation phase.
enum StreamTag : std::uint64_t {
  kEpisode = 1,         // the system's own randomness during an episode
  kRandomActions = 11,  // the actions of a random rollout
  kInducing = 12,       // the subset of inputs of a sparse GP
  kPolicyInit = 13,     // the initial RBF policy
  kSimulation = 14,     // the simulation phase's base seed
};

// ---------------------------------------------------------------------------------------------
// The policies PILCO runs on a system.

/// The task with the raw state as its observation: PILCO's controller computes its own inputs
/// (x_aug[policy_inputs]) from x. Everything else is the task's.
class RawStateTask final : public rollout::Task {
 public:
  explicit RawStateTask(const rollout::Task& task) : task_(task) {}
  std::string name() const override { return task_.name(); }
  int state_dim() const override { return task_.state_dim(); }
  int action_dim() const override { return task_.action_dim(); }
  int observation_dim() const override { return task_.state_dim(); }
  int horizon() const override { return task_.horizon(); }
  double dt() const override { return task_.dt(); }
  VectorXd initial_state() const override { return task_.initial_state(); }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override { obs = x; }
  double reward(const VectorXd& x) const override { return task_.reward(x); }
  double action_reward(const VectorXd& u) const override { return task_.action_reward(u); }
  bool has_action_reward() const override { return task_.has_action_reward(); }
  bool solved(const rollout::Trajectory& t) const override { return task_.solved(t); }
  bool absorbing(const VectorXd& x) const override { return task_.absorbing(x); }

 private:
  const rollout::Task& task_;
};

/// PILCO's controller on the raw state: u_k = max_u_k (9 sin u~_k + sin 3 u~_k) / 8 with u~ the
/// RBF policy at x_aug[policy_inputs] (conCat(congp, gSat); baselines.md §1a).
class Controller final : public policy::Policy {
 public:
  Controller(const pilco::TaskModel& model, pilco::RbfPolicy rbf)
      : model_(model), rbf_(std::move(rbf)), theta_(rbf_.params()) {}
  int observation_dim() const override { return model_.config.state_dim; }
  int action_dim() const override { return model_.config.control_dim(); }
  int param_dim() const override { return rbf_.num_params(); }
  void set_params(const VectorXd& theta) override {
    rbf_.set_params(theta);
    theta_ = theta;
  }
  const VectorXd& params() const override { return theta_; }
  void act(const VectorXd& x, double, Eigen::Ref<VectorXd> u) const override {
    const VectorXd v = rbf_.action(model_.policy_input(x));
    for (Index k = 0; k < v.size(); ++k) u[k] = pilco::squash(v[k], model_.config.max_u[k]);
  }
  std::unique_ptr<policy::Policy> clone() const override {
    return std::make_unique<Controller>(*this);
  }

 private:
  const pilco::TaskModel& model_;
  pilco::RbfPolicy rbf_;
  VectorXd theta_;
};

/// PILCO's random rollout: u = max_u (2 rand - 1) at every step, i.i.d. (rollout.m), drawn in
/// advance (one row per step) and played open loop.
class RandomActions final : public policy::Policy {
 public:
  RandomActions(int state_dim, const VectorXd& max_u, int horizon, double dt, std::uint64_t seed)
      : state_dim_(state_dim), dt_(dt), actions_(horizon, max_u.size()) {
    Rng rng(seed);
    for (Index t = 0; t < actions_.rows(); ++t)
      for (Index k = 0; k < actions_.cols(); ++k)
        actions_(t, k) = max_u[k] * (2.0 * rng.uniform() - 1.0);
  }
  int observation_dim() const override { return state_dim_; }
  int action_dim() const override { return static_cast<int>(actions_.cols()); }
  int param_dim() const override { return 0; }
  void set_params(const VectorXd& theta) override {
    check_size("RandomActions: parameters", 0, theta.size());
  }
  const VectorXd& params() const override { return none_; }
  void act(const VectorXd&, double t, Eigen::Ref<VectorXd> u) const override {
    const Index step = std::clamp<Index>(std::lround(t / dt_), 0, actions_.rows() - 1);
    u = actions_.row(step).transpose();
  }
  std::unique_ptr<policy::Policy> clone() const override {
    return std::make_unique<RandomActions>(*this);
  }

 private:
  int state_dim_;
  double dt_;
  MatrixXd actions_;
  VectorXd none_;
};

// ---------------------------------------------------------------------------------------------
// Learning the dynamics.

/// The prior mean of PILCO with priors: per output, the simulator GP's posterior mean as an RBF
/// network block (baselines.md §2a); empty without a prior.
using PriorMean = std::vector<pilco::SeBlock>;

/// A trained dynamics model: the moment-matching model and what the next training starts from.
struct Dynamics {
  pilco::SeModel model;     ///< per output [prior mean block (with a prior), GP block]
  std::vector<VectorXd> h;  ///< per output [log l (Din), log sigma_f, log sigma_n]
  int points = 0;           ///< N, the transitions learned from
  int inducing = 0;         ///< M, the inducing inputs of the sparse GP (0: the full GP)
  long rprop_iterations = 0;
  VectorXd log_likelihoods;  ///< per output, on the (subset of) points the kernel was fitted on
  double seconds = 0;
};

/// PILCO's starting hyper-parameters of a GP on (X, y) (train.m): log l_d = log std(X_d),
/// log sigma_f = log std(y), log sigma_n = log(std(y) / 10); spreads below 1e-6 count as 1e-6 and
/// the values are clamped to Rprop's box.
VectorXd initial_h(const MatrixXd& X, const VectorXd& y) {
  auto stdev = [](const auto& v) {
    const double m = v.mean();
    const double s =
        v.size() > 1 ? std::sqrt((v.array() - m).square().sum() / (v.size() - 1)) : 1.0;
    return std::max(s, 1e-6);
  };
  VectorXd h(X.cols() + 2);
  for (Index d = 0; d < X.cols(); ++d) h[d] = std::log(stdev(X.col(d)));
  const double sy = stdev(y);
  h[X.cols()] = std::log(sy);
  h[X.cols() + 1] = std::max(std::log(sy / 10.0), std::log(1e-5));
  return h.cwiseMax(-10.0).cwiseMin(10.0);
}

/// Trains one GP per output (in parallel) on inputs [x_aug[dynamics_inputs], u] and targets
/// dx - m(x) (m: the prior mean, if any), warm-started from h0 (or initial_h), with PILCO's soft
/// walls; beyond max_points transitions the kernel is fitted on a random subset of max_points of
/// them (stream `subset_seed`) and the model is the FITC GP with that subset as inducing inputs.
Dynamics learn_dynamics(const pilco::TaskModel& tm, const std::vector<Transition>& data,
                        const PriorMean& prior, const std::vector<VectorXd>& h0,
                        const PilcoOptions& o, std::uint64_t subset_seed) {
  const auto t0 = Clock::now();
  const Index N = static_cast<Index>(data.size());
  const Index D = tm.config.state_dim;
  const Index Din = static_cast<Index>(tm.config.dynamics_inputs.size()) + tm.config.control_dim();
  MatrixXd X(N, Din), Y(N, D);
  for (Index i = 0; i < N; ++i) {
    const Transition& tr = data[static_cast<std::size_t>(i)];
    X.row(i) = tm.dynamics_input(tr.x, tr.u).transpose();
    Y.row(i) = tr.dx.transpose();
  }
  if (!prior.empty())
    for (Index a = 0; a < D; ++a) Y.col(a) -= pilco::block_values(prior[a], X);

  // The points the kernels are fitted on: all, or a random subset (partial Fisher-Yates).
  std::vector<Index> subset(static_cast<std::size_t>(N));
  std::iota(subset.begin(), subset.end(), Index{0});
  const bool sparse = N > o.max_points;
  if (sparse) {
    Rng rng(subset_seed);
    for (Index k = 0; k < o.max_points; ++k) {
      const Index j = k + static_cast<Index>(rng.uniform() * static_cast<double>(N - k));
      std::swap(subset[static_cast<std::size_t>(k)],
                subset[static_cast<std::size_t>(std::min(j, N - 1))]);
    }
    subset.resize(static_cast<std::size_t>(o.max_points));
    std::sort(subset.begin(), subset.end());
  }
  const Index M = static_cast<Index>(subset.size());
  MatrixXd Xs(M, Din), Ys(M, D);
  for (Index k = 0; k < M; ++k) {
    Xs.row(k) = X.row(subset[static_cast<std::size_t>(k)]);
    Ys.row(k) = Y.row(subset[static_cast<std::size_t>(k)]);
  }

  Dynamics dyn;
  dyn.points = static_cast<int>(N);
  dyn.inducing = sparse ? static_cast<int>(M) : 0;
  dyn.h.resize(static_cast<std::size_t>(D));
  dyn.log_likelihoods.resize(D);
  std::vector<pilco::SeBlock> blocks(static_cast<std::size_t>(D));
  std::vector<long> iterations(static_cast<std::size_t>(D), 0);
  parallel_for(static_cast<std::size_t>(D), [&](std::size_t a) {
    const Index ia = static_cast<Index>(a);
    gp::Gp g(static_cast<int>(Din));
    const bool warm = a < h0.size() && h0[a].size() == Din + 2;
    g.set_h_params(warm ? h0[a] : initial_h(Xs, Ys.col(ia)));
    g.compute(Xs, Ys.col(ia));
    const gp::RpropSummary rs = g.optimize_h_params(o.rprop);
    iterations[a] = rs.iterations;
    dyn.log_likelihoods[ia] = rs.final_log_likelihood;
    dyn.h[a] = g.h_params();
    if (!sparse) {
      blocks[a] = pilco::gp_block(g);
    } else {
      const VectorXd& h = dyn.h[a];
      blocks[a] = pilco::fitc_block(X, Y.col(ia), Xs, h.head(Din).array().exp(),
                                    std::exp(2.0 * h[Din]), std::exp(2.0 * h[Din + 1]));
    }
  });
  dyn.model.input_dim = static_cast<int>(Din);
  for (Index a = 0; a < D; ++a) {
    pilco::SeOutput out;
    if (!prior.empty()) out.blocks.push_back(prior[a]);
    out.blocks.push_back(std::move(blocks[static_cast<std::size_t>(a)]));
    dyn.model.outputs.push_back(std::move(out));
  }
  dyn.rprop_iterations = std::accumulate(iterations.begin(), iterations.end(), 0L);
  dyn.seconds = seconds_since(t0);
  return dyn;
}

/// The posterior means of a trained model's GP blocks: the prior mean of PILCO with priors.
PriorMean mean_blocks(const pilco::SeModel& model) {
  PriorMean m;
  for (const auto& out : model.outputs) {
    pilco::SeBlock b = out.blocks.back();
    b.gp_variance = false;
    b.k_inverse.resize(0, 0);
    m.push_back(std::move(b));
  }
  return m;
}

// ---------------------------------------------------------------------------------------------
// The policy.

/// PILCO's initial policy (settings_pendubot.m): centres drawn from the Gaussian of the initial
/// state's policy inputs x_aug[policy_inputs] under N(x0, Sigma0), targets 0.1 N(0, 1), length
/// scales TaskModel::policy_length_scales (1 when empty).
pilco::RbfPolicy initial_policy(const pilco::TaskModel& tm, const VectorXd& x0, int centres,
                                std::uint64_t seed) {
  const auto& c = tm.config;
  const Index D = c.state_dim, p = c.augmented_dim();
  const pilco::Moments trig = pilco::trig_moments(c.angles, x0, tm.initial_cov);
  VectorXd m(p);
  m << x0, trig.mean;
  MatrixXd S(p, p);
  S.topLeftCorner(D, D) = tm.initial_cov;
  S.topRightCorner(D, p - D) = tm.initial_cov * trig.cross;
  S.bottomLeftCorner(p - D, D) = S.topRightCorner(D, p - D).transpose();
  S.bottomRightCorner(p - D, p - D) = trig.cov;
  const Index d = static_cast<Index>(c.policy_inputs.size());
  VectorXd mp(d);
  MatrixXd Sp(d, d);
  for (Index i = 0; i < d; ++i) {
    mp[i] = m[c.policy_inputs[static_cast<std::size_t>(i)]];
    for (Index j = 0; j < d; ++j)
      Sp(i, j) = S(c.policy_inputs[static_cast<std::size_t>(i)],
                   c.policy_inputs[static_cast<std::size_t>(j)]);
  }
  // A square root that also works for a singular Sigma0.
  const Eigen::SelfAdjointEigenSolver<MatrixXd> eig(0.5 * (Sp + Sp.transpose()));
  const MatrixXd root =
      eig.eigenvectors() * eig.eigenvalues().cwiseMax(0.0).cwiseSqrt().asDiagonal();
  Rng rng(seed);
  const int U = c.control_dim();
  MatrixXd C(centres, d), T(centres, U);
  for (Index i = 0; i < centres; ++i) {
    VectorXd z(d);
    for (Index k = 0; k < d; ++k) z[k] = rng.normal();
    C.row(i) = (mp + root * z).transpose();
  }
  for (Index i = 0; i < centres; ++i)
    for (Index k = 0; k < U; ++k) T(i, k) = 0.1 * rng.normal();
  const VectorXd l = tm.policy_length_scales.size() ? tm.policy_length_scales : VectorXd::Ones(d);
  const MatrixXd logl = l.array().log().matrix().replicate(1, U);
  pilco::RbfPolicy policy(static_cast<int>(d), centres, U);
  policy.set(C, T, logl);
  return policy;
}

/// What one policy optimisation found.
struct PolicySearch {
  VectorXd theta;
  opt::LbfgsSummary lbfgs;
  long failures = 0;          ///< evaluations where J could not be computed (counted as 2 H)
  std::string first_failure;  ///< the first such error's message
};

/// L-BFGS on J(theta) from theta0. An evaluation that fails numerically (a Cholesky of the policy
/// or of the moment matching, length scales out of range after a long line-search step) counts
/// as J = 2 H (worse than any policy) with a zero gradient, so that the line search backs off;
/// such failures are counted and the first message kept.
PolicySearch optimize_policy(const pilco::ExpectedCost& J, const VectorXd& theta0,
                             const opt::LbfgsOptions& options, double fail_value,
                             const std::function<bool(const opt::LbfgsProgress&)>& on_evaluation) {
  PolicySearch s;
  auto f = [&](const VectorXd& theta, VectorXd* g) {
    try {
      return J(theta, g);
    } catch (const Error& e) {
      if (dynamic_cast<const NumericalError*>(&e) == nullptr &&
          dynamic_cast<const InvalidArgument*>(&e) == nullptr)
        throw;
      if (s.failures++ == 0) s.first_failure = e.what();
      if (g) g->setZero(theta.size());
      return fail_value;
    }
  };
  s.lbfgs = opt::lbfgs_minimize(f, theta0, options, on_evaluation);
  s.theta = s.lbfgs.x;
  return s;
}

/// The model's prediction of a policy: state means, control means and expected rewards
/// 1 - E[c_{reward_width}(x_t)] per step (NaN without a reward width), and their sum.
struct Prediction {
  rollout::Trajectory trajectory;
  double predicted_return = kNaN;
};

Prediction predict(const pilco::ExpectedCost& J, const VectorXd& theta,
                   const pilco::TaskModel& tm) {
  const pilco::PredictedTrajectory pt = J.predict(theta);
  const Index H = J.horizon(), D = tm.config.state_dim, U = tm.config.control_dim();
  Prediction p;
  rollout::Trajectory& tr = p.trajectory;
  tr.states.resize(H + 1, D);
  tr.actions.resize(H, U);
  tr.rewards.resize(H);
  for (Index t = 0; t <= H; ++t)
    tr.states.row(t) = pt.means[static_cast<std::size_t>(t)].transpose();
  for (Index t = 0; t < H; ++t)
    tr.actions.row(t) = pt.action_means[static_cast<std::size_t>(t)].transpose();
  if (tm.reward_width > 0) {
    const pilco::SaturatingCost reward_cost = tm.cost(tm.reward_width);
    for (Index t = 1; t <= H; ++t)
      tr.rewards[t - 1] =
          1.0 - pilco::state_cost(tm.config, reward_cost, pt.means[static_cast<std::size_t>(t)],
                                  pt.covs[static_cast<std::size_t>(t)])
                    .mean;
    p.predicted_return = tr.rewards.sum();
  } else {
    tr.rewards.setConstant(kNaN);
  }
  return p;
}

// ---------------------------------------------------------------------------------------------
// One iteration of PILCO's loop.

/// What PILCO carries from one episode to the next within a phase.
struct LoopState {
  std::vector<Transition> data;  ///< every transition of the phase
  VectorXd theta;                ///< the current policy (empty before the first optimisation)
  std::vector<VectorXd> h;       ///< GP hyper-parameters (warm starts)
};

/// What is fixed during a run.
struct Setting {
  const rollout::Task& task;
  const RawStateTask& raw;
  const pilco::TaskModel& tm;
  const PilcoOptions& o;
  pilco::SaturatingCost cost;  ///< of the optimisation's width
  VectorXd x0;
  int horizon = 0;
  double fail_value = 0;  ///< J counted for a failed evaluation
};

/// An episode's plan: the policy to run, the model's prediction of it and the facts to record.
struct Plan {
  std::unique_ptr<policy::Policy> policy;
  VectorXd theta;  ///< empty for random actions
  bool random = false;
  Prediction prediction;
  Dynamics dynamics;  ///< the model that chose the policy (empty for random actions)
  double model_seconds = 0, policy_seconds = 0;
  long evaluations = 0;
  Details details;
  bool interrupted = false;  ///< the optimisation was stopped by the caller: do not run
};

Plan random_plan(const Setting& s, std::uint64_t seed) {
  Plan p;
  p.random = true;
  p.policy = std::make_unique<RandomActions>(s.tm.config.state_dim, s.tm.config.max_u, s.horizon,
                                             s.task.dt(), seed);
  p.details.texts["policy"] = "random actions";
  return p;
}

/// Learns the model on st.data (prior mean: `prior`), optimises the policy from st.theta (the
/// initial policy when empty) and predicts it; updates st.theta and st.h. `base`: the phase's base
/// seed; `status(phase, evaluations, best)` reports progress; `stop()` polls the caller.
Plan learned_plan(const Setting& s, LoopState& st, const PriorMean& prior, std::uint64_t base,
                  std::uint64_t episode,
                  const std::function<void(const char*, long, double)>& status,
                  const std::function<bool()>& stop) {
  Plan p;
  status("model", 0, 0);
  p.dynamics =
      learn_dynamics(s.tm, st.data, prior, st.h, s.o, derive_seed(base, {episode, kInducing}));
  st.h = p.dynamics.h;
  p.model_seconds = p.dynamics.seconds;

  const auto t_policy = Clock::now();
  pilco::RbfPolicy proto =
      initial_policy(s.tm, s.x0, s.o.centres, derive_seed(base, {kPolicyInit}));
  if (st.theta.size() == 0) st.theta = proto.params();
  const pilco::ExpectedCost J(s.tm.config, p.dynamics.model, proto, s.cost, s.x0, s.tm.initial_cov,
                              s.horizon, s.o.discount);
  const double max_j =
      s.o.discount == 1.0
          ? s.horizon
          : s.o.discount * (1 - std::pow(s.o.discount, s.horizon)) / (1 - s.o.discount);
  const PolicySearch search =
      optimize_policy(J, st.theta, s.o.lbfgs, s.fail_value, [&](const opt::LbfgsProgress& pr) {
        status("policy", pr.evaluations, max_j - pr.best_value);
        if (stop()) return false;
        return true;
      });
  p.policy_seconds = seconds_since(t_policy);
  p.evaluations = search.lbfgs.evaluations;
  if (search.lbfgs.termination == opt::LbfgsTermination::kStopped) {
    p.interrupted = true;
    return p;
  }
  st.theta = search.theta;
  p.theta = search.theta;
  auto controller = std::make_unique<Controller>(s.tm, proto);
  controller->set_params(p.theta);
  p.policy = std::move(controller);
  p.prediction = predict(J, p.theta, s.tm);

  auto& n = p.details.numbers;
  n["gp_points"] = p.dynamics.points;
  n["gp_inducing_inputs"] = p.dynamics.inducing;
  n["rprop_iterations"] = static_cast<double>(p.dynamics.rprop_iterations);
  n["lbfgs_evaluations"] = search.lbfgs.evaluations;
  n["expected_cost_start"] = search.lbfgs.initial_value;
  n["expected_cost"] = search.lbfgs.value;
  n["objective_failures"] = static_cast<double>(search.failures);
  p.details.texts["policy"] = "L-BFGS";
  p.details.texts["lbfgs_stop"] = opt::to_string(search.lbfgs.termination);
  if (!search.first_failure.empty())
    p.details.texts["first_objective_failure"] = search.first_failure;
  return p;
}

// ---------------------------------------------------------------------------------------------
// The state saved between episodes: PILCO's own part of a RunState.

/// Episode 1 of PILCO with priors, planned on the simulation model.
struct SimulationResult {
  PriorMean prior;        ///< per output, the posterior mean of the GP that chose theta
  VectorXd theta;         ///< theta_sim, the simulation phase's last policy
  Prediction prediction;  ///< theta's prediction on the simulation model
};

/// The simulation phase so far, saved after each simulated episode but the last (episodes_done
/// stays 0) so that a run stopped during the phase continues it where it was.
struct PartialSimulation {
  int episodes = 0;              ///< simulated episodes done, in [1, sim_episodes - 1]
  LoopState state;               ///< the phase's transitions, policy and GP warm starts
  std::vector<Details> records;  ///< per simulated episode, its record
  double seconds = 0;            ///< the phase's elapsed seconds
};

/// What a saved state must fit: the run's sizes and whether it has a simulation phase.
struct StateShape {
  Index state_dim = 0;           ///< D
  Index control_dim = 0;         ///< U
  Index horizon = 0;             ///< H
  Index dynamics_input_dim = 0;  ///< Din: the GPs' inputs [x_aug[dynamics_inputs], u]
  bool with_prior = false;       ///< PILCO with priors
  int sim_episodes = 0;          ///< PilcoOptions::sim_episodes
};

/// PILCO's own part of a RunState (RunState::extra, checkpoint.json "extra"), written and read
/// only by run_pilco. A state saved during the simulation phase holds only partial_simulation; one
/// saved after it holds theta (once there is one) and, with a prior, the simulation result.
struct PilcoOwnState {
  /// The real phase's current policy (empty before its first optimisation).
  VectorXd theta;
  /// With a prior: the simulation phase's result.
  std::optional<SimulationResult> simulation;
  /// With a prior: the simulation phase so far, when the run stopped during it.
  std::optional<PartialSimulation> partial_simulation;

  /// Its entries of RunState::extra (none for an empty field).
  StateVectors save() const;
  /// Reads it back from RunState::extra. With shape.with_prior, a state that holds a partial
  /// simulation gives that alone; any other gives theta (when it has one) and the simulation
  /// result, whose entries are then required. Without a prior, theta only. Throws InvalidArgument
  /// naming the entry when one is missing or does not fit `shape`.
  static PilcoOwnState load(const StateVectors& extra, const StateShape& shape);
};

// PilcoOwnState's entries. Matrices are stored flat in column-major order, a number as a vector
// of one.
constexpr const char* kThetaKey = "theta";  // the real phase's current policy
// Per output a of the prior mean: "prior.<a>.centres" (centres x Din), "prior.<a>.weights"
// (centres), "prior.<a>.length_scales" (Din), "prior.<a>.signal_variance".
constexpr const char* kPriorKey = "prior.";
constexpr const char* kSimulationThetaKey = "simulation.theta";
constexpr const char* kPredictedStatesKey = "simulation.predicted_states";    // (H + 1) x D
constexpr const char* kPredictedActionsKey = "simulation.predicted_actions";  // H x U
constexpr const char* kPredictedRewardsKey = "simulation.predicted_rewards";  // H
constexpr const char* kPredictedReturnKey = "simulation.predicted_return";
// The partial simulation's entries are kPartialKey followed by "episodes", "seconds", "data"
// (transitions x [x, u, dx]; absent without transitions), "theta" (absent before the first
// optimisation), "h.<a>" per output a, "number.<name>" and "number_kind.<name>" per number of the
// records (see write_partial_simulation), "text.<name>" per text of the records (each episode's
// text as its bytes, followed by a 0).
constexpr const char* kPartialKey = "simulation.partial.";

std::string prior_key(const char* what, Index a) {
  return std::string(kPriorKey) + std::to_string(a) + "." + what;
}

VectorXd flat(const MatrixXd& m) { return Eigen::Map<const VectorXd>(m.data(), m.size()); }

/// The entry `k`; throws InvalidArgument naming it when the state has none.
const VectorXd& entry(const StateVectors& extra, const std::string& k) {
  const auto it = extra.find(k);
  if (it == extra.end()) throw InvalidArgument("resume: the state has no '" + k + "'");
  return it->second;
}

void write_prior(const PriorMean& prior, StateVectors& extra) {
  for (Index a = 0; a < static_cast<Index>(prior.size()); ++a) {
    const auto& b = prior[static_cast<std::size_t>(a)];
    extra[prior_key("centres", a)] = flat(b.centres);
    extra[prior_key("weights", a)] = b.weights;
    extra[prior_key("length_scales", a)] = b.length_scales;
    extra[prior_key("signal_variance", a)] = VectorXd::Constant(1, b.signal_variance);
  }
}

PriorMean read_prior(const StateVectors& extra, Index outputs, Index input_dim) {
  PriorMean prior;
  for (Index a = 0; a < outputs; ++a) {
    pilco::SeBlock b;
    const VectorXd& c = entry(extra, prior_key("centres", a));
    if (c.size() % input_dim != 0)
      throw InvalidArgument("resume: " + prior_key("centres", a) + " does not hold whole centres");
    b.centres = Eigen::Map<const MatrixXd>(c.data(), c.size() / input_dim, input_dim);
    b.weights = entry(extra, prior_key("weights", a));
    b.length_scales = entry(extra, prior_key("length_scales", a));
    const VectorXd& sv = entry(extra, prior_key("signal_variance", a));
    check_size("resume: prior signal variance", 1, sv.size());
    b.signal_variance = sv[0];
    prior.push_back(std::move(b));
  }
  pilco::SeModel check{static_cast<int>(input_dim), {}};
  for (const auto& b : prior) {
    pilco::SeOutput out;
    out.blocks.push_back(b);
    check.outputs.push_back(std::move(out));
  }
  check.validate();
  return prior;
}

void write_simulation(const SimulationResult& sim, StateVectors& extra) {
  write_prior(sim.prior, extra);
  extra[kSimulationThetaKey] = sim.theta;
  const auto& t = sim.prediction.trajectory;
  extra[kPredictedStatesKey] = flat(t.states);
  extra[kPredictedActionsKey] = flat(t.actions);
  extra[kPredictedRewardsKey] = t.rewards;
  extra[kPredictedReturnKey] = VectorXd::Constant(1, sim.prediction.predicted_return);
}

SimulationResult read_simulation(const StateVectors& extra, const StateShape& shape) {
  const Index D = shape.state_dim, U = shape.control_dim, H = shape.horizon;
  SimulationResult sim;
  sim.prior = read_prior(extra, D, shape.dynamics_input_dim);
  sim.theta = entry(extra, kSimulationThetaKey);
  const VectorXd& xs = entry(extra, kPredictedStatesKey);
  const VectorXd& us = entry(extra, kPredictedActionsKey);
  check_size((std::string("resume: ") + kPredictedStatesKey).c_str(), (H + 1) * D, xs.size());
  check_size((std::string("resume: ") + kPredictedActionsKey).c_str(), H * U, us.size());
  sim.prediction.trajectory.states = Eigen::Map<const MatrixXd>(xs.data(), H + 1, D);
  sim.prediction.trajectory.actions = Eigen::Map<const MatrixXd>(us.data(), H, U);
  sim.prediction.trajectory.rewards = entry(extra, kPredictedRewardsKey);
  check_size((std::string("resume: ") + kPredictedRewardsKey).c_str(), H,
             sim.prediction.trajectory.rewards.size());
  sim.prediction.predicted_return = entry(extra, kPredictedReturnKey)[0];
  return sim;
}

void write_partial_simulation(const PartialSimulation& p, StateVectors& extra) {
  const std::string k = kPartialKey;
  extra[k + "episodes"] = VectorXd::Constant(1, p.episodes);
  extra[k + "seconds"] = VectorXd::Constant(1, p.seconds);
  const auto& data = p.state.data;
  if (!data.empty()) {
    const Index D = data.front().x.size(), U = data.front().u.size();
    MatrixXd rows(static_cast<Index>(data.size()), 2 * D + U);
    for (std::size_t i = 0; i < data.size(); ++i)
      rows.row(static_cast<Index>(i)) << data[i].x.transpose(), data[i].u.transpose(),
          data[i].dx.transpose();
    extra[k + "data"] = flat(rows);
  }
  if (p.state.theta.size()) extra[k + "theta"] = p.state.theta;
  for (std::size_t a = 0; a < p.state.h.size(); ++a)
    extra[k + "h." + std::to_string(a)] = p.state.h[a];
  // Numbers per key as two vectors over the episodes: the values (non-finite ones as 0, as the
  // checkpoint's JSON has no NaN) and their kinds (0 absent, 1 finite, 2 NaN, 3 +inf, 4 -inf).
  std::map<std::string, std::pair<VectorXd, VectorXd>> numbers;
  const auto n = static_cast<Index>(p.records.size());
  for (Index e = 0; e < n; ++e) {
    for (const auto& [key, v] : p.records[static_cast<std::size_t>(e)].numbers) {
      auto [it, fresh] =
          numbers.try_emplace(key, VectorXd::Zero(n), VectorXd::Zero(n));
      const bool finite = std::isfinite(v);
      it->second.first[e] = finite ? v : 0.0;
      it->second.second[e] = finite ? 1 : std::isnan(v) ? 2 : v > 0 ? 3 : 4;
    }
  }
  std::vector<std::string> text_keys;
  for (const auto& d : p.records)
    for (const auto& [key, v] : d.texts)
      if (std::find(text_keys.begin(), text_keys.end(), key) == text_keys.end())
        text_keys.push_back(key);
  for (const auto& key : text_keys) {
    std::vector<double> bytes;
    for (const auto& d : p.records) {
      const auto it = d.texts.find(key);
      if (it != d.texts.end())
        for (const unsigned char c : it->second) bytes.push_back(c);
      bytes.push_back(0);
    }
    extra[k + "text." + key] = Eigen::Map<const VectorXd>(bytes.data(), bytes.size());
  }
  for (auto& [key, v] : numbers) {
    extra[k + "number." + key] = std::move(v.first);
    extra[k + "number_kind." + key] = std::move(v.second);
  }
}

bool has_partial_simulation(const StateVectors& extra) {
  return extra.count(std::string(kPartialKey) + "episodes") > 0;
}

PartialSimulation read_partial_simulation(const StateVectors& extra, const StateShape& shape) {
  const Index D = shape.state_dim, U = shape.control_dim, H = shape.horizon;
  const std::string k = kPartialKey;
  PartialSimulation p;
  p.episodes = static_cast<int>(entry(extra, k + "episodes")[0]);
  if (p.episodes < 1 || p.episodes >= shape.sim_episodes)
    throw InvalidArgument("resume: " + k + "episodes = " + std::to_string(p.episodes) +
                          " is outside [1, " + std::to_string(shape.sim_episodes - 1) + "]");
  p.seconds = entry(extra, k + "seconds")[0];
  const Index width = 2 * D + U;
  const VectorXd& d = entry(extra, k + "data");
  check_size(("resume: " + k + "data (episodes x horizon x (2 D + U))").c_str(),
             static_cast<long>(p.episodes) * H * width, d.size());
  const Eigen::Map<const MatrixXd> rows(d.data(), d.size() / width, width);
  for (Index i = 0; i < rows.rows(); ++i)
    p.state.data.push_back(
        {rows.row(i).head(D).transpose(), rows.row(i).segment(D, U).transpose(),
         rows.row(i).tail(D).transpose()});
  if (const auto it = extra.find(k + "theta"); it != extra.end()) p.state.theta = it->second;
  for (Index a = 0; extra.count(k + "h." + std::to_string(a)); ++a) {
    p.state.h.push_back(entry(extra, k + "h." + std::to_string(a)));
    check_size("resume: simulation GP hyper-parameters", shape.dynamics_input_dim + 2,
               p.state.h.back().size());
  }
  p.records.resize(static_cast<std::size_t>(p.episodes));
  const std::string numbers = k + "number.", texts = k + "text.";
  for (const auto& [key, v] : extra) {
    if (key.rfind(numbers, 0) == 0) {
      const std::string name = key.substr(numbers.size());
      const VectorXd& kind = entry(extra, k + "number_kind." + name);
      check_size(("resume: " + key).c_str(), p.episodes, v.size());
      check_size(("resume: " + k + "number_kind." + name).c_str(), p.episodes, kind.size());
      for (int e = 0; e < p.episodes; ++e) {
        const double inf = std::numeric_limits<double>::infinity();
        const double value = kind[e] == 1   ? v[e]
                             : kind[e] == 2 ? std::nan("")
                             : kind[e] == 3 ? inf
                                            : -inf;
        if (kind[e] != 0) p.records[static_cast<std::size_t>(e)].numbers[name] = value;
      }
    } else if (key.rfind(texts, 0) == 0) {
      std::size_t e = 0;
      std::string text;
      for (Index i = 0; i < v.size(); ++i) {
        if (v[i] != 0) {
          text.push_back(static_cast<char>(static_cast<unsigned char>(v[i])));
          continue;
        }
        if (e >= p.records.size()) throw InvalidArgument("resume: " + key + ": too many texts");
        if (!text.empty()) p.records[e].texts[key.substr(texts.size())] = text;
        text.clear();
        ++e;
      }
      check_size(("resume: " + key + " (texts)").c_str(), p.episodes, static_cast<long>(e));
    }
  }
  return p;
}

StateVectors PilcoOwnState::save() const {
  StateVectors extra;
  if (theta.size()) extra[kThetaKey] = theta;
  if (simulation) write_simulation(*simulation, extra);
  if (partial_simulation) write_partial_simulation(*partial_simulation, extra);
  return extra;
}

PilcoOwnState PilcoOwnState::load(const StateVectors& extra, const StateShape& shape) {
  PilcoOwnState own;
  if (shape.with_prior && has_partial_simulation(extra)) {
    own.partial_simulation = read_partial_simulation(extra, shape);
    return own;
  }
  if (const auto it = extra.find(kThetaKey); it != extra.end()) own.theta = it->second;
  if (shape.with_prior) own.simulation = read_simulation(extra, shape);
  return own;
}

}  // namespace

// ---------------------------------------------------------------------------------------------

gp::RpropOptions pilco_rprop_defaults() {
  gp::RpropOptions r;
  r.max_iterations = 300;
  r.tolerance = 1e-3;
  r.patience = 10;
  r.penalty = true;
  r.max_length_scale_ratio = 100.0;
  r.max_snr = 1000.0;
  r.power = 30;
  return r;
}

opt::LbfgsOptions pilco_lbfgs_defaults() {
  opt::LbfgsOptions l;
  l.max_evaluations = 150;
  l.scale_first_step = true;  // minimize.m's first step; NLopt's full -g step fails on J
  l.max_restarts = 50;        // bounded by the budget; see docs/pilco.md (J round-off noise)
  l.ftol_rel = 1e-8;
  l.xtol_rel = 1e-8;
  return l;
}

bool PilcoOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (episodes < 1) return fail("episodes must be >= 1");
  if (random_rollouts < 1) return fail("random_rollouts must be >= 1");
  if (with_prior && sim_episodes <= random_rollouts)
    return fail(
        "sim_episodes must be > random_rollouts (the simulation phase must end with a "
        "learned policy)");
  if (centres < 1) return fail("centres must be >= 1");
  if (!(cost_width >= 0) || !std::isfinite(cost_width)) return fail("cost_width must be >= 0");
  if (!(discount > 0 && discount <= 1)) return fail("discount must be in (0, 1]");
  if (max_points < 1) return fail("max_points must be >= 1");
  std::string w;
  if (!lbfgs.IsValid(&w)) return fail("lbfgs: " + w);
  if (lbfgs.lower.size()) return fail("lbfgs: the policy search has no bounds");
  if (!rprop.IsValid(&w)) return fail("rprop: " + w);
  return true;
}

Pilco::Pilco(const PilcoOptions& options, pilco::TaskModel task_model)
    : options_(options), task_model_(std::move(task_model)) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("PILCO options: " + why);
  if (!task_model_.IsValid(&why)) throw InvalidArgument(why);
}

RunSummary Pilco::run(const Problem& problem, const Callbacks& callbacks,
                      const RunState* resume) const {
  if (!problem.task) throw InvalidArgument("Problem: task is null");
  if (!problem.real) throw InvalidArgument("Problem: real system is null");
  return run_pilco(problem.task, *problem.real, problem.prior, problem.prior_parameters,
                   task_model_, options_, callbacks, resume);
}

RunSummary run_pilco(std::shared_ptr<const rollout::Task> task, const rollout::System& real,
                     std::shared_ptr<const model::MeanFunction> prior,
                     const model::PriorParameters& prior_parameters, const pilco::TaskModel& tm,
                     const PilcoOptions& o, const Callbacks& callbacks, const RunState* resume) {
  // 0. Checks and what is fixed during the run.
  std::string why;
  if (!o.IsValid(&why)) throw InvalidArgument("PILCO options: " + why);
  if (!tm.IsValid(&why)) throw InvalidArgument(why);
  if (!task) throw InvalidArgument("run_pilco: task is null");
  check_size("run_pilco: task model state_dim vs task state_dim", task->state_dim(),
             tm.config.state_dim);
  check_size("run_pilco: task model controls (max_u) vs task action_dim", task->action_dim(),
             tm.config.control_dim());
  if (o.with_prior) {
    if (!prior)
      throw InvalidArgument("run_pilco: PILCO with priors needs the task's simulator prior");
    check_size("run_pilco: prior state_dim vs task", task->state_dim(), prior->state_dim());
    check_size("run_pilco: prior action_dim vs task", task->action_dim(), prior->action_dim());
  }
  const double width = o.cost_width > 0 ? o.cost_width : tm.reward_width;
  if (!(width > 0))
    throw InvalidArgument(
        "run_pilco: cost width: the task model gives no reward width; set the "
        "cost width (PilcoOptions::cost_width, pilco.cost_width)");
  const auto t_run = Clock::now();
  const RawStateTask raw(*task);
  const Setting s{*task,
                  raw,
                  tm,
                  o,
                  tm.cost(width),
                  task->initial_state(),
                  task->horizon(),
                  2.0 * task->horizon()};
  const Index D = tm.config.state_dim, U = tm.config.control_dim();
  const Index Din = static_cast<Index>(tm.config.dynamics_inputs.size()) + U;
  const double episode_time = task->horizon() * task->dt();
  auto stop = [&] { return callbacks.should_stop && callbacks.should_stop(); };

  RunSummary summary;
  LoopState st;  // the real phase
  PriorMean prior_mean;
  SimulationResult sim;
  VectorXd best_theta;
  double best_return = -std::numeric_limits<double>::infinity();
  int first_episode = 1;
  auto save = [&](int episodes_done) {
    if (!callbacks.on_state) return;
    RunState rs;
    rs.episodes_done = episodes_done;
    rs.data = st.data;
    rs.best_theta = best_theta;
    rs.best_return = best_return;
    rs.first_solved_episode = summary.first_solved_episode;
    rs.model.h_params = st.h;
    PilcoOwnState own;
    own.theta = st.theta;
    if (o.with_prior) own.simulation = sim;
    rs.extra = own.save();
    callbacks.on_state(rs);
  };

  // 1. Resume, or (with a prior) the simulation phase: PILCO on the simulator at phi_0, itself
  // resumed when the run stopped during it.
  const StateShape shape{D, U, task->horizon(), Din, o.with_prior, o.sim_episodes};
  PilcoOwnState resumed = resume ? PilcoOwnState::load(resume->extra, shape) : PilcoOwnState{};
  const bool resume_simulation = resumed.partial_simulation.has_value();
  if (resume && !resume_simulation) {
    if (resume->episodes_done < (o.with_prior ? 0 : 1) || resume->episodes_done > o.episodes)
      throw InvalidArgument("resume: episodes_done = " + std::to_string(resume->episodes_done) +
                            " is outside [" + (o.with_prior ? "0" : "1") + ", " +
                            std::to_string(o.episodes) + "]");
    check_size("resume: transitions (episodes_done x horizon)",
               static_cast<long>(resume->episodes_done) * task->horizon(),
               static_cast<long>(resume->data.size()));
    st.data = resume->data;
    st.h = resume->model.h_params;
    for (const auto& h : st.h) check_size("resume: GP hyper-parameters", Din + 2, h.size());
    st.theta = std::move(resumed.theta);
    best_theta = resume->best_theta;
    best_return = resume->best_return;
    summary.first_solved_episode = resume->first_solved_episode;
    summary.episodes_done = resume->episodes_done;
    summary.best_real_return = resume->episodes_done > 0 ? best_return : 0.0;
    if (o.with_prior) {
      sim = std::move(*resumed.simulation);  // load requires it with a prior
      prior_mean = sim.prior;
    }
    first_episode = resume->episodes_done + 1;
  } else if (o.with_prior) {
    const std::uint64_t base = derive_seed(o.seed, {kSimulation});
    const auto simulator_model = model::make_prior_only_model(prior, prior_parameters);
    rollout::RolloutOptions deterministic;
    deterministic.sample = false;
    const rollout::ModelSystem simulator(*simulator_model, deterministic);
    PartialSimulation done_so_far;
    if (resume_simulation) done_so_far = std::move(*resumed.partial_simulation);
    LoopState ss = std::move(done_so_far.state);
    PhaseRecord phase;
    phase.name = "simulation";
    phase.episodes = std::move(done_so_far.records);
    Plan last;
    const auto t_sim = Clock::now();
    const double seconds_before = done_so_far.seconds;
    for (int e = done_so_far.episodes + 1; e <= o.sim_episodes; ++e) {
      if (stop()) {
        summary.interrupted = true;
        summary.seconds = seconds_since(t_run);
        return summary;
      }
      const auto ep = static_cast<std::uint64_t>(e);
      auto sim_status = [&](const char*, long evals, double best) {
        if (callbacks.on_status) callbacks.on_status(Status{e, "simulation", evals, best});
      };
      Plan plan = e <= o.random_rollouts ? random_plan(s, derive_seed(base, {ep, kRandomActions}))
                                         : learned_plan(s, ss, {}, base, ep, sim_status, stop);
      if (plan.interrupted) {
        summary.interrupted = true;
        summary.seconds = seconds_since(t_run);
        return summary;
      }
      Rng rng(derive_seed(base, {ep, kEpisode}));
      const rollout::Trajectory tr = rollout::run_episode(raw, simulator, *plan.policy, rng);
      for (auto& t : tr.transitions()) ss.data.push_back(std::move(t));
      Details d = plan.details;
      d.numbers["episode"] = e;
      d.numbers["return"] = tr.total_return();
      d.numbers["predicted_return"] = plan.prediction.predicted_return;
      d.numbers["solved"] = rollout::episode_solved(*task, tr) ? 1 : 0;
      d.numbers["model_learning_s"] = plan.model_seconds;
      d.numbers["policy_optimization_s"] = plan.policy_seconds;
      phase.episodes.push_back(std::move(d));
      if (callbacks.on_status) {
        Status done{e, "simulation episode", plan.evaluations, tr.total_return()};
        done.budget = o.sim_episodes;
        callbacks.on_status(done);
      }
      if (e < o.sim_episodes && callbacks.on_phase) {
        PhaseRecord so_far = phase;
        so_far.complete = false;
        so_far.summary.numbers["episodes_done"] = e;
        so_far.summary.numbers["episodes"] = o.sim_episodes;
        so_far.summary.numbers["seconds"] = seconds_before + seconds_since(t_sim);
        callbacks.on_phase(so_far);
      }
      if (e < o.sim_episodes && callbacks.on_state) {
        PilcoOwnState own;
        own.partial_simulation =
            PartialSimulation{.episodes = e,
                              .state = ss,
                              .records = phase.episodes,
                              .seconds = seconds_before + seconds_since(t_sim)};
        RunState rs;
        rs.extra = own.save();
        callbacks.on_state(rs);
      }
      last = std::move(plan);
    }
    // The GPs that chose the last policy become the prior mean; that policy, theta_sim, is run
    // first on the real system, and its prediction on them is episode 1's.
    sim.prior = mean_blocks(last.dynamics.model);
    sim.theta = last.theta;
    sim.prediction = last.prediction;
    prior_mean = sim.prior;
    st.theta = sim.theta;
    auto& n = phase.summary.numbers;
    n["episodes"] = o.sim_episodes;
    n["random_rollouts"] = o.random_rollouts;
    n["transitions"] = static_cast<double>(ss.data.size());
    n["prior_mean_centres"] = static_cast<double>(sim.prior.front().centres.rows());
    n["last_return"] = phase.episodes.back().numbers["return"];
    n["last_predicted_return"] = sim.prediction.predicted_return;
    n["seconds"] = seconds_before + seconds_since(t_sim);
    phase.summary.texts["system"] = "the simulator prior at its starting phi, deterministic";
    if (callbacks.on_phase) callbacks.on_phase(phase);
    save(0);
  }

  // 2. The real episodes.
  for (int episode = first_episode; episode <= o.episodes; ++episode) {
    if (stop()) {
      summary.interrupted = true;
      break;
    }
    const auto ep = static_cast<std::uint64_t>(episode);
    auto status = [&](const char* phase, long evals, double best) {
      if (callbacks.on_status) callbacks.on_status(Status{episode, phase, evals, best});
    };
    Plan plan;
    if (!o.with_prior && episode <= o.random_rollouts) {
      plan = random_plan(s, derive_seed(o.seed, {ep, kRandomActions}));
    } else if (o.with_prior && episode == 1) {
      // No real data yet: theta_sim, as planned on the simulation model.
      auto controller = std::make_unique<Controller>(
          tm, initial_policy(tm, s.x0, o.centres, derive_seed(o.seed, {kPolicyInit})));
      controller->set_params(sim.theta);
      plan.policy = std::move(controller);
      plan.theta = sim.theta;
      plan.prediction = sim.prediction;
      plan.details.texts["policy"] = "the simulation phase's last policy";
    } else {
      plan = learned_plan(s, st, prior_mean, o.seed, ep, status, stop);
      if (plan.interrupted) {
        summary.interrupted = true;
        break;  // the half-optimised policy is not run: nothing partial is recorded
      }
    }

    status("episode", 0, 0);
    EpisodeRecord rec;
    rec.episode = episode;
    Rng rng(derive_seed(o.seed, {ep, kEpisode}));
    rec.real = rollout::run_episode(raw, real, *plan.policy, rng);
    rec.real_return = rec.real.total_return();
    rec.solved = rollout::episode_solved(*task, rec.real);
    rec.interaction_time = episode * episode_time;
    rec.theta = plan.theta;
    rec.random_policy = plan.random;
    rec.selected = plan.random ? "random" : o.with_prior && episode == 1 ? "simulation" : "lbfgs";
    rec.predicted = plan.random ? rollout::Trajectory{} : plan.prediction.trajectory;
    rec.predicted_return = plan.prediction.predicted_return;
    if (o.with_prior) rec.phi = prior_parameters.values;
    rec.model.points = plan.dynamics.points;
    rec.model.log_likelihoods = plan.dynamics.log_likelihoods;
    rec.model.rprop_iterations = plan.dynamics.rprop_iterations;
    rec.model.seconds = plan.model_seconds;
    rec.model_seconds = plan.model_seconds;
    rec.policy_seconds = plan.policy_seconds;
    rec.evaluations = plan.evaluations;
    rec.details = std::move(plan.details);
    rec.details.numbers["cost_width"] = width;
    for (auto& t : rec.real.transitions()) st.data.push_back(std::move(t));
    if (rec.real_return > best_return) {
      best_return = rec.real_return;
      best_theta = rec.theta;
    }
    if (rec.solved && summary.first_solved_episode == 0) summary.first_solved_episode = episode;
    summary.episodes_done = episode;
    summary.best_real_return = best_return;
    if (callbacks.on_episode) callbacks.on_episode(rec);
    save(episode);
  }
  summary.seconds = seconds_since(t_run);
  return summary;
}

}  // namespace drops::algo
