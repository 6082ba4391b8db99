#pragma once
/// \file The configuration side of a robot's description file (URDF or MJCF) as the simulator prior
/// (issue 64): the keys prior.model, prior.parameters, prior.substeps and prior.coulomb_velocity,
/// their one reader (description_prior_spec(), also used by `drops identify`), the declaration
/// by which a task maps its state and action onto the file's joints, and the building of the
/// prior through a factory that the application registers (Registry::
/// set_description_prior_factory). drops::experiment names no physics engine: the factory is
/// drops::description's DescriptionPrior (MuJoCo) in the `drops` program and the Python module
/// when they are built with MuJoCo.
///
/// The grammar, in a `drops run` configuration (docs/your-own-robot.md):
///
///     prior:
///       model: robot.xml             # a URDF or an MJCF file
///       parameters:                  # phi, in this order
///         - {name: Link1.mass, bounds: [0.05, 1], value: 0.65}   # value: default the file's
///         - {name: Link2.com.z, bounds: [0.025, 0.5]}
///         - {name: Joint1.damping, tunable: false}               # fixed: no bounds needed
///       substeps: 5                  # optional: RK4 steps per control period
///       coulomb_velocity: 0.01       # optional: rad/s, the smooth Coulomb friction's scale

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drops/core/types.hpp"
#include "drops/experiment/config.hpp"
#include "drops/model/mean_function.hpp"

