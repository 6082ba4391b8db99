#pragma once
/// \file Interfaces of a learning problem: the Task (start state, observation, reward, success test),
/// the System that plays the robot, and the Trajectory of an episode. Below both the models (which
/// observe through a Task) and the rollouts (which run a System); drops::rollout declares the same
/// types under its own name (rollout::Task, ...), beside run_episode().

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drops/core/rng.hpp"
#include "drops/core/types.hpp"

namespace drops {

/// One episode: states x_0..x_H (H + 1 rows, dim E each), actions u_0..u_{H-1} (H rows, dim U),
/// rewards r_1..r_H (r_t computed on the state reached after step t, paper eq. 3).
struct Trajectory {
  MatrixXd states;   ///< (H + 1) x E
  MatrixXd actions;  ///< H x U
  VectorXd rewards;  ///< H
  /// The step t at which the system returned a non-finite state x_{t+1} (-1: none). The episode
  /// ended there: later rows repeat the last finite state, with action 0 and reward 0.
  int nonfinite_step = -1;
  /// Sum of the rewards.
  double total_return() const { return rewards.sum(); }
  /// The recorded transitions (x_t, u_t, x_{t+1} - x_t) of the steps whose next state is finite:
  /// t = 0..H-1, or t < nonfinite_step when the episode ended early.
  std::vector<Transition> transitions() const;
};

/// A reflection symmetry of a system's dynamics: the map R(x) = offset + sign .* x on states and
/// R_u(u) = action_sign .* u on actions such that the real one-step difference transforms as
/// f(R(x), R_u(u)) = sign .* f(x, u), f(x, u) = x_{t+1} - x_t (an involution: applying it twice
/// gives x back). A planar arm's is the mirror about the vertical (every angle and velocity and
/// the torque change sign; with angles measured from upright in [0, 2 pi), theta maps to
/// 2 pi - theta).
/// A model that knows it learns each recorded transition twice (ModelOptions::reflect_transitions;
/// data augmentation by a known symmetry). A damaged or asymmetric robot has none.
struct Reflection {
  VectorXd state_sign;    ///< dim E; every entry +1 or -1
  VectorXd state_offset;  ///< dim E, in the state's units
  VectorXd action_sign;   ///< dim U; every entry +1 or -1
  /// The reflected transition (x, u, dx) -> (R(x), R_u(u), sign .* dx). Sizes must match
  /// (InvalidArgument otherwise). Thread-safe.
  Transition apply(const Transition& t) const;
};

/// A goal state that a task declares: where a stabilising controller computed from the learned
/// model (control/balance.hpp, policy.balance.mode) takes over from the learned policy.
struct Goal {
  VectorXd state;   ///< x* (dim E), in the raw state's units
  VectorXd action;  ///< u* (dim U): the action that holds x* (e.g. zero torque upright)
  /// |u_i| <= action_limit[i] (dim U, > 0): the controller's actions are clipped to it (the
  /// task's action bounds, e.g. the policy's max torque).
  VectorXd action_limit;
  /// Indices of the entries of x that are angles in rad: their differences x_i - x*_i are
  /// wrapped into [-pi, pi).
  std::vector<int> angles;
  /// x - x* (dim E) with the angle entries wrapped into [-pi, pi). Throws InvalidArgument when
  /// x has not the size of state. Thread-safe.
  VectorXd error(const VectorXd& x) const;
  /// Throws InvalidArgument unless state has dim E, action and action_limit dim U, every limit
  /// is > 0, every entry finite and every angle index in [0, E).
  void check(int E, int U) const;
};

/// Everything about a problem except its dynamics: dimensions, start state, horizon, the observation
/// fed to the policy and the GP (e.g. angles as cos/sin), the reward and the success criterion.
/// Immutable and thread-safe.
class Task {
 public:
  virtual ~Task() = default;
  virtual std::string name() const = 0;
  virtual int state_dim() const = 0;        ///< E
  virtual int action_dim() const = 0;       ///< U
  virtual int observation_dim() const = 0;  ///< O
  virtual int horizon() const = 0;          ///< H steps per episode
  virtual double dt() const = 0;            ///< control period in s
  virtual VectorXd initial_state() const = 0;  ///< x_0 (dim E)
  /// Policy and model input computed from the raw state x (dim E); obs: dim O.
  virtual void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const = 0;
  /// Immediate reward of reaching state x (dim E).
  virtual double reward(const VectorXd& x) const = 0;
  /// observe() for every row of X (B x E): obs is resized to B x O. Called once per step of a
  /// batch of rollouts, so a task that is costly to enter (a Python task: one interpreter lock
  /// per call) overrides it. Default: observe() row by row. Thread-safe, as observe().
  virtual void observe_batch(const MatrixXd& X, MatrixXd& obs) const {
    obs.resize(X.rows(), observation_dim());
    VectorXd x(X.cols()), o(observation_dim());
    for (Eigen::Index b = 0; b < X.rows(); ++b) {
      x = X.row(b).transpose();
      observe(x, o);
      obs.row(b) = o.transpose();
    }
  }
  /// reward() for every row of X (B x E): r is resized to B. Default: reward() row by row.
  /// Thread-safe, as reward().
  virtual void reward_batch(const MatrixXd& X, VectorXd& r) const {
    r.resize(X.rows());
    VectorXd x(X.cols());
    for (Eigen::Index b = 0; b < X.rows(); ++b) {
      x = X.row(b).transpose();
      r[b] = reward(x);
    }
  }
  /// Reward for applying action u (dim U, the caller's duty: not checked) over one control
  /// period, added to the reward of the state it leads to: step t earns reward(x_{t+1}) +
  /// action_reward(u_t), in the reward's units (e.g. -w |u|^2 for a torque cost). The paper's
  /// reward is r(x) alone; this is the usual r(x, u) of reinforcement learning. A rollout stopped
  /// early (absorbing or nonfinite state) earns none for the steps it does not take. Default: 0,
  /// with has_action_reward() false. Throws nothing by default. Thread-safe.
  virtual double action_reward(const VectorXd& u) const {
    (void)u;
    return 0.0;
  }
  /// Whether action_reward() can be nonzero. Algorithms whose cost is a function of the state
  /// alone (PILCO's analytic expected cost) refuse a task that has one. Default: false.
  virtual bool has_action_reward() const { return false; }
  /// Whether an episode solved the task (task-specific criterion).
  virtual bool solved(const Trajectory& trajectory) const = 0;
  /// Whether x (dim E) is absorbing: a state the system does not leave and whose reward every
  /// later step of the episode repeats (e.g. a robot that fell over). Rollouts on a model stop at
  /// an absorbing state and add reward(x) for each remaining step, which saves the predictions of
  /// the rest of the episode; episodes on the real system run to the end. Default: none.
  virtual bool absorbing(const VectorXd& x) const {
    (void)x;
    return false;
  }
  /// The system's reflection symmetry, if the task declares one (see Reflection; the
  /// declaration is the task's claim about the real system, which no model checks). Default:
  /// none. Thread-safe.
  virtual std::optional<Reflection> reflection() const { return std::nullopt; }
  /// The goal state the task declares for a catch-and-balance controller (see Goal). Default:
  /// none. Thread-safe.
  virtual std::optional<Goal> goal() const { return std::nullopt; }
};

class System;

/// One episode in progress on a System. A physical robot has state that the recorded state x does
/// not carry (true versus measured state, contacts, actuator internals), so run_episode() advances
/// an episode through a session that owns it, rather than through the stateless System::step.
/// Not thread-safe: one session per episode (System::begin_episode may be called concurrently).
class EpisodeSession {
 public:
  virtual ~EpisodeSession() = default;
  /// Applies u (dim U) over one control period from the session's current state and returns the
  /// next state as recorded (dim E; e.g. a noisy measurement). May draw from rng.
  virtual VectorXd step(const VectorXd& u, Rng& rng) = 0;
};

/// The system a policy is run on: the "real" robot, or a learned model wrapped as a system.
/// step() may be stochastic and draws from rng. Implementations are thread-safe for const calls.
class System {
 public:
  virtual ~System() = default;
  /// Next state from state x (dim E) under action u (dim U), held over one control period.
  virtual VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const = 0;
  /// Starts an episode at x0 (dim E). The default session is stateless: each of its steps returns
  /// x <- step(x, u, rng) from the last returned state, so model systems need not override this.
  /// Systems with hidden state (a robot) override it. Thread-safe for const systems.
  virtual std::unique_ptr<EpisodeSession> begin_episode(const VectorXd& x0) const;
};

namespace detail {
/// The default session of System::begin_episode (Markovian in the recorded state).
class StatelessSession final : public EpisodeSession {
 public:
  StatelessSession(const System& system, const VectorXd& x0) : system_(system), x_(x0) {}
  VectorXd step(const VectorXd& u, Rng& rng) override {
    x_ = system_.step(x_, u, rng);
    return x_;
  }

 private:
  const System& system_;
  VectorXd x_;
};
}  // namespace detail

inline std::unique_ptr<EpisodeSession> System::begin_episode(const VectorXd& x0) const {
  return std::make_unique<detail::StatelessSession>(*this, x0);
}

/// The problem's types as the rollouts, the algorithms and the tasks name them (the same types).
namespace rollout {
using drops::EpisodeSession;
using drops::Goal;
using drops::Reflection;
using drops::System;
using drops::Task;
using drops::Trajectory;
}  // namespace rollout

}  // namespace drops
