#pragma once
/// \file A robot's description file (URDF or MJCF) as the simulator prior M(x, u; phi) of GP-MI,
/// its physical parameters as named phi (issue 64; the engine: MuJoCo 2.2,
/// docs/decisions/description-file-engine.md). The only place of drops, with bench/, that includes
/// MuJoCo; this header does not, so users of drops::description need not have its headers.
///
/// The model: the file's rigid bodies on hinge and slide joints, loaded by MuJoCo, with
///   M(q) qdd + c(q, qd) + g(q) = gear .* u - b .* qd - f_c .* tanh(qd / v_s)   (+ the file's
///   springs)
/// (M includes the armature on its diagonal). Joint limits, contacts and MuJoCo's actuators are
/// off: the action is the driven joints' torques times their gear, nothing else acts. Coulomb
/// friction is the smooth torque above, applied by drops through MuJoCo's qfrc_applied (the file's
/// `friction` / `frictionloss` is its start value f_c); viscous damping b is MuJoCo's dof_damping,
/// explicit in mj_forward.
///
/// Integration: one control period dt is `substeps` steps of classical RK4 of h = dt / substeps,
/// each stage's accelerations from MuJoCo's forward dynamics (4 per substep), u held over the
/// period. A model where no constraint can arise (no equality constraint, no limited tendon and
/// no tendon friction loss: the prior turns the rest off) runs only the smooth pieces of
/// mj_forward per stage (kinematics, composite inertia and its factor, tendons, velocity terms,
/// M^-1 times the forces: the same arithmetic, the same qacc), other models the whole
/// mj_forward. Defaults: dt = 0.01 s, 10 substeps of 1 ms (the engine study measured 35-61 us
/// per such period on the double pendulum with mj_forward, and agreement with the analytic
/// model to 2e-12 rad over 2 s; docs/benchmarks.md, "Description-file prior", for the pendubot).

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "drops/core/types.hpp"
#include "drops/model/mean_function.hpp"

namespace drops::description {

namespace detail {
struct PriorModel;    // the file's model, shared by copies and never written after loading
class WorkspacePool;  // per-call workspaces: an mjModel copy and an mjData each
}  // namespace detail

/// What DescriptionPrior loads and how it integrates. Every field has its default in-class.
struct DescriptionPriorOptions {
  /// The robot's description file: a URDF (the root element is <robot>) or an MJCF (<mujoco>).
  /// A URDF is read by drops and handed to MuJoCo from memory: its <collision> and <visual>
  /// elements are dropped (the prior needs neither: contacts are off, the links' <inertial> give
  /// the masses), an undeclared `world` link that a joint names as parent is declared, and links
  /// fixed to their parent stay bodies of their own (MuJoCo's fusestatic off), so each link's
  /// phi is the file's <inertial> of that link (MuJoCo would otherwise fuse the DFKI file's
  /// massless `Weight` into `Link2` and `base_link` into the world, and their names would be
  /// gone). An MJCF is loaded from its path as written (includes and meshes relative to it); one
  /// that sets <compiler fusestatic="true"/> has its fused bodies' names no more, and an unknown
  /// name's error lists the bodies left.
  std::string file;
  /// The joints of the state, in this order (hinge or slide joints; names as in the file). Empty:
  /// every joint of the model in the model's order (depth-first through the kinematic tree, for a
  /// chain the order from the base). Must name every joint that moves: a joint left out would have
  /// no state.
  std::vector<std::string> joints;
  /// The joints the action drives, in the order of u (a subset of the model's joints). Empty:
  /// the state's joints. An underactuated robot (the pendubot: only Joint1) lists its motors.
  std::vector<std::string> actuated;
  /// The phi of parameter_names(), in this order: `<body>.mass` (kg, >= 0), `<body>.com.x|y|z`
  /// (m, the centre of mass in the body's frame: a URDF link's frame, the <inertial> origin),
  /// `<body>.inertia` (a scale > 0 of the body's whole rotational inertia, 1 = the file's),
  /// `<joint>.damping` (N m s/rad or N s/m, >= 0), `<joint>.friction` (Coulomb f_c, N m or N,
  /// >= 0), `<joint>.armature` (rotor inertia, kg m^2, >= 0), `<joint>.gear` (torque per unit
  /// of action of a driven joint, 1 = u is the torque), `gravity` (m/s^2, >= 0, the magnitude of
  /// the file's gravity along its direction; MuJoCo's default 9.81 down -z). Empty: no phi.
  std::vector<std::string> parameters;
  /// Control period: dx is the change of the state over dt, s (> 0).
  double dt = 0.01;
  /// RK4 steps per control period (>= 1); the substep is dt / substeps.
  int substeps = 10;
  /// Velocity scale v_s of the smooth Coulomb friction f_c tanh(qd / v_s), rad/s or m/s (> 0).
  /// The study's default. RK4 stays stable while h f_c / (v_s I) is below about 2.8 (I: the
  /// smallest inertia a joint moves): a light joint with friction needs a larger v_s or a
  /// smaller substep.
  double coulomb_velocity = 0.01;
  /// True when every field is valid; else false and, if why is not null, the reason.
  bool IsValid(std::string* why) const;
};

/// The values a parameter of DescriptionPrior may take (its physical domain) and its unit:
/// lower <= value <= upper, lower excluded when lower_open. A mass, damping, friction, armature
/// or gravity: [0, inf); an inertia scale: (0, inf) (a positive scale keeps the file's inertia
/// positive definite and its principal moments a triangle); a centre of mass or a gear: any
/// finite value.
struct ParameterDomain {
  double lower = -std::numeric_limits<double>::infinity();
  bool lower_open = false;
  double upper = std::numeric_limits<double>::infinity();
  /// E.g. "kg", "m", "N m s/rad" (a slide joint's: "N s/m"), "" for a scale.
  std::string unit;
  /// What the parameter is, for messages: "a mass", "an inertia scale", ...
  std::string what;
};

/// A URDF or MJCF file as a model::MeanFunction: state x = [q, qd] (dim 2n: the `joints`'
/// positions, rad or m, then their velocities, in the order of DescriptionPriorOptions::joints;
/// note that tasks/pendubot orders its state velocities first, so a task maps its own order),
/// action u = the `actuated` joints' torques (dim m, N m or N, times their gear), phi = the
/// `parameters` by name (dim P). dx = x(t + dt) - x(t) (angles not wrapped).
///
/// Thread safety: const calls (evaluate, evaluate_batch, joint_accelerations) may run
/// concurrently on one instance: each call leases a workspace (its own mjModel copy, into which
/// the call writes phi unless that workspace holds this phi already, and its own mjData) from
/// the instance's pool, created on first need
/// (mj_copyModel: microseconds; mj_makeData: about 0.1 ms and 13.5 MB of arena) and returned at
/// the end of the call; the file's model itself is shared and never written. clone() gives an
/// independent instance with its own pool and one workspace.
class DescriptionPrior : public model::MeanFunction {
 public:
  /// Loads options.file with MuJoCo. Throws InvalidArgument naming the file when the options are
  /// invalid, the file cannot be read or does not parse (with MuJoCo's message), it has a
  /// floating base (a free joint: a URDF's `floating` joint or an MJCF's <freejoint>) or a
  /// ball joint, a joint or body named in the options or the parameters is not in it (the
  /// message lists the names it has), or a name is not a parameter. Missing mesh files of a
  /// URDF's <visual> and <collision> are no error (the prior uses no geometry): warnings() lists
  /// them. Also installs, once per process and only if none is installed, MuJoCo's fatal-error
  /// hook (mju_user_error, which by default exits the process): an engine error in a later call
  /// is then thrown as a NumericalError naming the file (the workspace of that call is
  /// discarded).
  explicit DescriptionPrior(const DescriptionPriorOptions& options);
  ~DescriptionPrior() override;
  DescriptionPrior(const DescriptionPrior& other);
  DescriptionPrior& operator=(const DescriptionPrior&) = delete;

