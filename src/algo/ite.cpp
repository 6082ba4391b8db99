// IT&E (Cully et al., Nature 2015) as a drops algorithm: Ite::run reads top-down (the archive, then
// the adaptation); the pieces it uses follow it.
#include "drops/algo/ite.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "drops/core/errors.hpp"
#include "drops/core/rng.hpp"
#include "drops/rollout/rollout.hpp"

namespace drops::algo {

// IteTrials' entries of RunState::extra (checkpoint.json "extra").
constexpr const char* kTrialCells = "ite.trial_cells";
constexpr const char* kTrialReturns = "ite.trial_returns";

const ArchiveState* archive_state(const RunState& state) {
  if (!state.side_state.has_value()) return nullptr;
  const auto* a = std::any_cast<ArchiveState>(&state.side_state);
  if (!a)
    throw Error(std::string("the state's side state is a ") + state.side_state.type().name() +
                ", not IT&E's archive");
  return a;
}

StateVectors IteTrials::save() const {
  VectorXd c(static_cast<Eigen::Index>(cells.size()));
  for (std::size_t i = 0; i < cells.size(); ++i)
    c[static_cast<Eigen::Index>(i)] = static_cast<double>(cells[i]);
  return {{kTrialCells, c},
          {kTrialReturns,
           Eigen::Map<const VectorXd>(returns.data(), static_cast<Eigen::Index>(returns.size()))}};
}

IteTrials IteTrials::load(const StateVectors& extra) {
  const auto c = extra.find(kTrialCells), r = extra.find(kTrialReturns);
  if (c == extra.end() || r == extra.end() || c->second.size() != r->second.size())
    throw InvalidArgument(std::string("resume: the state holds no IT&E trials (extra '") +
                          kTrialCells + "' and '" + kTrialReturns + "' of equal length)");
  IteTrials t;
  for (Eigen::Index i = 0; i < c->second.size(); ++i) {
    const double x = c->second[i];
    if (!(x >= 0) || x != std::floor(x))
      throw InvalidArgument(std::string("resume: the state's '") + kTrialCells + "' holds " +
                            std::to_string(x) + ", not a cell index");
    t.cells.push_back(static_cast<std::int64_t>(x));
    t.returns.push_back(r->second[i]);
  }
  return t;
}
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

/// The archive and how it was obtained (run() step 1).
struct ArchiveOutcome {
  std::shared_ptr<const ite::Archive> archive;  ///< null when the generation was interrupted
  std::string source;                           ///< "resumed", "given" or "map_elites"
  ite::MapElitesCursor cursor;                  ///< where the run that built it ended
  ite::MapElitesSummary map_elites;             ///< this session's generation (if any)
  double seconds = 0;                           ///< wall-clock time of this session's generation
};

ArchiveOutcome obtain_archive(const Problem& problem, const IteOptions& options,
                              const Callbacks& callbacks, const RunState* resume);
std::shared_ptr<const ite::Archive> scaled_archive(const ite::Archive& archive, double scale);
void check_archive(const ite::Archive& archive, const Problem& problem, int descriptor_dim,
                   const char* what);

}  // namespace

bool IteOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (episodes < 1) return fail("episodes: expected >= 1, got " + std::to_string(episodes));
  if (!(theta_bound > 0) || !std::isfinite(theta_bound))
    return fail("theta_bound: expected > 0, got " + std::to_string(theta_bound));
  if (!(performance_scale > 0) || !std::isfinite(performance_scale))
    return fail("performance_scale: expected > 0, got " + std::to_string(performance_scale));
  if (std::isnan(observation_floor)) return fail("observation_floor: expected a number, got NaN");
  if (!(checkpoint_seconds >= 0))
    return fail("checkpoint_seconds: expected >= 0, got " + std::to_string(checkpoint_seconds));
  for (int b : bins)
    if (b < 1) return fail("bins: expected >= 1 per dimension, got " + std::to_string(b));
  if (!bins.empty() && behaviour.available() && bins.size() != behaviour.bins.size())
    return fail("bins: expected " + std::to_string(behaviour.bins.size()) +
                " dimensions (the behaviour descriptor's), got " + std::to_string(bins.size()));
  std::string w;
  if (!map_elites.IsValid(&w)) return fail("map_elites: " + w);
  ite::MboaOptions m = mboa;
  m.max_trials = episodes;
  if (!m.IsValid(&w)) return fail("mboa: " + w);
  return true;
}

Ite::Ite(const IteOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument("IT&E options: " + why);
}

