/// realaigym_score: the RealAIGym simulation leaderboards' criteria and RealAI score of trajectory
/// files in the lab's sim_swingup.csv form (columns time, pos_meas1, pos_meas2, vel_meas1,
/// vel_meas2, tau_con1, tau_con2), beside the scores.csv published next to each file when there is
/// one; with --replay, the file's torques replayed open loop on the leaderboard's plant from rest,
/// and the largest angle difference to the file's angles over the first seconds.
/// Usage: realaigym_score [--definition v1|v2] [--plant a0|c1] [--replay] FILE...
/// (docs/decisions/realaigym-scorer.md).

#include <fmt/core.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/experiment/recorded_log.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/realaigym/plant.hpp"
#include "drops/realaigym/score.hpp"

namespace rg = drops::realaigym;
namespace fs = std::filesystem;

namespace {

constexpr const char* kUsage =
    "usage: realaigym_score [--definition v1|v2] [--plant a0|c1] [--replay] FILE...\n"
    "  FILE: a leaderboard trajectory (sim_swingup.csv); a scores.csv beside it is compared.\n"
    "  --definition: the leaderboard's score (v1: simulation_v1, default; v2: simulation_v2)\n"
    "  --plant: the plant of --replay (a0: design A.0 model 2.0, the v1 plant; c1: design C.1\n"
    "           model 1.0, the v2 plant; default: the definition's)\n"
    "  --replay: replay the file's torques open loop from rest at dt 2 ms\n";

rg::SwingupTrajectory read_trajectory(const fs::path& path) {
  const drops::experiment::LogTable table =
      drops::experiment::parse_log_csv(drops::experiment::read_file_text(path), path.string(), {});
  const char* names[] = {"time",      "pos_meas1", "pos_meas2", "vel_meas1",
                         "vel_meas2", "tau_con1",  "tau_con2"};
  std::vector<int> col;
  for (const char* name : names) {
    const int c = table.column(name);
    if (c < 0) throw drops::Error(path.string() + ": no column " + name);
    col.push_back(c);
  }
  const Eigen::Index n = table.values.rows();
  rg::SwingupTrajectory tr{drops::VectorXd(n), drops::MatrixXd(n, 4), drops::MatrixXd(n, 2)};
  tr.t = table.values.col(col[0]);
  for (int j = 0; j < 4; ++j) tr.x.col(j) = table.values.col(col[1 + j]);
  for (int j = 0; j < 2; ++j) tr.tau.col(j) = table.values.col(col[5 + j]);
  if (!tr.t.allFinite() || !tr.x.allFinite() || !tr.tau.allFinite())
    throw drops::Error(path.string() + ": a value is empty or not finite");
  return tr;
}

// scores.csv: a header line and one line of values.
std::vector<std::pair<std::string, double>> read_published(const fs::path& path) {
  std::istringstream in(drops::experiment::read_file_text(path));
  std::string header, values;
  std::getline(in, header);
  std::getline(in, values);
  std::vector<std::pair<std::string, double>> out;
  std::istringstream h(header), v(values);
  std::string name, value;
  while (std::getline(h, name, ',') && std::getline(v, value, ','))
    out.emplace_back(name, std::stod(value));
  return out;
}

void print_scores(const rg::SwingupTrajectory& tr, const rg::ScoreDefinition& def,
                  const fs::path& scores_csv) {
  const rg::Score s = rg::score(tr, def);
  const rg::CriterionValues& c = s.criteria;
  struct Row {
    const char* column;  // the lab's column name in scores.csv and the tables
    double value;
    int digits;  // the tables' rounding
  };
  const Row rows[] = {{"Swingup Success", s.success ? 1.0 : 0.0, 0},
                      {"Swingup Time [s]", c.swingup_time, 2},
                      {"Energy [J]", c.energy, 2},
                      {"Max. Torque [Nm]", c.max_tau, 2},
                      {"Integrated Torque [Nms]", c.integrated_tau, 2},
                      {"Torque Cost[N²m²]", c.tau_cost, 2},
                      {"Torque Smoothness [Nm]", c.tau_smoothness, 3},
                      {"Velocity Cost [m²/s²]", c.velocity_cost, 2},
                      {"RealAI Score", s.realai_score, 3}};
  std::vector<std::pair<std::string, double>> published;
  if (fs::exists(scores_csv)) published = read_published(scores_csv);
  fmt::print("  {:<24} {:>22} {:>9} {:>22} {:>9} {:>9}\n", "criterion", "ours", "printed",
             "published", "printed", "|diff|");
  for (const Row& r : rows) {
    const double* pub = nullptr;
    for (const auto& [name, value] : published)
      if (name == r.column) pub = &value;
    const std::string ours = fmt::format("{:.{}f}", r.value, r.digits);
    if (pub == nullptr) {
      fmt::print("  {:<24} {:>22.15g} {:>9} {:>22} {:>9}\n", r.column, r.value, ours, "-", "-");
      continue;
    }
    const std::string theirs = fmt::format("{:.{}f}", *pub, r.digits);
    fmt::print("  {:<24} {:>22.15g} {:>9} {:>22.15g} {:>9} {:>9.1e}{}\n", r.column, r.value, ours,
               *pub, theirs, std::abs(r.value - *pub), ours == theirs ? "" : "  DIFFERS");
  }
}

void print_replay(const rg::SwingupTrajectory& tr, const rg::PlantParameters& plant,
                  const std::string& plant_name) {
  constexpr double dt = 0.002;
  const Eigen::Index n = tr.t.size();
  // Two layouts: a first row at t = 0 holds x_0 and the torque applied over [0, dt]
  // (simulation_v2); a first row at t = dt holds x(dt) and the torque that produced it
  // (simulation_v1's files).
  const bool starts_at_zero = std::abs(tr.t[0]) < 0.5 * dt;
  drops::MatrixXd reference, torques;
  if (starts_at_zero) {
    reference = tr.x;
    torques = tr.tau.topRows(n - 1);
  } else {
    reference.resize(n + 1, 4);
    reference.row(0).setZero();
    reference.bottomRows(n) = tr.x;
    torques = tr.tau;
  }
  const drops::MatrixXd states = rg::simulate_torques(plant, Eigen::Vector4d::Zero(), torques, dt);
  fmt::print("  replay on {} ({} layout): max |q - q_file| (rad) over", plant_name,
             starts_at_zero ? "x_k, tau_k" : "x_k+1, tau_k");
  for (double seconds : {0.5, 1.0, 2.0, 3.0, 5.0}) {
    const Eigen::Index k = std::min<Eigen::Index>(std::lround(seconds / dt) + 1, states.rows());
    const double err =
        (states.topRows(k).leftCols(2) - reference.topRows(k).leftCols(2)).cwiseAbs().maxCoeff();
    fmt::print("  {:g} s: {:.2e}", seconds, err);
  }
  fmt::print("\n");
}

}  // namespace

