// The model variants behind one factory (paper §IV, §V-A): gp, gp_prior and gp_mi are
// GpDynamicsModel (gp_dynamics.cpp, GP-MI in gp_mi.cpp); mi and the prior-only planning model are
// SimulatorModel (simulator_model.cpp).
#include "drops/model/dynamics_model.hpp"

#include <algorithm>
#include <sstream>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/model/gp_dynamics.hpp"
#include "drops/model/simulator_model.hpp"

namespace drops::model {

bool MiOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (max_evaluations < 1) return fail("mi.max_evaluations must be >= 1");
  if (!(xtol_rel >= 0) || !(ftol_rel >= 0)) return fail("mi tolerances must be >= 0");
  return true;
}

bool ModelOptions::IsValid(std::string* why) const {
  std::string w;
  if (!rprop.IsValid(&w)) {
    if (why) *why = "rprop: " + w;
    return false;
  }
  if (!gp_mi.IsValid(why)) return false;
  if (variance_points < 0) {
    if (why) *why = "variance_points must be >= 0 (0: every transition), got " +
                    std::to_string(variance_points);
    return false;
  }
  if (inducing_points < 0) {
    if (why) *why = "inducing_points must be >= 0 (0: exact GPs), got " +
                    std::to_string(inducing_points);
    return false;
  }
  return mi.IsValid(why);
}

PhiSampling DynamicsModel::draw_phi_samples(int count, std::uint64_t /*seed*/) {
  if (count < 1)
    throw InvalidArgument("draw_phi_samples: count must be >= 1, got " + std::to_string(count));
  return {};
}

void DynamicsModel::check_samples(Eigen::Index rows, const std::vector<int>& sample) const {
  check_size("predict_batch_sampled: sample (one per row of X)", rows,
             static_cast<Eigen::Index>(sample.size()));
  const int samples = std::max(1, phi_samples());
  for (const int s : sample) {
    if (s < 0 || s >= samples)
      throw InvalidArgument("predict_batch_sampled: sample " + std::to_string(s) +
                            " out of range [0, " + std::to_string(samples) + ")");
  }
}

void DynamicsModel::predict_batch_sampled(const MatrixXd& X, const MatrixXd& U,
                                          const std::vector<int>& sample, MatrixXd& mean,
                                          MatrixXd& var) const {
  check_samples(X.rows(), sample);
  predict_batch(X, U, mean, var);
}

std::string to_string(ModelType type) {
  switch (type) {
    case ModelType::kGp: return "gp";
    case ModelType::kGpPrior: return "gp_prior";
    case ModelType::kGpMi: return "gp_mi";
    case ModelType::kMi: return "mi";
  }
  return "?";
}

std::string ModelSummary::BriefReport() const {
  std::ostringstream o;
  o << "model: " << points << " points";
  if (phi.size()) {
    o << ", phi = [";
    for (Eigen::Index i = 0; i < phi.size(); ++i) o << (i ? ", " : "") << phi[i];
    o << "]";
  }
  if (phi_evaluations) o << ", " << phi_evaluations << " phi evaluations";
  if (log_likelihoods.size()) o << ", score " << score;
  o << ", " << rprop_iterations << " Rprop iterations, " << seconds << " s";
  if (nonfinite_prior_outputs) o << ", " << nonfinite_prior_outputs << " non-finite prior outputs";
  return o.str();
}

std::unique_ptr<DynamicsModel> make_model(const ModelOptions& options,
                                          std::shared_ptr<const Task> task,
                                          std::shared_ptr<const MeanFunction> prior,
                                          const PriorParameters& parameters) {
  if (!task) throw InvalidArgument("make_model: task is null");
  switch (options.type) {
    case ModelType::kGp:
      return std::make_unique<GpDynamicsModel>(options, std::move(task), nullptr, PriorParameters{});
    case ModelType::kGpPrior:
    case ModelType::kGpMi:
      if (!prior)
        throw InvalidArgument("model '" + to_string(options.type) + "' needs a simulator prior");
      return std::make_unique<GpDynamicsModel>(options, std::move(task), std::move(prior), parameters);
    case ModelType::kMi:
      return std::make_unique<SimulatorModel>(options, std::move(prior), parameters, true);
  }
  throw InvalidArgument("make_model: unknown type");
}

std::unique_ptr<DynamicsModel> make_prior_only_model(std::shared_ptr<const MeanFunction> prior,
                                                     const PriorParameters& parameters) {
  ModelOptions o;
  o.type = ModelType::kGpPrior;
  return std::make_unique<SimulatorModel>(o, std::move(prior), parameters, false);
}

}  // namespace drops::model