RunSummary Ite::run(const Problem& problem, const Callbacks& callbacks,
                    const RunState* resume) const {
  const auto t_run = Clock::now();
  problem.check();
  options_.behaviour.check();
  const rollout::Task& task = *problem.task;
  const double scale = options_.performance_scale;
  // What M-BOA observes of a real return (IteOptions::observation_floor).
  const auto observation = [&](double real_return) {
    return std::max(options_.observation_floor, scale * real_return);
  };
  RunSummary summary;
  auto stop = [&] { return callbacks.should_stop && callbacks.should_stop(); };

  // 1. The archive: resumed, given, or built by MAP-Elites on the prior at the starting phi.
  const ArchiveOutcome got = obtain_archive(problem, options_, callbacks, resume);
  if (got.source == "map_elites") {
    const ite::MapElitesSummary& m = got.map_elites;
    summary.details.numbers = {{"archive_evaluations", static_cast<double>(m.cursor.evaluations)},
                       {"archive_dead", static_cast<double>(m.dead)},
                       {"archive_invalid", static_cast<double>(m.invalid)},
                       {"archive_out_of_range", static_cast<double>(m.out_of_range)},
                       {"archive_seconds", got.seconds}};
  }
  if (!got.archive) {  // interrupted during the generation: its state went to on_state
    summary.interrupted = true;
    summary.seconds = seconds_since(t_run);
    return summary;
  }
  const ite::Archive& archive = *got.archive;
  summary.details.numbers["archive_cells"] = static_cast<double>(archive.size());
  summary.details.numbers["archive_coverage"] = archive.coverage();
  summary.details.numbers["archive_best_return"] = archive.best().fitness;

  // 2. The adaptation: M-BOA over the archive's cells on performance = scale * return.
  ite::MboaOptions mo = options_.mboa;
  mo.max_trials = options_.episodes;
  ite::Mboa mboa(*scaled_archive(archive, scale), mo);
  RunState state;
  state.side_state = ArchiveState{got.archive, true, got.cursor};
  IteTrials trials;
  if (resume && resume->episodes_done > 0) {
    // Replay the trials so far: the posterior is a function of them alone.
    trials = IteTrials::load(resume->extra);
    const std::size_t n = trials.cells.size();
    if (resume->episodes_done > options_.episodes ||
        n > static_cast<std::size_t>(resume->episodes_done) || n == 0)
      throw InvalidArgument("resume: episodes_done = " + std::to_string(resume->episodes_done) +
                            " with " + std::to_string(n) + " trials does not fit a run of " +
                            std::to_string(options_.episodes) + " episodes");
    for (std::size_t i = 0; i < n; ++i)
      mboa.observe(archive.cell_from_linear(trials.cells[i]), observation(trials.returns[i]));
    check_size("resume: best_theta vs policy parameters", problem.policy->param_dim(),
               resume->best_theta.size());
    state.episodes_done = summary.episodes_done = resume->episodes_done;
    state.best_theta = resume->best_theta;
    state.best_return = summary.best_real_return = resume->best_return;
    state.first_solved_episode = summary.first_solved_episode = resume->first_solved_episode;
  }

  for (int episode = state.episodes_done + 1; episode <= options_.episodes; ++episode) {
    if (stop()) {
      summary.interrupted = true;
      break;
    }
    // A trial while M-BOA goes on; afterwards the best tested cell again (or the end).
    const bool trial = !mboa.should_stop();
    if (!trial && options_.after_stop == IteAfterStop::kEnd) break;
    const ite::Cell cell = trial ? mboa.next_cell() : mboa.summary().best_cell;
    const ite::Elite& elite = mboa.elite(cell);

    EpisodeRecord rec;
    rec.episode = episode;
    rec.theta = elite.theta;
    rec.phi = problem.prior_parameters.values;
    rec.selected = trial ? "trial" : "best_tested";
    rec.predicted = problem.prior ? prior_episode(problem, rec.theta) : rollout::Trajectory{};
    rec.predicted_return = mboa.mean(cell) / scale;  // what M-BOA expects of it on the robot
    rec.details.numbers = {{"cell", static_cast<double>(archive.linear_index(cell))},
                   {"trial", trial ? 1.0 : 0.0},
                   {"archive_return", elite.fitness / scale},
                   {"predicted_sd", std::sqrt(mboa.variance(cell)) / scale}};
    if (episode == 1 && got.source == "map_elites") {
      rec.policy_seconds = got.seconds;
      rec.evaluations = got.cursor.evaluations;  // over every session of the generation
    }

    if (callbacks.on_status) callbacks.on_status(Status{episode, "episode", 0, 0});
    auto policy = problem.policy->clone();
    policy->set_params(rec.theta);
    Rng rng(derive_seed(options_.seed,
                        {static_cast<std::uint64_t>(episode), kIteRealEpisodeStream}));
    rec.real = rollout::run_episode(task, *problem.real, *policy, rng);
    rec.real_return = rec.real.total_return();
    rec.solved = rollout::episode_solved(task, rec.real);
    rec.interaction_time = episode * task.horizon() * task.dt();
    if (trial) {
      mboa.observe(cell, observation(rec.real_return));
      trials.cells.push_back(archive.linear_index(cell));
      trials.returns.push_back(rec.real_return);
    }
    rec.details.numbers["stop"] = mboa.should_stop() ? 1.0 : 0.0;

    if (rec.real_return > state.best_return) {
      state.best_return = rec.real_return;
      state.best_theta = rec.theta;
    }
    if (rec.solved && state.first_solved_episode == 0) state.first_solved_episode = episode;
    state.episodes_done = summary.episodes_done = episode;
    summary.best_real_return = state.best_return;
    summary.first_solved_episode = state.first_solved_episode;
    if (callbacks.on_episode) callbacks.on_episode(rec);
    if (callbacks.on_state) {
      state.extra = trials.save();
      callbacks.on_state(state);
    }
  }
  const ite::MboaSummary ms = mboa.summary();
  summary.details.numbers["trials"] = ms.trials;
  summary.details.numbers["stopped_by_rule"] = ms.stop == ite::MboaStop::kMaxPredictedValue ? 1.0 : 0.0;
  summary.seconds = seconds_since(t_run);
  return summary;
}

