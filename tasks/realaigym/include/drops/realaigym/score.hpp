#pragma once
/// \file The RealAIGym simulation leaderboards' criteria and "RealAI score" of a swing-up
/// trajectory, as the lab computes them (repository dfki-ric-underactuated-lab/double_pendulum:
/// src/python/double_pendulum/analysis/leaderboard.py, functions get_swingup_time, get_energy,
/// get_max_tau, get_integrated_torque, get_torque_cost, get_tau_smoothness, get_velocity_cost and
/// leaderboard_scores; weights and normalisation in leaderboard/ROBOT/simulation_v1/ and
/// simulation_v2/calculate_leaderboard_score.py). Written anew from those definitions; checked
/// against the published scores in docs/decisions/realaigym-scorer.md (ROBOT: the lab's name for
/// the double pendulum with joint 2 passive; the full paths are there too).
///
/// A trajectory is N samples (t_i, x_i, tau_i), x_i = [q1, q2, qd1, qd2] (rad, rad/s) and tau_i
/// the torques (N m) recorded with it, as in the lab's sim_swingup.csv. Sums run over i = 0..N-2
/// with dt_i = t_{i+1} - t_i (the lab's np.diff and U[:-1]):
///   swing-up time   the time t_k where the last run of samples whose end of link 2 is higher than
///                   height_fraction (l1 + l2) above joint 1 begins, the run ending at sample N-2
///                   and k >= 1 (samples 0 and N-1 are not examined); t_{N-1} when sample N-2 is
///                   not up; +inf when t_{N-1} < 0.99 t_final. Success: swing-up time < t_{N-1}.
///   energy          sum_i sum_j |(q_j,i+1 - q_j,i) tau_j,i|                         (J)
///   max torque      max_i,j |tau_j,i| (every sample)                                 (N m)
///   integrated tau  sum_i sum_j |tau_j,i| dt_i                                       (N m s)
///   torque cost     sum_i tau_i' tau_i dt_i (R = identity)                           (N^2 m^2 s)
///   smoothness      sum_j std_i(tau_j,i+1 - tau_j,i), population std (ddof 0)        (N m)
///   velocity cost   sum_i qd_i' qd_i dt_i (Q = identity)                             (rad^2/s)
/// The score, with w_c the weights, n_c the normalisations and s = 1 on success, else 0:
///   linear (v1):  s (1 - sum_c w_c c / n_c)
///   tanh (v2):    s (1 - 1/|{c: w_c != 0}| sum_c tanh(pi w_c c / n_c))
/// (The lab's tables label the torque cost N^2 m^2 and the velocity cost m^2/s^2; the units above
/// are what the sums are.)

#include <string>

#include "drops/core/types.hpp"

namespace drops::realaigym {

/// One value per criterion: the criteria of a trajectory, or the weights or normalisations of a
/// score (then dimensionless, resp. in the criterion's unit).
struct CriterionValues {
  double swingup_time = 0;    ///< s
  double energy = 0;          ///< J
  double max_tau = 0;         ///< N m
  double integrated_tau = 0;  ///< N m s
  double tau_cost = 0;        ///< N^2 m^2 s
  double tau_smoothness = 0;  ///< N m
  double velocity_cost = 0;   ///< rad^2 / s
};

/// How the criteria combine into the RealAI score.
enum class ScoreFormula {
  kLinear,  ///< leaderboard_scores(score_version="v1"): 1 - sum w c / n
  kTanh,    ///< score_version="v2": 1 - mean over nonzero weights of tanh(pi w c / n)
};

/// A leaderboard's definition of the score.
struct ScoreDefinition {
  std::string name;  ///< e.g. "simulation_v1"
  ScoreFormula formula = ScoreFormula::kLinear;
  CriterionValues weights;        ///< >= 0
  CriterionValues normalization;  ///< > 0 where the weight is nonzero
  double link1_length = 0.3;      ///< l1 of the swing-up's height rule, m (> 0)
  double link2_length = 0.2;      ///< l2, m (> 0)
  double height_fraction = 0.9;   ///< up: end of link 2 above this times (l1 + l2)
  double t_final = 10.0;          ///< the episode's length, s (> 0)
  /// The files' row layout (the scores do not depend on it beyond the rows they sum): true when
  /// row i holds x(t_i) and the torque that produced it, the first row at t = sim_dt (v1's files);
  /// false when row i holds x(t_i) and the torque applied after it, from t = 0 (v2's).
  bool rows_after_step = false;
  /// True when the fields are finite and in range; otherwise false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// leaderboard/ROBOT/simulation_v1 (the archived v1 table, the numbers issue 67 cites:
/// MC-PILCO 0.891): linear score, weights swing-up time 0.2, energy 0.1, max torque 0.1,
/// integrated torque 0.1, torque cost 0.1, smoothness 0.2, velocity cost 0.2; normalisations 10 s,
/// 100 J, 6 N m, 60 N m s, 360, 12 N m, 1000; the height rule on design A.0 (l1 = 0.3, l2 = 0.2 m).
ScoreDefinition simulation_v1();

/// leaderboard/ROBOT/simulation_v2 (the current table: MC-PILCO 0.48): tanh score over five
/// criteria of weight 1 (swing-up time, energy, torque cost, smoothness, velocity cost) with
/// normalisations 20 s, 60 J, 20, 0.1 N m, 400; the height rule on design C.1 (l1 = 0.2, l2 = 0.3
/// m).
ScoreDefinition simulation_v2();

/// A trajectory in the leaderboards' form (sim_swingup.csv).
struct SwingupTrajectory {
  VectorXd t;    ///< N sample times, s, increasing
  MatrixXd x;    ///< N x 4: q1, q2, qd1, qd2 (rad, rad/s)
  MatrixXd tau;  ///< N x 2: torques, N m
};

/// The criteria and the score of one trajectory.
struct Score {
  bool success = false;      ///< the swing-up rule holds (swing-up time < the last sample's time)
  CriterionValues criteria;  ///< swingup_time may be +inf
  double realai_score = 0;   ///< in [0, 1] for a valid definition with weights summing to <= 1
};

// Each criterion (the file's head gives the definitions). Sizes: t (N), x (N x 4), tau (N x 2),
// N >= 2; they throw InvalidArgument on other sizes. Pure, thread-safe.

/// Swing-up time (s, +inf if the trajectory is shorter than 0.99 t_final) under the height rule.
double swingup_time(const VectorXd& t, const MatrixXd& x, double l1, double l2,
                    double height_fraction, double t_final);
/// Mechanical energy spent, J.
double energy(const MatrixXd& x, const MatrixXd& tau);
/// Largest |torque|, N m.
double max_torque(const MatrixXd& tau);
/// Time integral of |torque|, N m s.
double integrated_torque(const VectorXd& t, const MatrixXd& tau);
/// Time integral of tau' tau.
double torque_cost(const VectorXd& t, const MatrixXd& tau);
/// Sum over joints of the standard deviation of the torque's changes, N m.
double torque_smoothness(const MatrixXd& tau);
/// Time integral of qd' qd.
double velocity_cost(const VectorXd& t, const MatrixXd& x);

/// Every criterion and the RealAI score of `trajectory` under `definition`. Throws
/// InvalidArgument for inconsistent sizes, N < 2, or an invalid definition.
Score score(const SwingupTrajectory& trajectory, const ScoreDefinition& definition);

/// The score of given criteria (success and criteria as score() computes them).
double realai_score(bool success, const CriterionValues& criteria,
                    const ScoreDefinition& definition);

}  // namespace drops::realaigym