int main(int argc, char** argv) {
  std::string definition = "v1", plant_name;
  bool replay = false;
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help") {
      std::fputs(kUsage, stdout);
      return 0;
    } else if ((a == "--definition" || a == "--plant") && i + 1 < argc) {
      (a == "--definition" ? definition : plant_name) = argv[++i];
    } else if (a == "--replay") {
      replay = true;
    } else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "realaigym_score: unknown option '%s'\n%s", a.c_str(), kUsage);
      return 2;
    } else {
      files.emplace_back(a);
    }
  }
  if (files.empty() || (definition != "v1" && definition != "v2") ||
      (!plant_name.empty() && plant_name != "a0" && plant_name != "c1")) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const rg::ScoreDefinition def = definition == "v1" ? rg::simulation_v1() : rg::simulation_v2();
  if (plant_name.empty()) plant_name = definition == "v1" ? "a0" : "c1";
  const rg::PlantParameters plant =
      plant_name == "a0" ? rg::design_a0_model_2_0() : rg::design_c1_model_1_0();
  try {
    for (const fs::path& file : files) {
      fmt::print("{} ({})\n", file.string(), def.name);
      const rg::SwingupTrajectory tr = read_trajectory(file);
      print_scores(tr, def, file.parent_path() / "scores.csv");
      if (replay)
        print_replay(tr, plant,
                     plant_name == "a0" ? "design A.0 model 2.0" : "design C.1 model 1.0");
    }
  } catch (const drops::Error& e) {
    std::fprintf(stderr, "realaigym_score: %s\n", e.what());
    return 1;
  }
  return 0;
}
