#pragma once
/// \file The hexapod simulator prior as a model::MeanFunction with one discrete parameter, the
/// removed leg (paper §V-B: "7 discrete different parameterizations"; settings.md §6), and the pool
/// of per-thread simulator copies behind it. No DART in this header.
///
/// What the action u is. In drops, u is what the policy outputs at each control step and what the
/// GP sees next to x. The hexapod's policy is the open-loop gait controller (controller.hpp): its
/// 36 parameters theta are constant over an episode, so they are not an action; what it sends to
/// the robot every 0.1 s is the 18 target joint angles. So u = q_target (dim 18, rad, order
/// 3 k + j), and M(x, u) = simulate 0.1 s from x towards the targets u. This keeps the model
/// Markovian in (x, u) without knowing the time or theta, and lets the same model serve any
/// policy that outputs joint targets. (The time/phase needed by an open-loop policy is the
/// policy's business, e.g. an observation carrying the step index; that is the next part of
/// issue 4.)

#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "drops/model/mean_function.hpp"
#include "drops/hexapod/simulator.hpp"

namespace drops::hexapod {

/// A bounded pool of PriorSimulator copies of one spec, one per concurrent user. acquire() hands
/// out a free simulator, builds a new one while fewer than `capacity` exist, and otherwise blocks
/// on a condition variable until a lease is returned (never busy-waits). Thread-safe. The pool
/// must outlive its leases.
class SimulatorPool {
 public:
  /// RAII lease of one simulator; returns it to the pool on destruction. Movable, not copyable.
  class Lease {
   public:
    Lease(Lease&& other) noexcept;
    Lease& operator=(Lease&& other) noexcept;
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;
    ~Lease();
    PriorSimulator& operator*() const { return *sim_; }
    PriorSimulator* operator->() const { return sim_.get(); }

   private:
    friend class SimulatorPool;
    Lease(SimulatorPool* pool, std::unique_ptr<PriorSimulator> sim);
    void release();
    SimulatorPool* pool_ = nullptr;
    std::unique_ptr<PriorSimulator> sim_;
  };

  /// capacity: maximum number of simulators (>= 1; 0 means std::thread::hardware_concurrency(),
  /// at least 1). Simulators are built lazily. Throws InvalidArgument when spec or options are
  /// invalid or capacity < 0.
  SimulatorPool(const HexapodSpec& spec, const PriorOptions& options, int capacity = 0);
  /// A leased simulator, in the state left by its previous user (callers set_state or reset).
  /// Blocks while `capacity` simulators are leased. Rethrows a construction failure.
  Lease acquire();
  int capacity() const { return capacity_; }
  /// Number of simulators built so far (<= capacity).
  int created() const;
  const HexapodSpec& spec() const { return spec_; }