rollout::Trajectory prior_episode(const Problem& problem, const VectorXd& theta) {
  if (!problem.prior) throw InvalidArgument("prior_episode: the problem has no prior");
  check_size("prior_episode: theta vs policy parameters", problem.policy->param_dim(),
             theta.size());
  const auto model = model::make_prior_only_model(problem.prior, problem.prior_parameters);
  rollout::RolloutOptions mean_only;
  mean_only.sample = false;
  const rollout::ModelSystem system(*model, mean_only);
  auto policy = problem.policy->clone();
  policy->set_params(theta);
  Rng unused(0);
  return rollout::run_episode(*problem.task, system, *policy, unused);
}

ite::EvaluationFunction prior_evaluation(const Problem& problem,
                                         const ite::BehaviourDescriptor& behaviour) {
  if (!problem.prior) throw InvalidArgument("prior_evaluation: the problem has no prior");
  behaviour.check();
  std::shared_ptr<const model::DynamicsModel> model =
      model::make_prior_only_model(problem.prior, problem.prior_parameters);
  rollout::RolloutOptions mean_only;
  mean_only.sample = false;
  auto system = std::make_shared<const rollout::ModelSystem>(*model, mean_only);
  const int k = static_cast<int>(behaviour.bins.size());
  return [model, system, k, behaviour, task = problem.task, policy = problem.policy](
             const VectorXd& theta, std::uint64_t stream) {
    auto p = policy->clone();
    p->set_params(theta);
    Rng rng(stream);  // the system is deterministic; the stream is there for the interface
    long nonfinite = 0;
    const rollout::Trajectory tr = rollout::run_episode(*task, *system, *p, rng, &nonfinite);
    ite::Evaluation e;
    if (nonfinite > 0) {  // the prior could not finish the episode: counted as invalid
      e.descriptor = VectorXd::Constant(k, kNaN);
      return e;
    }
    e.fitness = tr.total_return();
    e.descriptor = behaviour.describe(tr);
    e.alive = !behaviour.alive || behaviour.alive(tr);
    return e;
  };
}

