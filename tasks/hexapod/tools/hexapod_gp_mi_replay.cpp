// hexapod_gp_mi_replay: GP-MI's choices on a hexapod run's data, replayed episode by episode
// (docs/decisions/hexapod-gp-mi-candidate-start.md).
//
//   build/tasks/hexapod/tools/hexapod_gp_mi_replay RUN_DIR K [score S] [start C] [inner N]
//
// One gp_mi model with the hexapod's 7 removed-leg priors learns the measured transitions of
// episodes 1..k of RUN_DIR (episodes/NNN/real.csv) for k = 1..K in turn, as a `drops run` does
// before episodes 2..K+1 (its kernels and phi carried from one episode to the next), with the
// hexapod's kernel fits (soft walls 10 and 500, Rprop tolerance 1e-3). Prints per k the prior it
// names, its score and seconds, beside the prior the run itself used at episode k+1
// (episodes.csv). Options: "score sum_likelihoods|sum_log_likelihoods" (model.gp_mi.score;
// default the paper's), "start best_so_far|initial" (model.gp_mi.candidate_start; default
// best_so_far), "inner N" (model.gp_mi.inner_rprop_iterations; default 50). Same data, other
// choices: a counterfactual on the identification only, not on the policies the run chose.
// Runs on one thread, as each run of a campaign.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/hexapod/prior.hpp"
#include "drops/hexapod/task.hpp"
#include "drops/model/dynamics_model.hpp"
#include "drops/model/gp_mi.hpp"
#include "hexapod_run_data.hpp"

namespace {

/// The phi column of RUN_DIR/episodes.csv per episode (index 0 = episode 1), read with the
/// run-directory reader; empty when the file cannot be read or has no phi column.
std::vector<double> run_phis(const std::string& dir) {
  std::vector<double> out;
  try {
    const auto table = drops::experiment::read_trajectory_csv(dir + "/episodes.csv");
    const int c = table.column("phi");
    if (c < 0) return out;
    for (const auto& row : table.rows) out.push_back(row[static_cast<std::size_t>(c)]);
  } catch (const drops::Error&) {
    out.clear();
  }
  return out;
}

std::string leg_name(double phi) {
  const int leg = static_cast<int>(phi);
  return leg < 0 ? "intact" : "leg" + std::to_string(leg);
}

}  // namespace

int main(int argc, char** argv) {
  namespace hx = drops::hexapod;
  namespace dm = drops::model;
  char* walls[] = {const_cast<char*>("walls"), const_cast<char*>("10"), const_cast<char*>("500")};
  dm::ModelOptions options = drops::tools::gp_prior_options(walls);
  options.type = dm::ModelType::kGpMi;
  options.gp_mi.search = dm::GpMiSearch::kNested;
  bool usage = argc < 3;
  for (int a = 3; a < argc && !usage; a += 2) {
    const std::string w = argv[a];
    const std::string v = a + 1 < argc ? argv[a + 1] : "";
    if (w == "score" && (v == "sum_likelihoods" || v == "sum_log_likelihoods")) {
      options.gp_mi.score = v == "sum_likelihoods" ? dm::GpMiScore::kSumOfLikelihoods
                                                   : dm::GpMiScore::kSumOfLogLikelihoods;
    } else if (w == "start" && (v == "best_so_far" || v == "initial")) {
      options.gp_mi.candidate_start =
          v == "initial" ? dm::GpMiCandidateStart::kInitial : dm::GpMiCandidateStart::kBestSoFar;
    } else if (w == "inner" && std::atoi(v.c_str()) >= 1) {
      options.gp_mi.inner_rprop_iterations = std::atoi(v.c_str());
    } else {
      usage = true;
    }
  }
  if (usage) {
    std::fprintf(stderr,
                 "usage: %s RUN_DIR K [score sum_likelihoods|sum_log_likelihoods] "
                 "[start best_so_far|initial] [inner N]\n"
                 "  GP-MI's prior per episode on episodes 1..k of RUN_DIR, k = 1..K\n",
                 argv[0]);
    return 2;
  }
  // One thread, as each run of a campaign (threads: 1), and one thread per BLAS call as in drops.
  drops::use_single_threaded_blas();
  const drops::ThreadLimit one_thread(1);
  try {
    const std::string dir = argv[1];
    const int k_max = std::atoi(argv[2]);
    if (k_max < 1) throw drops::InvalidArgument("K must be >= 1");
    const std::vector<double> ran = run_phis(dir);
    auto task = std::make_shared<hx::HexapodTask>();
    hx::HexapodPriorOptions prior_options;
    prior_options.pool_capacity = 1;
    auto prior = std::make_shared<hx::HexapodPrior>(prior_options);
    auto model = dm::make_model(options, task, prior, hx::HexapodPrior::prior_parameters());
    std::printf("%-3s | %-7s | %12s | %8s | %s\n", "k", "named", "score", "seconds",
                "the run's prior at episode k+1");
    for (int k = 1; k <= k_max; ++k) {
      const dm::ModelSummary s = model->learn(drops::tools::read_episodes(dir, k));
      const std::string theirs = static_cast<std::size_t>(k) < ran.size()
                                     ? leg_name(ran[static_cast<std::size_t>(k)])
                                     : "-";
      std::printf("%-3d | %-7s | %12.2f | %8.1f | %s\n", k, leg_name(s.phi[0]).c_str(), s.score,
                  s.seconds, theirs.c_str());
      std::fflush(stdout);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hexapod_gp_mi_replay: %s\n", e.what());
    return 1;
  }
  return 0;
}