 private:
  void give_back(std::unique_ptr<PriorSimulator> sim);
  HexapodSpec spec_;
  PriorOptions options_;
  int capacity_;
  mutable std::mutex mutex_;
  std::condition_variable available_;
  std::vector<std::unique_ptr<PriorSimulator>> free_;
  int created_ = 0;
};

/// What HexapodPrior::evaluate does with a state x that fails the state guard (issue 4, item 6).
enum class StateGuardPolicy {
  /// Return an all-NaN dx: the rollout code counts it (RolloutStats::nonfinite_steps) and stops
  /// that rollout (its remaining rewards are 0).
  kStop,
  /// Repair x into the plausible box (see StateGuardOptions) and simulate from the repaired state;
  /// dx is taken relative to the original x, so x + dx is the successor of the repaired state. A
  /// non-finite x cannot be repaired and is stopped as under kStop.
  kClamp,
};

/// The state guard of HexapodPrior: x enters the simulator only if check_state(x, spec, bounds)
/// holds and the body height x[38] is in [min_height, max_height].
struct StateGuardOptions {
  StateGuardPolicy policy = StateGuardPolicy::kStop;
  StateBounds bounds;       ///< see simulator.hpp
  double min_height = 0.0;  ///< m; the body centre below the ground plane is implausible
  double max_height = 1.0;  ///< m, > min_height; the robot cannot jump higher than this
  /// True when heights are finite and ordered and bounds are positive; else false with *why.
  bool IsValid(std::string* why = nullptr) const;
};

/// Counts of the state guard since construction (or reset_guard_counts).
struct StateGuardCounts {
  long evaluations = 0;  ///< calls of evaluate()
  long stopped = 0;      ///< states answered with NaN (kStop, or non-finite under kClamp)
  long clamped = 0;      ///< states repaired under kClamp
};

/// The prior simulators' default settings: settings.md §6 with the dedicated rigid-body step
/// (PriorEngine::kRigid: DART's physics to round-off, the prior alone about 7 times faster;
/// docs/benchmarks.md, "A dedicated rigid-body step"). Thread-safe.
inline PriorOptions prior_simulator_defaults() {
  PriorOptions o;
  o.engine = PriorEngine::kRigid;
  return o;
}

/// Options of HexapodPrior.
struct HexapodPriorOptions {
  /// Settings of every prior simulator (settings.md §6; the rigid-body step by default).
  PriorOptions simulator = prior_simulator_defaults();
  int pool_capacity = 0;    ///< simulators per prior (per removed-leg value); 0: hardware threads
  StateGuardOptions guard;  ///< validation of x before it enters the simulator
  /// True when simulator options are valid and pool_capacity >= 0; else false with *why.
  bool IsValid(std::string* why = nullptr) const;
};

/// M(x, u; phi) = x' - x where x' is the prior simulator's state after set_state(x) and one step
/// of 0.1 s towards the targets u. x: dim 48 (simulator.hpp), u: dim 18 target joint angles (rad),
/// phi = [removed_leg] with removed_leg in {-1 (intact), 0, ..., 5}. The yaw entry of dx is the
/// unwrapped change (small, no 2 pi jumps). Every x first passes the state guard
/// (options.guard): an implausible x is stopped (all-NaN dx, which callers count, MeanFunction
/// contract) or repaired, by the configured StateGuardPolicy, and counted (guard_counts()).
/// evaluate() is thread-safe: each call leases a simulator of the wanted prior from a pool (one
/// pool per value of phi, built on first use), so no DART world is shared between threads, and
/// results do not depend on which copy or thread served the call.
class HexapodPrior final : public model::MeanFunction {
 public:
  /// Throws InvalidArgument when options are invalid.
  explicit HexapodPrior(const HexapodPriorOptions& options = {});
  int state_dim() const override { return kStateDim; }
  int action_dim() const override { return kNumJoints; }
  /// {"removed_leg"}.
  std::vector<std::string> parameter_names() const override;
  /// Throws InvalidArgument unless phi has dim 1 and phi[0] is exactly one of -1, 0, ..., 5.
  void check_phi(const VectorXd& phi) const override;
  /// dx = M(x, u; phi); see the class comment. Throws InvalidArgument on wrong sizes, a non-finite
  /// u or an invalid phi.
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override;
  /// The state guard's counters (atomic; readable while other threads evaluate).
  StateGuardCounts guard_counts() const;
  /// Sets the state guard's counters to zero.
  void reset_guard_counts();
  /// Applies the guard to x (dim 48) for the intact robot's limits: returns true when x passes;
  /// otherwise false, with *repaired (if not null) set to the kClamp repair of x (only meaningful
  /// when x is finite) and the reason in *why (if not null). Does not count. Thread-safe.
  bool guard_state(const VectorXd& x, VectorXd* repaired = nullptr,
                   std::string* why = nullptr) const;
  /// Independent copy with the same options and its own (empty) pools and zero counters.
  std::unique_ptr<model::MeanFunction> clone() const override;
  /// The GP-MI search space: removed_leg, discrete, choices {-1, 0, ..., 5}, starting at -1.
  static model::PriorParameters prior_parameters();
  /// The pool of prior `removed_leg` (-1..5), built on first use. Thread-safe.
  SimulatorPool& pool(int removed_leg) const;
  const HexapodPriorOptions& options() const { return options_; }

 private:
  HexapodPriorOptions options_;
  mutable std::mutex pools_mutex_;
  mutable std::unique_ptr<SimulatorPool> pools_[kNumLegs + 1];
  mutable std::atomic<long> evaluations_{0};
  mutable std::atomic<long> stopped_{0};
  mutable std::atomic<long> clamped_{0};
};

}  // namespace drops::hexapod