namespace {

/// Step 1 of run(). Order: an archive in the resume state (complete: used; partial: its
/// generation continued from its cursor), then options.archive, then a new MAP-Elites run.
/// on_state gets the archive (episodes_done = 0) during the generation at most every
/// checkpoint_seconds, when it is stopped, and once it is complete (the given one too).
ArchiveOutcome obtain_archive(const Problem& problem, const IteOptions& options,
                              const Callbacks& callbacks, const RunState* resume) {
  const ite::BehaviourDescriptor& behaviour = options.behaviour;
  const int k = static_cast<int>(behaviour.bins.size());
  const int n = problem.policy->param_dim();
  ArchiveOutcome out;
  auto hand_out = [&](std::shared_ptr<const ite::Archive> archive, bool complete,
                      const ite::MapElitesCursor& cursor) {
    if (!callbacks.on_state) return;
    RunState st;
    st.side_state = ArchiveState{std::move(archive), complete, cursor};
    callbacks.on_state(st);
  };
  const ArchiveState* resumed = resume ? archive_state(*resume) : nullptr;
  if (resumed && resumed->archive && resumed->complete) {
    check_archive(*resumed->archive, problem, k, "resume: the archive");
    out.archive = resumed->archive;
    out.cursor = resumed->cursor;
    out.source = "resumed";
    return out;
  }
  if (resume && resume->episodes_done > 0)
    throw InvalidArgument("resume: the state has episodes but no complete archive");
  if (options.archive) {
    check_archive(*options.archive, problem, k, "the given archive");
    if (options.archive->empty()) throw InvalidArgument("the given archive is empty");
    out.archive = options.archive;
    out.cursor = options.archive_cursor;
    out.source = "given";
    hand_out(out.archive, true, out.cursor);
    return out;
  }

  // MAP-Elites on the prior, continued from a partial archive when resuming.
  if (!problem.prior)
    throw InvalidArgument("IT&E: the problem has no simulator prior to build the archive on, "
                          "and no archive is given");
  const std::vector<int> bins = options.bins.empty() ? behaviour.bins : options.bins;
  auto archive = std::make_shared<ite::Archive>(bins, n);
  const ite::MapElitesCursor* cursor = nullptr;
  if (resumed && resumed->archive) {
    check_archive(*resumed->archive, problem, k, "resume: the partial archive");
    if (resumed->archive->bins() != bins)
      throw InvalidArgument("resume: the partial archive's grid differs from the configured one");
    *archive = *resumed->archive;
    cursor = &resumed->cursor;
  }
  ite::MapElitesOptions mo = options.map_elites;
  mo.seed = derive_seed(options.seed, {kIteArchiveStream});
  mo.parallel = true;
  const VectorXd lower = VectorXd::Constant(n, -options.theta_bound);
  const VectorXd upper = VectorXd::Constant(n, options.theta_bound);
  const auto t0 = Clock::now();
  auto last_checkpoint = t0;
  bool interrupted = false;
  auto on_batch = [&](const ite::MapElitesProgress& p, const ite::Archive& a) {
    if (callbacks.on_status) {
      Status s{1, "archive", p.cursor.evaluations, p.best_fitness};
      s.budget = mo.max_evaluations;
      s.coverage = p.coverage;
      callbacks.on_status(s);
    }
    interrupted = callbacks.should_stop && callbacks.should_stop();
    const bool done = p.cursor.evaluations >= mo.max_evaluations;
    if (!done && (interrupted || seconds_since(last_checkpoint) >= options.checkpoint_seconds)) {
      hand_out(std::make_shared<const ite::Archive>(a), false, p.cursor);
      last_checkpoint = Clock::now();
    }
    return !interrupted;
  };
  out.map_elites = ite::run_map_elites(prior_evaluation(problem, behaviour), lower, upper, mo,
                                       *archive, on_batch, cursor);
  out.seconds = seconds_since(t0);
  out.source = "map_elites";
  if (interrupted) return out;  // out.archive stays null
  if (archive->empty())
    throw Error("IT&E: MAP-Elites filled no cell of the archive in " +
                std::to_string(out.map_elites.cursor.evaluations) + " evaluations (" +
                std::to_string(out.map_elites.dead) + " dead, " +
                std::to_string(out.map_elites.invalid) + " invalid, " +
                std::to_string(out.map_elites.out_of_range) +
                " out of range): the behaviour descriptor or the prior needs a look");
  out.archive = archive;
  out.cursor = out.map_elites.cursor;
  hand_out(out.archive, true, out.cursor);
  return out;
}

/// A copy of `archive` with every fitness multiplied by scale (M-BOA's prior mean).
std::shared_ptr<const ite::Archive> scaled_archive(const ite::Archive& archive, double scale) {
  auto scaled = std::make_shared<ite::Archive>(archive.bins(), archive.param_dim());
  for (ite::Elite e : archive.elites()) {
    e.fitness *= scale;
    scaled->restore(std::move(e));
  }
  return scaled;
}

void check_archive(const ite::Archive& archive, const Problem& problem, int descriptor_dim,
                   const char* what) {
  if (archive.descriptor_dim() != descriptor_dim)
    throw InvalidArgument(std::string(what) + " has " + std::to_string(archive.descriptor_dim()) +
                          " descriptor dimensions; the task's behaviour descriptor has " +
                          std::to_string(descriptor_dim));
  if (archive.param_dim() != problem.policy->param_dim())
    throw InvalidArgument(std::string(what) + " holds policies of " +
                          std::to_string(archive.param_dim()) + " parameters; the task's policy has " +
                          std::to_string(problem.policy->param_dim()));
}

}  // namespace
}  // namespace drops::algo