  /// 2n: the joints' positions then velocities.
  int state_dim() const override;
  /// m: the driven joints.
  int action_dim() const override;
  /// The options' parameters (dim P).
  std::vector<std::string> parameter_names() const override;
  /// Throws InvalidArgument naming the parameter and the file when phi (dim P) has the wrong size
  /// or a value outside its domain (parameter_domain: a negative mass, damping, friction,
  /// armature or gravity, an inertia scale <= 0, anything not finite).
  void check_phi(const VectorXd& phi) const override;
  /// dx = M(x, u; phi): x dim 2n, u dim m, phi dim P (assumed checked), dx dim 2n. Thread-safe.
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override;
  /// Every row of X (B x 2n) and U (B x m) with one workspace, phi written once; dX B x 2n.
  /// Thread-safe.
  void evaluate_batch(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                      MatrixXd& dX) const override;
  std::unique_ptr<model::MeanFunction> clone() const override;

  /// The file's values of parameter_names() (dim P): the start of phi (gear 1).
  VectorXd default_phi() const;
  /// The physical domain and unit of parameter i (0 <= i < P). Throws InvalidArgument for an i
  /// out of range. Thread-safe.
  ParameterDomain parameter_domain(int i) const;
  /// The index of the parameter `name` in parameter_names(), or -1 when it is not one.
  int parameter_index(const std::string& name) const;
  /// Checks search bounds [lower, upper] of parameter i (0 <= i < P) before anything runs:
  /// throws InvalidArgument naming the file, the parameter and its physical domain when a bound
  /// is not finite, lower > upper, or the interval leaves the domain (a lower bound below 0 kg
  /// for a mass, <= 0 for an inertia scale, ...: GP-MI would try non-physical phi). For the
  /// configuration's and Python's prior.parameters entries. Thread-safe.
  void check_bounds(int i, double lower, double upper) const;
  /// What loading found that does not stop the prior (each a sentence naming the file): today
  /// the mesh files a URDF's <visual> or <collision> elements name that do not exist (relative
  /// to the file; `package://` names are not resolved and not listed). The library prints
  /// nothing: the caller shows them (the Python class as a warnings.warn).
  const std::vector<std::string>& warnings() const;
  /// Joint accelerations qdd (dim n, rad/s^2 or m/s^2) at x (dim 2n) under u (dim m) and phi
  /// (dim P, assumed checked): one forward dynamics as a stage of evaluate, the friction and gear
  /// applied. Thread-safe.
  VectorXd joint_accelerations(const VectorXd& x, const VectorXd& u, const VectorXd& phi) const;
  /// The state's joints (dim n), the driven joints (dim m), the model's bodies (the world
  /// excluded): names as in the file.
  const std::vector<std::string>& joint_names() const;
  const std::vector<std::string>& actuated_joint_names() const;
  std::vector<std::string> body_names() const;
  /// Every parameter name the file offers, in the order bodies, joints, gravity.
  std::vector<std::string> available_parameters() const;
  const DescriptionPriorOptions& options() const;

 private:
  // evaluate_batch after its size checks; MuJoCo's errors come out as they are thrown.
  void evaluate_rows(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi, MatrixXd& dX) const;
  std::shared_ptr<const detail::PriorModel> loaded_;
  std::unique_ptr<detail::WorkspacePool> pool_;
};

}  // namespace drops::description
