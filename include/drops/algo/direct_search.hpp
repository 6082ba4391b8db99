#pragma once
/// \file The policy optimized directly on the real system by BIPOP-aCMA-ES, one real episode per
/// evaluation and no model. Not the paper's method: a model-free baseline, and with a large budget
/// the ceiling of what the policy family achieves on the robot.

#include <cstdint>
#include <string>

#include "drops/algo/algorithm.hpp"
#include "drops/opt/cmaes.hpp"

namespace drops::algo {

/// Options of DirectSearch.
struct DirectSearchOptions {
  std::uint64_t seed = 1;    ///< the search's seed (CMA-ES sampling and the real episodes' noise)
  double theta_bound = 5.0;  ///< policy parameters searched in [-b, b], > 0
  /// CMA-ES settings; max_evaluations is the budget of real episodes, sigma0 <= 0 means b
  /// (settings.md §5), seed and evaluate_start are set by the search.
  opt::CmaesOptions cmaes;
  /// Start point (dim param_dim, inside the box): evaluated first and kept unless beaten. Empty:
  /// the centre of the box, not evaluated on its own.
  VectorXd start;
  /// Returns true when every field is valid; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// BIPOP-aCMA-ES on the real system: each evaluation is one real episode, reported through
/// on_episode in evaluation order (a generation's episodes run in parallel, then are reported in
/// candidate order). Only the episodes that improve on the best return so far keep their
/// trajectories (EpisodeRecord::keep_trajectories). on_state is not called: a direct search
/// cannot be resumed. Deterministic for a given seed whatever the thread count.
class DirectSearch final : public Algorithm {
 public:
  /// Throws InvalidArgument when options are invalid.
  explicit DirectSearch(const DirectSearchOptions& options);
  std::string name() const override { return "direct"; }
  int episodes() const override { return static_cast<int>(options_.cmaes.max_evaluations); }
  bool resumable() const override { return false; }
  /// Throws InvalidArgument when resume is not null, or the start does not fit the policy or lies
  /// outside the box.
  RunSummary run(const Problem& problem, const Callbacks& callbacks,
                 const RunState* resume = nullptr) const override;

 private:
  DirectSearchOptions options_;
};

}  // namespace drops::algo
