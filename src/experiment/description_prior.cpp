// The description-file prior's keys, their reader, and the prior on a task's state (issue 64).
#include "drops/experiment/description_prior.hpp"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include "drops/core/errors.hpp"
#include "drops/experiment/run_directory.hpp"
#include "sha256.hpp"

namespace drops::experiment {
namespace {

constexpr const char* kModel = "prior.model";
constexpr const char* kParameters = "prior.parameters";
constexpr const char* kSubsteps = "prior.substeps";
constexpr const char* kCoulomb = "prior.coulomb_velocity";
/// The largest description file read: 64 MiB (a URDF with inline meshes stays far below).
constexpr std::uintmax_t kMaxDescriptionFileBytes = std::uintmax_t{64} << 20;
/// Up to this many tunable parameters every corner of the bounds' box is checked (2^10 calls).
constexpr std::size_t kMaxCornerParameters = 10;

std::string key_head(const std::string& key, const std::string& value) {
  return "config key '" + key + "' = '" + value + "': ";
}

std::string number(double v) { return fmt::format("{}", v); }

std::string parameters_head(const std::string& file) {
  return std::string("config key '") + kParameters + "' (of '" + file + "'): ";
}

}  // namespace

bool JointDeclaration::IsValid(std::string* why) const {
  const auto fail = [why](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (joints.empty()) return fail("joints: empty (the file's joints of the state)");
  if (actuated.empty()) return fail("actuated: empty (the joints the action drives)");
  const auto n2 = static_cast<Eigen::Index>(2 * joints.size());
  if (state_from_joints.size() != 0 &&
      (state_from_joints.rows() != n2 || state_from_joints.cols() != n2))
    return fail(fmt::format("state_from_joints: expected {0} x {0} (2 x the joints), got {1} x {2}",
                            n2, state_from_joints.rows(), state_from_joints.cols()));
  if (state_from_joints.size() != 0 && !state_from_joints.allFinite())
    return fail("state_from_joints: not finite");
  if (state_from_joints.size() != 0 && state_from_joints.fullPivLu().rank() < n2)
    return fail("state_from_joints: not invertible");
  if (action_limit.size() != 0 &&
      (action_limit.size() != static_cast<Eigen::Index>(actuated.size()) ||
       !(action_limit.array() > 0).all()))
    return fail(fmt::format("action_limit: expected {} entries > 0 (one per actuated joint)",
                            actuated.size()));
  if (substeps < 0) return fail("substeps: expected >= 0, got " + std::to_string(substeps));
  return true;
}

std::vector<KeySpec> description_prior_keys() {
  std::vector<KeySpec> k(4);
  k[0].key = kModel;
  k[0].type = "path";
  k[0].unit = "-";
  k[0].doc =
      "a robot description file (URDF or MJCF) as the simulator prior, its physical parameters "
      "as phi (prior.parameters); a relative path is looked for in the configuration file's "
      "directory, then in the working directory. Empty: the task's own prior";
  k[1].key = kParameters;
  k[1].type = "list";
  k[1].default_value = "[]";
  k[1].unit = "-";
  k[1].doc =
      "with prior.model: phi, a list of {name: N, bounds: [lo, hi], value: V, tunable: T}: N one "
      "of <body>.mass, .com.x, .com.y, .com.z, .inertia; <joint>.damping, .friction, .armature, .gear; gravity; "
      "value default the file's; tunable default true (then bounds are required)";
  k[2].key = kSubsteps;
  k[2].type = "int";
  k[2].min = 1;
  k[2].max = 100000;
  k[2].unit = "-";
  k[2].doc = "with prior.model: RK4 steps per control period (empty: the task's, else dt / 1 ms)";
  k[3].key = kCoulomb;
  k[3].type = "double";
  k[3].min = 1e-9;
  k[3].max = 1e6;
  k[3].unit = "rad/s or m/s";
  k[3].doc =
      "with prior.model: velocity scale v_s of the smooth Coulomb friction f_c tanh(qd / v_s) "
      "(empty: 0.01)";
  return k;
}

bool uses_description_prior(const Settings& settings) {
  const auto it = settings.find(kModel);
  return it != settings.end() && !it->second.empty();
}

std::string description_prior_label(const Settings& settings) {
  return std::filesystem::path(settings.at(kModel)).filename().string();
}

DescriptionPriorSpec description_prior_spec(const Settings& s) {
  DescriptionPriorSpec spec;
  spec.file = s.at(kModel);
  try {
    spec.sha256 = sha256_hex(read_file_text(spec.file, kMaxDescriptionFileBytes));
  } catch (const Error& e) {
    throw ConfigError(key_head(kModel, spec.file) + e.what());
  }
  spec.parameters = description_prior_parameters(s);
  if (s.count(kSubsteps) && !s.at(kSubsteps).empty())
    spec.substeps = static_cast<int>(get_int(s, kSubsteps));
  if (s.count(kCoulomb) && !s.at(kCoulomb).empty()) spec.coulomb_velocity = get_double(s, kCoulomb);
  return spec;
}

std::vector<DescriptionParameter> description_prior_parameters(const Settings& s) {
  std::vector<DescriptionParameter> parameters;
  const std::string text = s.count(kParameters) ? s.at(kParameters) : "";
  YAML::Node list;
  try {
    list = YAML::Load(text.empty() ? "[]" : text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(key_head(kParameters, text) + "invalid YAML: " + e.what());
  }
  if (!list.IsSequence())
    throw ConfigError(key_head(kParameters, text) +
                      "expected a list of {name: N, bounds: [lo, hi], value: V, tunable: T}");
  std::set<std::string> seen;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node e = list[i];
    const std::string where = key_head(kParameters, text) + "entry " + std::to_string(i + 1);
    if (!e.IsMap())
      throw ConfigError(where + ": expected a mapping {name: N, bounds: [lo, hi], value: V, "
                                "tunable: T}");
    DescriptionParameter p;
    for (const auto& kv : e) {
      const std::string field = kv.first.as<std::string>("");
      if (field != "name" && field != "bounds" && field != "value" && field != "tunable")
        throw ConfigError(where + ": unknown field '" + field +
                          "'; the fields: name, bounds, value, tunable");
    }
    if (!e["name"] || !e["name"].IsScalar() || e["name"].Scalar().empty())
      throw ConfigError(where + ": no name (e.g. name: Link1.mass)");
    p.name = e["name"].Scalar();
    const std::string at = where + " (" + p.name + ")";
    if (!seen.insert(p.name).second) throw ConfigError(at + ": the parameter is listed twice");
    const auto number_of = [&](const YAML::Node& n, const std::string& what) {
      double v = NAN;
      try {
        if (n.IsScalar()) v = n.as<double>();
      } catch (const YAML::Exception&) {
      }
      if (!std::isfinite(v)) throw ConfigError(at + ": " + what + " is not a finite number");
      return v;
    };
    if (e["value"]) p.value = number_of(e["value"], "value");
    if (e["tunable"]) {
      const std::string t = e["tunable"].IsScalar() ? e["tunable"].Scalar() : "";
      if (t == "true")
        p.tunable = true;
      else if (t == "false")
        p.tunable = false;
      else
        throw ConfigError(at + ": tunable must be true or false");
    }
    if (e["bounds"]) {
      const YAML::Node b = e["bounds"];
      if (!b.IsSequence() || b.size() != 2)
        throw ConfigError(at + ": bounds must be [lower, upper]");
      const double lo = number_of(b[0], "the lower bound"), hi = number_of(b[1], "the upper bound");
      if (!(lo < hi)) throw ConfigError(at + ": bounds must be [lower, upper] with lower < upper");
      p.bounds = std::array<double, 2>{lo, hi};
    }
    if (p.tunable && !p.bounds)
      throw ConfigError(at + ": a tunable parameter needs bounds: [lower, upper] (or tunable: "
                             "false)");
    if (p.value && p.bounds && (*p.value < (*p.bounds)[0] || *p.value > (*p.bounds)[1]))
      throw ConfigError(at + ": value " + number(*p.value) + " lies outside its bounds [" +
                        number((*p.bounds)[0]) + ", " + number((*p.bounds)[1]) + "]");
    parameters.push_back(p);
  }
  return parameters;
}

DescriptionPriorSetup make_description_prior(const DescriptionPriorFactory& factory,
                                             const DescriptionPriorSpec& spec,
                                             const JointDeclaration& joints, double dt) {
  const std::string head = key_head(kModel, spec.file);
  if (!factory)
    throw ConfigError(head +
                      "this drops was built without MuJoCo, which loads description files; "
                      "install libmujoco-dev (scripts/install-deps), then scripts/build again");
  std::string why;
  if (!joints.IsValid(&why))
    throw ConfigError(head + "the task's joint declaration is invalid: " + why);
  DescriptionPriorRequest r;
  r.file = spec.file;
  r.joints = joints.joints;
  r.actuated = joints.actuated;
  for (const auto& p : spec.parameters) r.parameters.push_back(p.name);
  r.dt = dt;
  if (spec.substeps)
    r.substeps = *spec.substeps;
  else if (joints.substeps > 0)
    r.substeps = joints.substeps;
  else
    r.substeps = std::max(1, static_cast<int>(std::ceil(dt / 1e-3 - 1e-9)));
  if (spec.coulomb_velocity) r.coulomb_velocity = *spec.coulomb_velocity;
  DescriptionPriorModel m;
  try {
    m = factory(r);
  } catch (const InvalidArgument& e) {
    throw ConfigError(head + e.what());
  }
  const auto P = static_cast<Eigen::Index>(spec.parameters.size());
  if (!m.prior || m.file_values.size() != P)
    throw Error(head + "internal: the description prior factory returned no prior or " +
                std::to_string(m.file_values.size()) + " values for " + std::to_string(P) +
                " parameters");

  DescriptionPriorSetup out;
  try {
    out.prior = std::make_shared<JointMappedPrior>(m.prior, joints);
  } catch (const InvalidArgument& e) {
    throw ConfigError(head + "the task's joint declaration does not fit the file: " + e.what());
  }
  model::PriorParameters& pp = out.parameters;
  pp.names = r.parameters;
  pp.values = m.file_values;
  for (Eigen::Index i = 0; i < P; ++i) {
    const DescriptionParameter& p = spec.parameters[static_cast<std::size_t>(i)];
    if (p.value) pp.values[i] = *p.value;
    if (!p.tunable) continue;
    pp.tunable.push_back(static_cast<int>(i));
    const double v = pp.values[i], lo = (*p.bounds)[0], hi = (*p.bounds)[1];
    if (v < lo || v > hi)
      throw ConfigError(parameters_head(spec.file) + p.name + ": the file's value " + number(v) +
                        " lies outside the bounds [" + number(lo) + ", " + number(hi) +
                        "]: give a value or other bounds");
  }
  const auto T = static_cast<Eigen::Index>(pp.tunable.size());
  pp.lower.resize(T);
  pp.upper.resize(T);
  pp.choices.assign(pp.tunable.size(), {});
  for (Eigen::Index j = 0; j < T; ++j) {
    const auto& b = *spec.parameters[static_cast<std::size_t>(pp.tunable[j])].bounds;
    pp.lower[j] = b[0];
    pp.upper[j] = b[1];
  }
  // The prior's domain at the starting values, at each bound, then at the box's corners.
  const auto check = [&](const VectorXd& phi, const std::string& what) {
    try {
      m.prior->check_phi(phi);
    } catch (const InvalidArgument& e) {
      throw ConfigError(parameters_head(spec.file) + what + ": " + e.what());
    }
  };
  check(pp.values, "the starting values");
  for (Eigen::Index j = 0; j < T; ++j) {
    const std::string& name = pp.names[static_cast<std::size_t>(pp.tunable[j])];
    for (const bool upper : {false, true}) {
      VectorXd phi = pp.values;
      phi[pp.tunable[j]] = upper ? pp.upper[j] : pp.lower[j];
      check(phi, std::string("the ") + (upper ? "upper" : "lower") + " bound of " + name);
    }
  }
  if (pp.tunable.size() <= kMaxCornerParameters)
    for (unsigned c = 0; c < (1u << pp.tunable.size()); ++c) {
      VectorXd phi = pp.values;
      for (Eigen::Index j = 0; j < T; ++j)
        phi[pp.tunable[j]] = (c >> j) & 1u ? pp.upper[j] : pp.lower[j];
      check(phi, "a corner of the bounds' box");
    }
  try {
    pp.check();
  } catch (const InvalidArgument& e) {
    throw ConfigError(parameters_head(spec.file) + e.what());
  }
  out.declaration[kModel] = spec.file;
  out.declaration[std::string(kModel) + ".sha256"] = spec.sha256;
  return out;
}

JointMappedPrior::JointMappedPrior(std::shared_ptr<const model::MeanFunction> inner,
                                   const JointDeclaration& joints)
    : inner_(std::move(inner)) {
  std::string why;
  if (!joints.IsValid(&why)) throw InvalidArgument("joint declaration: " + why);
  if (!inner_) throw InvalidArgument("joint-mapped prior: no prior");
  check_size("joint-mapped prior: the prior's state (2 x the declared joints)",
             static_cast<long>(2 * joints.joints.size()), inner_->state_dim());
  check_size("joint-mapped prior: the prior's action (the declared actuated joints)",
             static_cast<long>(joints.actuated.size()), inner_->action_dim());
  if (joints.state_from_joints.size() != 0) {
    from_joints_t_ = joints.state_from_joints.transpose();
    to_joints_t_ = joints.state_from_joints.inverse().transpose();
  }
  limit_ = joints.action_limit;
}

void JointMappedPrior::evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                                Eigen::Ref<VectorXd> dx) const {
  // Per-thread buffers: a run calls this at every step (resized, not reallocated).
  thread_local MatrixXd X, U, dX;
  X = x.transpose();
  U = u.transpose();
  evaluate_batch(X, U, phi, dX);
  dx = dX.row(0).transpose();
}

void JointMappedPrior::evaluate_batch(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                                      MatrixXd& dX) const {
  check_size("joint-mapped prior: X's columns", inner_->state_dim(), X.cols());
  check_size("joint-mapped prior: U's columns", inner_->action_dim(), U.cols());
  const MatrixXd* Xq = &X;
  const MatrixXd* Uq = &U;
  // Per-thread buffers (a run calls this at every step of every rollout); the inner prior does
  // not call back into a JointMappedPrior, so they are never in use twice on one thread.
  thread_local MatrixXd Xj, Uc, dXj;
  if (to_joints_t_.size() != 0) {
    // Coefficient-wise products: the mapping is 2n x 2n (n: a robot's joints); a BLAS call
    // (EIGEN_USE_BLAS) costs microseconds per call on one state, more than the product.
    Xj.noalias() = X.lazyProduct(to_joints_t_);
    Xq = &Xj;
  }
  if (limit_.size() != 0) {
    Uc = U;
    for (Eigen::Index a = 0; a < Uc.cols(); ++a)
      Uc.col(a) = Uc.col(a).cwiseMax(-limit_[a]).cwiseMin(limit_[a]);
    Uq = &Uc;
  }
  if (from_joints_t_.size() == 0) {
    inner_->evaluate_batch(*Xq, *Uq, phi, dX);
    return;
  }
  inner_->evaluate_batch(*Xq, *Uq, phi, dXj);
  dX.noalias() = dXj.lazyProduct(from_joints_t_);
}

std::unique_ptr<model::MeanFunction> JointMappedPrior::clone() const {
  auto copy = std::make_unique<JointMappedPrior>(*this);
  copy->inner_ = inner_->clone();
  return copy;
}

}  // namespace drops::experiment