namespace drops::experiment {

/// How a task's state and action map onto the joints of a description file, declared by a task
/// that offers a description-file prior (TaskSetup::joints). The prior's own state is
/// [q, qd] (dim 2n: the joints' positions, rad or m, then their velocities), its action the
/// actuated joints' torques (N m or N).
struct JointDeclaration {
  /// The joints of q, in order (dim n), names as in the file; every joint that moves.
  std::vector<std::string> joints;
  /// The joints the action drives, in the order of u (dim U, the task's action_dim).
  std::vector<std::string> actuated;
  /// The task's state from the joints': x = state_from_joints * [q; qd] (E x 2n, E = 2n,
  /// invertible), e.g. a permutation, or absolute angles from relative joint angles. Empty: the
  /// identity (the task's state is [q, qd]).
  MatrixXd state_from_joints;
  /// The prior clips u_i to [-action_limit_i, action_limit_i] (dim U) as the task's system does;
  /// empty: no clip.
  VectorXd action_limit;
  /// RK4 substeps per control period when prior.substeps is empty (0: dt / 1 ms, rounded up).
  int substeps = 0;
  /// True when the sizes agree (joints and actuated not empty, state_from_joints square of
  /// 2 x joints or empty, action_limit of actuated's size with entries > 0 or empty, substeps
  /// >= 0); else false and the reason in *why.
  bool IsValid(std::string* why) const;
};

/// What the factory is asked to load: DescriptionPriorOptions of drops::description.
struct DescriptionPriorRequest {
  std::string file;                     ///< the description file (a resolved path)
  std::vector<std::string> joints;      ///< JointDeclaration::joints
  std::vector<std::string> actuated;    ///< JointDeclaration::actuated
  std::vector<std::string> parameters;  ///< phi's names, in order (dim P)
  double dt = 0.01;                     ///< control period, s
  int substeps = 10;                    ///< RK4 steps per dt (>= 1)
  double coulomb_velocity = 0.01;       ///< the smooth Coulomb friction's velocity scale
};

/// What the factory returns: the prior on the joints' state [q, qd] and action (torques), and
/// the file's values of the requested parameters (dim P).
struct DescriptionPriorModel {
  std::shared_ptr<const model::MeanFunction> prior;
  VectorXd file_values;
  /// The joints of the prior's state and action, in order (names as in the file): the request's,
  /// or the file's when the request left them empty. Empty when the factory does not say.
  std::vector<std::string> joints, actuated;
};

/// Loads a description file as a prior. Throws InvalidArgument with a message naming the file
/// and the item (a joint, body or parameter name not in the file lists the names it has).
using DescriptionPriorFactory =
    std::function<DescriptionPriorModel(const DescriptionPriorRequest&)>;

/// One entry of prior.parameters.
struct DescriptionParameter {
  std::string name;                             ///< e.g. "Link1.mass", "Joint1.damping", "gravity"
  std::optional<double> value;                  ///< the starting value (empty: the file's)
  bool tunable = true;                          ///< whether GP-MI and MI may tune it
  std::optional<std::array<double, 2>> bounds;  ///< [lower, upper], required when tunable
};

/// The description-file prior of a configuration: what description_prior_spec() reads.
struct DescriptionPriorSpec {
  std::string file;                              ///< prior.model, as resolved by load_settings_file
  std::string sha256;                            ///< SHA-256 of the file's bytes (64 hex digits)
  std::vector<DescriptionParameter> parameters;  ///< prior.parameters, in order
  std::optional<int> substeps;                   ///< prior.substeps (empty: the task's)
  std::optional<double> coulomb_velocity;        ///< prior.coulomb_velocity (empty: 0.01)
};

/// The keys of the description-file prior, for a task that offers one to include in its keys():
/// prior.model (type "path": a relative path is looked for in the configuration file's
/// directory, then in the working directory; load_settings_file), prior.parameters (type "list"),
/// prior.substeps and prior.coulomb_velocity (optional). Thread-safe.
std::vector<KeySpec> description_prior_keys();

/// Whether settings choose a description-file prior (prior.model is a key of their schema and
/// not empty). Thread-safe.
bool uses_description_prior(const Settings& settings);
/// The prior's label in run names and report panels: the file's name, e.g. "robot.urdf".
/// Thread-safe.
std::string description_prior_label(const Settings& settings);

/// Reads the description-file prior's keys of validated settings (uses_description_prior()
/// true). Throws ConfigError naming the key and the entry: a file that cannot be read, an entry
/// of prior.parameters that is not a mapping, lacks its name, names a parameter twice, has an
/// unknown field (the message lists name, bounds, value, tunable), a tunable entry without
/// bounds, bounds that are not [lower, upper] with lower < upper, a value outside them.
/// Engine-free: the names are checked against the file by make_description_prior(). Thread-safe.
DescriptionPriorSpec description_prior_spec(const Settings& settings);

/// The entries of prior.parameters alone, checked as description_prior_spec() checks them,
/// without reading the file (e.g. for reports). Throws ConfigError as description_prior_spec().
/// Thread-safe.
std::vector<DescriptionParameter> description_prior_parameters(const Settings& settings);

/// The built prior: the task's state and action mapped onto the file's joints, its starting phi,
/// tunable set and bounds, and what the run records (TaskSetup::declaration).
struct DescriptionPriorSetup {
  std::shared_ptr<const model::MeanFunction> prior;  ///< on the task's x (dim E) and u (dim U)
  model::PriorParameters parameters;
  /// "prior.model" (the file), "prior.model.sha256" (its bytes' digest): a resume with another
  /// file's content is refused.
  std::map<std::string, std::string> declaration;
};

/// Builds the prior of `spec` for a task of control period dt (s) that declared `joints`, with
/// `factory`. Before anything runs it checks every starting value with the prior's check_phi,
/// and every bound: each tunable parameter at its lower and at its upper bound (the others at
/// their values), then every corner of the box when at most 10 parameters are tunable, so that a
/// bound that makes a mass or an inertia non-physical is refused. Throws ConfigError naming the
/// file and the item: no factory (a build without MuJoCo), an invalid declaration, the factory's
/// error (unknown names list the file's), a value or a bound outside the prior's domain.
/// Thread-safe.
DescriptionPriorSetup make_description_prior(const DescriptionPriorFactory& factory,
                                             const DescriptionPriorSpec& spec,
                                             const JointDeclaration& joints, double dt);

/// A prior on the joints' state [q, qd] and torques seen through a JointDeclaration: x -> [q, qd]
/// = S^-1 x, u clipped to the declared limits, dx = S dx_joints (S = state_from_joints). The
/// names, check_phi and phi are the inner prior's. Thread-safe as the inner prior.
class JointMappedPrior final : public model::MeanFunction {
 public:
  /// inner: state dim 2n, action dim U. Throws InvalidArgument when the declaration is invalid
  /// (JointDeclaration::IsValid) or disagrees with inner's dimensions.
  JointMappedPrior(std::shared_ptr<const model::MeanFunction> inner,
                   const JointDeclaration& joints);
  int state_dim() const override { return inner_->state_dim(); }
  int action_dim() const override { return inner_->action_dim(); }
  std::vector<std::string> parameter_names() const override { return inner_->parameter_names(); }
  void check_phi(const VectorXd& phi) const override { inner_->check_phi(phi); }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override;
  void evaluate_batch(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                      MatrixXd& dX) const override;
  std::unique_ptr<model::MeanFunction> clone() const override;

 private:
  std::shared_ptr<const model::MeanFunction> inner_;
  MatrixXd to_joints_t_, from_joints_t_;  // transposed S^-1 and S (empty: identity)
  VectorXd limit_;                        // empty: no clip
};

}  // namespace drops::experiment
