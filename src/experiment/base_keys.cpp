// The base keys (the experiment's and Algorithm 1's), each declared once beside the field it sets:
// the schema (base_keys()), docs/configuration.md and the options all derive from this table.
#include "drops/experiment/experiment.hpp"
#include "drops/experiment/keys.hpp"

namespace drops::experiment {
namespace {

/// The CMA-ES keys of the policy search (and of the direct search): optimizer.max_evaluations to
/// optimizer.uncertainty_handling.
KeyTable<opt::CmaesOptions> cmaes_key_table() {
  KeyTable<opt::CmaesOptions> t;
  t.add("optimizer.max_evaluations", [](auto& c) -> auto& { return c.max_evaluations; })
      .range(10, 100000000)
      .help("CMA-ES policy evaluations per optimization, all restarts; for algorithm=direct, the "
            "number of real episodes");
  t.add("optimizer.run_evaluations", [](auto& c) -> auto& { return c.max_run_evaluations; })
      .derived([](const auto& c) { return c.max_evaluations / 4; })
      .range(0, 100000000)
      .help("CMA-ES evaluations of one run before it restarts (empty = a quarter of "
            "optimizer.max_evaluations; 0 = no per-run budget): with a noisy objective the "
            "tolerances rarely end a run, so this is what makes restarts happen");
  t.add("optimizer.restarts", [](auto& c) -> auto& { return c.max_restarts; })
      .range(0, 100)
      .help("large-population (IPOP) restarts after the first run; BIPOP's small runs come in "
            "between");
  t.add("optimizer.restart_from", [](auto& c) -> auto& { return c.restart_start; })
      .values({{"mixed", opt::CmaesRestartStart::kMixed},
               {"random", opt::CmaesRestartStart::kRandom},
               {"start", opt::CmaesRestartStart::kStart}})
      .help("where restarts begin: mixed = BIPOP's small (local) runs from the start policy and "
            "its large runs from random points; random = every restart from a random point "
            "(Hansen 2009); start = every restart from the start policy");
  t.add("optimizer.tol_fun", [](auto& c) -> auto& { return c.tol_fun; })
      .also([](auto& c) -> auto& { return c.tol_hist_fun; })
      .range(0, 1e6)
      .unit("return")
      .help("a run stops when its best returns of the last 10 + 30n/lambda generations "
            "(TolHistFun), or those and all of the last generation's (TolFun), lie within this "
            "range");
  t.add("optimizer.stagnation", [](auto& c) -> auto& { return c.stagnation; })
      .help("a run stops when its best and median returns stopped improving (Hansen 2009's "
            "Stagnation)");
  t.add("optimizer.lambda", [](auto& c) -> auto& { return c.lambda; })
      .range(0, 100000)
      .help("population size of the first run (0 = 4 + floor(3 ln n), 17 for 81 parameters)");
  t.add("optimizer.sigma0", [](auto& c) -> auto& { return c.sigma0; })
      .range(0, 1000)
      .help("initial step size (0 = policy.bound)");
  t.add("optimizer.elitism", [](auto& c) -> auto& { return c.elitism; })
      .help("re-inject the best-ever candidate");
  t.add("optimizer.active", [](auto& c) -> auto& { return c.active; })
      .help("active covariance update (aCMA)");
  t.add("optimizer.bipop", [](auto& c) -> auto& { return c.bipop; })
      .help("BIPOP restarts (false = IPOP)");
  t.add("optimizer.uncertainty_handling", [](auto& c) -> auto& { return c.uncertainty_handling; })
      .help("Hansen et al. 2009 uncertainty handling for the noisy rollout objective");
  return t;
}

KeyTable<BaseOptions> make_base_key_table() {
  KeyTable<BaseOptions> t;
  const double big = 1e9;
  t.add("task", [](auto& o) -> auto& { return o.task; })
      .help("the learning problem, one of the registered tasks (empty = the first registered: the "
            "first task of the drops command line); `drops config --markdown` lists each task's "
            "keys");
  // Allowed values: the registry's algorithms (registered_base_keys).
  t.add("algorithm", [](auto& o) -> auto& { return o.algorithm; })
      .help("the learning algorithm, one of the registered algorithms (each described in its own "
            "section; empty = the first registered: black_drops, Algorithm 1 with the model of "
            "model.type, for the drops command line)");
  t.add("seed", [](auto& o) -> auto& { return o.black_drops.seed; })
      .range(0, 4294967295.0)
      .help("the run's only seed: every random stream derives from it (same numbers with any "
            "thread count)");
  t.add("episodes", [](auto& o) -> auto& { return o.black_drops.episodes; })
      .range(1, 1000)
      .help("real episodes in total, including the first one");
  t.add("threads", [](auto& o) -> auto& { return o.threads; })
      .range(0, 1024)
      .help("worker threads (0 = all hardware threads)");
  t.add("output", [](auto& o) -> auto& { return o.output; })
      .help("parent directory of run directories");
  t.add("name", [](auto& o) -> auto& { return o.name; })
      .help("run directory name, one directory: 1 to 200 of A-Z a-z 0-9 _ . -, the first a "
            "letter, a digit or _ (a path goes in output; empty = "
            "<task>-<variant>-<prior>-seed<seed>-<date>-<time>)");
  // Allowed values and help: the registry's model variants (registered_base_keys).
  t.add("model.type", [](auto& o) -> auto& { return o.model_type; })
      .type("enum")
      .help("the model variant of Black-DROPS, one of the registered model variants");
  const auto model = [](auto& o) -> auto& { return o.black_drops.model; };
  t.add("model.variance_points", [=](auto& o) -> auto& { return model(o).variance_points; })
      .range(0, 1000000)
      .help("predictive variances of the output GPs from a subset of at most this many "
            "transitions once there are more, chosen greedily where the subset so far explains "
            "the data least (subset of data: never below the exact variance, O(m^2) instead of "
            "O(N^2) per prediction; means use every transition); 0 = every transition");
  t.add("model.inducing_points", [=](auto& o) -> auto& { return model(o).inducing_points; })
      .range(0, 1000000)
      .help("gp, gp_prior, gp_mi: once the output GPs have more than this many points, sparse "
            "GPs with at most this many inducing inputs (the variational bound of Titsias 2009, "
            "inputs chosen among the transitions by greedy conditional variance): learning "
            "O(N m^2) instead of O(N^3), predictions O(m^2) (variance_points is then unused); "
            "GP-MI's phi search too when its gp_mi.max_points exceed it; not with "
            "gp_mi.rollout_phi: posterior; 0 = exact GPs whatever the number of points");
  t.add("model.reflect_transitions",
        [=](auto& o) -> auto& { return model(o).reflect_transitions; })
      .help("gp, gp_prior, gp_mi: also learn every recorded transition reflected by the task's "
            "symmetry (data augmentation; a task without one rejects true): the model knows the "
            "mirror image of every state the robot visited, at up to 8 times the cost of "
            "learning");
  t.add("model.rprop.iterations", [=](auto& o) -> auto& { return model(o).rprop.max_iterations; })
      .range(1, 100000)
      .help("Rprop iterations of the final kernel fit per output GP");
  t.add("model.rprop.tolerance", [=](auto& o) -> auto& { return model(o).rprop.tolerance; })
      .range(0, big)
      .unit("nats")
      .help("stop a kernel fit early when the log-likelihood gains less than this over "
            "`patience` iterations (0 = always run every iteration)");
  t.add("model.rprop.patience", [=](auto& o) -> auto& { return model(o).rprop.patience; })
      .range(1, 100000)
      .help("window of the tolerance test");
  t.add("model.rprop.penalty", [=](auto& o) -> auto& { return model(o).rprop.penalty; })
      .values({{"on", true}, {"off", false}})
      .help("PILCO's soft walls on extreme length scales and signal-to-noise ratios in the "
            "kernel fits (a task whose GPs have few points in many input dimensions needs them, "
            "or they interpolate noise; the reference used them for its no-prior variant: "
            "model.type gp with penalty on)");
  t.add("model.rprop.max_length_scale_ratio",
        [=](auto& o) -> auto& { return model(o).rprop.max_length_scale_ratio; })
      .range(1.001, 1e6)
      .help("soft walls: length scale l_d within [s_d / ratio, ratio s_d], s_d the spread of "
            "input d (PILCO: 100)");
  t.add("model.rprop.max_snr", [=](auto& o) -> auto& { return model(o).rprop.max_snr; })
      .range(1.001, 1e9)
      .help("soft walls: signal-to-noise ratio sigma_f / sigma_n at most this (PILCO: 500)");
  t.add("model.gp_mi.search", [=](auto& o) -> auto& { return model(o).gp_mi.search; })
      .values({{"alternating", model::GpMiSearch::kAlternating},
               {"nested", model::GpMiSearch::kNested}})
      .help("nested: paper's Algorithm 2 (Rprop inside every Subplex evaluation); alternating: "
            "block-coordinate ascent on the same score (much faster)");
  t.add("model.gp_mi.score", [=](auto& o) -> auto& { return model(o).gp_mi.score; })
      .values({{"sum_likelihoods", model::GpMiScore::kSumOfLikelihoods},
               {"sum_log_likelihoods", model::GpMiScore::kSumOfLogLikelihoods}})
      .help("GP-MI's score: log sum_i exp(loglik_i), the paper's sum of the likelihoods, or "
            "sum_i loglik_i, the joint likelihood of the output GPs (every output counts)");
  t.add("model.gp_mi.candidate_start",
        [=](auto& o) -> auto& { return model(o).gp_mi.candidate_start; })
      .values({{"best_so_far", model::GpMiCandidateStart::kBestSoFar},
               {"initial", model::GpMiCandidateStart::kInitial}})
      .help("nested search (and a discrete phi): each candidate's kernel fit starts from the "
            "best candidate's kernels so far, or from a new GP's (equal terms for every "
            "candidate; docs/architecture.md)");
  t.add("model.gp_mi.rollout_phi", [=](auto& o) -> auto& { return model(o).gp_mi.rollout_phi; })
      .values({{"point", model::RolloutPhi::kPoint},
               {"posterior", model::RolloutPhi::kPosterior}})
      .help("the phi of the rollouts on the model: GP-MI's point estimate, or per rollout index "
            "one draw from phi's posterior (continuous tunable phi; the GP residuals conditioned "
            "on the data at that phi); summary.json counts the draws (phi_samples)");
  t.add("model.gp_mi.max_evaluations",
        [=](auto& o) -> auto& { return model(o).gp_mi.max_evaluations; })
      .range(1, 1000000)
      .help("Subplex evaluations per phi search");
  t.add("model.gp_mi.tolerance", [=](auto& o) -> auto& { return model(o).gp_mi.xtol_rel; })
      .also([=](auto& o) -> auto& { return model(o).gp_mi.ftol_rel; })
      .range(0, 1)
      .help("Subplex relative tolerance on phi and on the score");
  t.add("model.gp_mi.rounds", [=](auto& o) -> auto& { return model(o).gp_mi.rounds; })
      .range(1, 100)
      .help("alternating search: maximum rounds");
  t.add("model.gp_mi.inner_rprop_iterations",
        [=](auto& o) -> auto& { return model(o).gp_mi.inner_rprop_iterations; })
      .range(1, 100000)
      .help("Rprop iterations of kernel refits inside the phi search");
  t.add("model.gp_mi.screen_iterations",
        [=](auto& o) -> auto& { return model(o).gp_mi.screen_iterations; })
      .range(0, 99999)
      .help("discrete phi (nested search): Rprop iterations of a first, short kernel fit of "
            "every candidate; only those within model.gp_mi.screen_margin of the best get the "
            "full fit (0, or not less than model.gp_mi.inner_rprop_iterations: no screen)");
  t.add("model.gp_mi.screen_margin",
        [=](auto& o) -> auto& { return model(o).gp_mi.screen_margin; })
      .range(0, 1e9)
      .help("the screen's margin in units of GP-MI's score (nats): a candidate whose short fit "
            "scores more than this below the best one's is left out");
  t.add("model.gp_mi.max_points", [=](auto& o) -> auto& { return model(o).gp_mi.max_points; })
      .range(0, 1000000)
      .help("transitions used inside the phi search, evenly spaced (0 = all); the final fit uses "
            "all");
  t.add("model.mi.max_evaluations", [=](auto& o) -> auto& { return model(o).mi.max_evaluations; })
      .range(1, 1000000)
      .help("Subplex evaluations of MI");
  t.add("model.mi.tolerance", [=](auto& o) -> auto& { return model(o).mi.xtol_rel; })
      .also([=](auto& o) -> auto& { return model(o).mi.ftol_rel; })
      .range(0, 1)
      .help("Subplex relative tolerance of MI");
  const auto search = [](auto& o) -> auto& { return o.black_drops.search; };
  t.add("policy.bound", [=](auto& o) -> auto& { return search(o).theta_bound; })
      .range(1e-3, 1000)
      .help("policy parameters are searched in [-bound, bound]");
  t.include(cmaes_key_table(), [=](auto& o) -> auto& { return search(o).cmaes; });
  t.add("optimizer.keep_start", [=](auto& o) -> auto& { return search(o).keep_start_point; })
      .help("the best policy so far is the start and a candidate: each search starts from the "
            "policy of the best real episode, evaluates it on the current model like any "
            "candidate and runs it again unless a candidate beats it (as the reference's CMA-ES "
            "wrapper); false = the start only centres the first CMA-ES run");
  t.add("optimizer.trust_region",
        [](auto& o) -> auto& { return o.black_drops.trust_region.enabled; })
      .help("from episode 2 on, search only within r * policy.bound of the best real policy, "
            "with CMA-ES's sigma0 scaled by r (r = 1: the whole box); r starts at 1, doubles "
            "after a new policy beat the best real return and halves after one that did not "
            "(TuRBO's rule; docs/architecture.md, \"The policy search and what drops does "
            "differently\")");
  t.add("optimizer.trust_region_min",
        [](auto& o) -> auto& { return o.black_drops.trust_region.min_radius; })
      .range(1e-6, 1)
      .help("optimizer.trust_region: the smallest radius r, a fraction of policy.bound");
  t.add("optimizer.selection", [=](auto& o) -> auto& { return search(o).selection; })
      .values({{"reevaluate", algo::PolicySelection::kReevaluate},
               {"best_seen", algo::PolicySelection::kBestSeen}})
      .help("which evaluated policy is run: reevaluate = the best value (rollouts.statistic) "
            "when the start, the best evaluated policies and each run's final mean are "
            "re-evaluated with many rollouts (robust to lucky rollouts); best_seen = the best "
            "single evaluation (the paper's reference)");
  t.add("optimizer.reevaluation_rollouts",
        [=](auto& o) -> auto& { return search(o).reevaluation.rollouts; })
      .range(1, 100000)
      .help("selection reevaluate: rollouts per re-evaluated policy, on common random numbers");
  t.add("optimizer.reevaluation_candidates",
        [=](auto& o) -> auto& { return search(o).reevaluation.candidates; })
      .range(1, 10000)
      .help("selection reevaluate: best distinct evaluated policies re-evaluated (besides the "
            "start and the runs' final means)");
  t.add("optimizer.prior_optimizations",
        [](auto& o) -> auto& { return o.black_drops.prior_optimizations; })
      .range(1, 100)
      .help("with a prior: successive optimizations on the prior alone for episode 1");
  t.add("rollouts.count", [=](auto& o) -> auto& { return search(o).rollouts.rollouts; })
      .range(1, 10000)
      .help("Monte-Carlo rollouts per policy evaluation, combined by rollouts.statistic");
  t.add("rollouts.statistic", [=](auto& o) -> auto& { return search(o).rollouts.statistic; })
      .values({{"mean", rollout::ReturnStatistic::kMean},
               {"median", rollout::ReturnStatistic::kMedian}})
      .help("how a policy's rollout returns combine into its value on the model, in the search "
            "(rollouts.count > 1) and in the re-evaluation of optimizer.selection reevaluate: "
            "mean = the expected return (the paper's); median = robust to a minority of "
            "rollouts, e.g. rare predicted falls (docs/architecture.md, \"The policy search and "
            "what drops does differently\"). The reported predicted return is always the mean");
  t.add("rollouts.clip", [=](auto& o) -> auto& { return search(o).rollouts.clip; })
      .range(0, 100)
      .unit("sigma")
      .help("clip each predictive draw to mean +- clip * sigma (0 = no clipping)");
  t.add("rollouts.batch", [=](auto& o) -> auto& { return search(o).rollouts.batch; })
      .range(1, 1024)
      .help("rollouts advanced together through batched GP predictions");
  t.add("rollouts.predicted", [](auto& o) -> auto& { return o.black_drops.predicted_rollouts; })
      .range(1, 100000)
      .help("rollouts used to report each episode's predicted return");
  const auto balance = [](auto& o) -> auto& { return o.black_drops.balance; };
  t.add("policy.balance.mode", [=](auto& o) -> auto& { return balance(o).mode; })
      .values({{"off", control::BalanceMode::kOff}, {"lqr", control::BalanceMode::kLqr}})
      .help("Black-DROPS: catch and balance near the task's goal state (docs/balance.md): lqr = "
            "an LQR on the learned model's mean linearised at the goal, recomputed after each "
            "learning step, takes over from the learned policy inside the region of "
            "policy.balance.enter, in the model's rollouts as on the real system; off = the "
            "learned policy alone. lqr needs a task that declares a goal state (Task::goal) and "
            "algorithm black_drops (the others refuse it)");
  t.add("policy.balance.q", [=](auto& o) -> auto& { return balance(o).q; })
      .range(1e-9, 1e9)
      .help("policy.balance.mode lqr: the LQR's state weight Q = q I (raw state's units)");
  t.add("policy.balance.r", [=](auto& o) -> auto& { return balance(o).r; })
      .range(1e-9, 1e9)
      .help("policy.balance.mode lqr: the LQR's action weight R = r I (action's units)");
  t.add("policy.balance.enter", [=](auto& o) -> auto& { return balance(o).enter; })
      .range(1e-9, 1e12)
      .help("policy.balance.mode lqr: the LQR takes over when its cost-to-go e'Pe (e = x - x*, "
            "angles wrapped) is at most this");
  t.add("policy.balance.exit", [=](auto& o) -> auto& { return balance(o).exit; })
      .range(1e-9, 1e12)
      .help("policy.balance.mode lqr: ... and hands back to the learned policy when e'Pe "
            "exceeds this (hysteresis; >= policy.balance.enter)");
  t.add("policy.balance.step", [=](auto& o) -> auto& { return balance(o).step; })
      .range(1e-12, 1)
      .help("policy.balance.mode lqr: central finite-difference step of the model's "
            "linearisation at the goal (state's and action's units)");
  return t;
}

}  // namespace

const KeyTable<BaseOptions>& base_key_table() {
  static const KeyTable<BaseOptions> t = make_base_key_table();
  return t;
}

const KeyTable<policy::NeuralNetPolicyOptions>& neural_net_policy_key_table() {
  static const KeyTable<policy::NeuralNetPolicyOptions> t = [] {
    KeyTable<policy::NeuralNetPolicyOptions> k;
    k.add("policy.hidden_units", [](auto& o) -> auto& { return o.hidden_units; })
        .range(1, 1000)
        .help("tanh units of the network policy");
    return k;
  }();
  return t;
}

BaseOptions base_options(const Settings& settings) { return base_key_table().read(settings); }

}  // namespace drops::experiment
