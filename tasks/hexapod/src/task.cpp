// HexapodTask (task.hpp). No DART include here.

#include "drops/hexapod/task.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "drops/core/errors.hpp"

namespace drops::hexapod {

bool HexapodTaskOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& field, double v, const char* allowed) {
    if (why != nullptr) {
      std::ostringstream s;
      s << "HexapodTaskOptions." << field << " must be " << allowed << ", got " << v;
      *why = s.str();
    }
    return false;
  };
  auto finite_nonneg = [](double v) { return std::isfinite(v) && v >= 0.0; };
  if (horizon < 1) return fail("horizon", horizon, ">= 1");
  if (!(std::isfinite(dt) && dt > 0)) return fail("dt", dt, "> 0");
  if (!(std::isfinite(initial_height) && initial_height > 0))
    return fail("initial_height", initial_height, "> 0");
  if (!finite_nonneg(lateral_limit)) return fail("lateral_limit", lateral_limit, ">= 0");
  if (!finite_nonneg(lateral_penalty)) return fail("lateral_penalty", lateral_penalty, ">= 0");
  if (!(tilt_limit > 0 && tilt_limit <= 3.14159265358979323846))
    return fail("tilt_limit", tilt_limit, "in (0, pi]");
  if (!finite_nonneg(tilt_penalty)) return fail("tilt_penalty", tilt_penalty, ">= 0");
  if (!std::isfinite(solved_speed)) return fail("solved_speed", solved_speed, "finite");
  return true;
}

double body_tilt(double roll, double pitch) {
  return std::acos(std::clamp(std::cos(roll) * std::cos(pitch), -1.0, 1.0));
}

double walking_speed(const rollout::Trajectory& trajectory, double dt) {
  const MatrixXd& s = trajectory.states;
  if (s.cols() != kStateDim || s.rows() < 2) {
    throw InvalidArgument("walking_speed: expected states of 48 columns and >= 2 rows, got " +
                          std::to_string(s.rows()) + " x " + std::to_string(s.cols()));
  }
  if (!(std::isfinite(dt) && dt > 0)) throw InvalidArgument("walking_speed: dt must be > 0");
  const double duration = static_cast<double>(s.rows() - 1) * dt;
  return (s(s.rows() - 1, kBodyPos) - s(0, kBodyPos)) / duration;
}

HexapodTask::HexapodTask(const HexapodTaskOptions& options) : options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw InvalidArgument(why);
}

VectorXd HexapodTask::initial_state() const {
  VectorXd x = VectorXd::Zero(kStateDim);
  x[kBodyPos + 2] = options_.initial_height;
  return x;
}

void HexapodTask::observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const {
  check_size("HexapodTask::observe x", kStateDim, x.size());
  check_size("HexapodTask::observe obs", kObservationDim, obs.size());
  obs.head<kBodyPos>() = x.head<kBodyPos>();              // q, dq
  obs[kBodyPos] = x[kBodyPos + 2];                        // z
  obs.segment<2>(kBodyPos + 1) = x.segment<2>(kBodyRpy);  // roll, pitch
  obs.tail<6>() = x.tail<6>();                            // linear, angular velocity
}

double HexapodTask::reward(const VectorXd& x) const {
  check_size("HexapodTask::reward x", kStateDim, x.size());
  double r = x[kBodyPos] * options_.dt;
  if (std::abs(x[kBodyPos + 1]) > options_.lateral_limit)
    r -= options_.lateral_penalty * options_.dt;
  if (body_tilt(x[kBodyRpy], x[kBodyRpy + 1]) >= options_.tilt_limit) r -= options_.tilt_penalty;
  return r;
}

bool HexapodTask::solved(const rollout::Trajectory& trajectory) const {
  for (Eigen::Index t = 0; t < trajectory.states.rows(); ++t) {
    if (body_tilt(trajectory.states(t, kBodyRpy), trajectory.states(t, kBodyRpy + 1)) >=
        options_.tilt_limit) {
      return false;
    }
  }
  return walking_speed(trajectory) >= options_.solved_speed;
}

bool HexapodTask::absorbing(const VectorXd& x) const {
  check_size("HexapodTask::absorbing x", kStateDim, x.size());
  return body_tilt(x[kBodyRpy], x[kBodyRpy + 1]) >= options_.tilt_limit;
}

double HexapodTask::walking_speed(const rollout::Trajectory& trajectory) const {
  return hexapod::walking_speed(trajectory, options_.dt);
}

}  // namespace drops::hexapod
