// A robot defined in Python as a drops task plugin (python_robot.hpp).
#include "python_robot.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cmath>
#include <map>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

#include "drops/core/problem.hpp"
#include "drops/experiment/experiment.hpp"
#include "drops/model/mean_function.hpp"
#include "drops/policy/policy.hpp"

namespace drops::python {
namespace {

namespace ex = drops::experiment;
using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Row-major copies for Python.
Array to_array(const MatrixXd& m) {
  Array a({static_cast<py::ssize_t>(m.rows()), static_cast<py::ssize_t>(m.cols())});
  auto am = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) am(i, j) = m(i, j);
  return a;
}

Array to_array(const VectorXd& v) {
  Array a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

std::string shape_text(const std::vector<py::ssize_t>& shape) {
  std::string s = "(";
  for (std::size_t i = 0; i < shape.size(); ++i) s += (i ? ", " : "") + std::to_string(shape[i]);
  return s + (shape.size() == 1 ? ",)" : ")");
}

// `obj` as an array of exactly `shape`; InvalidArgument naming the callback, the expected and the
// received shape otherwise. `meaning` says what the axes are.
Array checked(py::handle obj, const std::string& callback, const std::vector<py::ssize_t>& shape,
              const std::string& meaning) {
  Array a;
  try {
    a = Array::ensure(obj);
  } catch (py::error_already_set&) {
  }
  if (!a) {
    PyErr_Clear();
    throw InvalidArgument(callback + " returned " + std::string(py::str(py::type::of(obj))) +
                          ", expected a float array of shape " + shape_text(shape) + " (" +
                          meaning + ")");
  }
  std::vector<py::ssize_t> got(a.shape(), a.shape() + a.ndim());
  if (got != shape)
    throw InvalidArgument(callback + " returned an array of shape " + shape_text(got) +
                          ", expected " + shape_text(shape) + " (" + meaning + ")");
  return a;
}

MatrixXd matrix_of(const Array& a) {
  auto r = a.unchecked<2>();
  MatrixXd m(r.shape(0), r.shape(1));
  for (py::ssize_t i = 0; i < r.shape(0); ++i)
    for (py::ssize_t j = 0; j < r.shape(1); ++j) m(i, j) = r(i, j);
  return m;
}

VectorXd vector_of(const Array& a) {
  VectorXd v(a.size());
  std::copy(a.data(), a.data() + a.size(), v.data());
  return v;
}

// The largest reward magnitude a Task.reward may return: an episode's return (a sum of at most a
// few thousand rewards) and the mean over rollouts stay finite (docs/python.md, "What drops
// refuses").
constexpr double kMaxRewardMagnitude = 1e100;

// Task.observe and Task.reward must give finite values for finite states (the model and the
// policy cannot use anything else).
void require_finite(const MatrixXd& m, const MatrixXd& X, const std::string& callback) {
  for (Eigen::Index b = 0; b < m.rows(); ++b)
    if (!m.row(b).allFinite()) {
      std::ostringstream o;
      o << callback << " returned a non-finite value in row " << b << " (for the state x = ["
        << X.row(b) << "]); it must be finite for every finite state";
      throw InvalidArgument(o.str());
    }
}

// Calls f() with the interpreter lock held; a Python exception is kept in `errors` and thrown on
// as CallbackError. Ctrl-C inside a call that has no side effects (`repeatable`: the task's and
// the prior's callbacks, System.step(x, u)) does not fail the run: Python has handled the signal
// by raising KeyboardInterrupt in the callback, so the interrupt is kept, the call is made again
// and the run stops after its current step (errors.interrupted()), as on the command line. A
// second Ctrl-C in the same call, or one inside a physical robot's session step (which may have
// moved the robot), fails the run like any exception; finished episodes stay on disk either way.
template <class F>
auto with_python(CallbackErrors& errors, const std::string& callback, F&& f,
                 bool repeatable = true) {
  py::gil_scoped_acquire gil;
  try {
    return f();
  } catch (py::error_already_set& e) {
    if (!repeatable || !e.matches(PyExc_KeyboardInterrupt)) errors.raise(std::move(e), callback);
    errors.interrupt(std::move(e));
  }
  try {
    return f();
  } catch (py::error_already_set& e) {
    errors.raise(std::move(e), callback);
  }
}

struct Spec {
  std::string name, description, prior_label, task_class, prior_class;
  std::map<std::string, std::string> declaration;  // TaskSetup::declaration
  std::vector<std::string> state_names, action_names, state_units, action_units;
  int E = 0, A = 0, O = 0, horizon = 0, hidden_units = 10;
  double dt = 0, max_action = 1;
  VectorXd x0, observation_scale;
  std::vector<std::string> phi_names, phi_units;
  VectorXd phi_values, phi_lower, phi_upper;
  std::vector<bool> phi_tunable;
  std::vector<double> phi_actual;
  bool has_check_phi = false;
  // A drops.DescriptionPrior's C++ prior (built for the task's dt), used by the run directly.
  std::shared_ptr<const model::MeanFunction> native_prior;
  std::optional<Reflection> reflection;  // Task.reflection, checked by drops.robot
  std::optional<Goal> goal;              // Task.goal, checked by drops.robot and Goal::check
};

VectorXd vector_from(py::handle h) {
  const auto v = h.cast<std::vector<double>>();
  return Eigen::Map<const VectorXd>(v.data(), static_cast<Eigen::Index>(v.size()));
}

Spec read_spec(const py::dict& d) {
  Spec s;
  s.name = d["name"].cast<std::string>();
  s.description = d["description"].cast<std::string>();
  s.task_class = d["task_class"].cast<std::string>();
  s.prior_class = d["prior_class"].cast<std::string>();
  s.declaration = d["declaration"].cast<std::map<std::string, std::string>>();
  s.prior_label = d["prior_label"].cast<std::string>();
  s.state_names = d["state_names"].cast<std::vector<std::string>>();
  s.action_names = d["action_names"].cast<std::vector<std::string>>();
  s.state_units = d["state_units"].cast<std::vector<std::string>>();
  s.action_units = d["action_units"].cast<std::vector<std::string>>();
  s.E = static_cast<int>(s.state_names.size());
  s.A = static_cast<int>(s.action_names.size());
  s.O = d["observation_dim"].cast<int>();
  s.horizon = d["horizon"].cast<int>();
  s.dt = d["dt"].cast<double>();
  s.x0 = vector_from(d["initial_state"]);
  s.max_action = d["max_action"].cast<double>();
  s.observation_scale = vector_from(d["observation_scale"]);
  s.hidden_units = d["hidden_units"].cast<int>();
  s.phi_names = d["phi_names"].cast<std::vector<std::string>>();
  s.phi_units = d["phi_units"].cast<std::vector<std::string>>();
  s.phi_values = vector_from(d["phi_values"]);
  s.phi_lower = vector_from(d["phi_lower"]);
  s.phi_upper = vector_from(d["phi_upper"]);
  s.phi_tunable = d["phi_tunable"].cast<std::vector<bool>>();
  s.phi_actual = d["phi_actual"].cast<std::vector<double>>();
  s.has_check_phi = d["has_check_phi"].cast<bool>();
  if (d.contains("native_prior")) s.native_prior = native_prior(d["native_prior"]);
  if (const py::handle r = d["reflection"]; !r.is_none()) {
    const auto rd = py::reinterpret_borrow<py::dict>(r);
    s.reflection = Reflection{vector_from(rd["state_sign"]), vector_from(rd["state_offset"]),
                              vector_from(rd["action_sign"])};
  }
  if (const py::handle g = d["goal"]; !g.is_none()) {
    const auto gd = py::reinterpret_borrow<py::dict>(g);
    s.goal = Goal{vector_from(gd["state"]), vector_from(gd["action"]),
                  vector_from(gd["action_limit"]), gd["angles"].cast<std::vector<int>>()};
    s.goal->check(s.E, s.A);
  }
  return s;
}

// The Python objects' methods (borrowed from the plugin, which owns them).
struct Callbacks {
  py::handle observe, reward, solved, begin_episode, evaluate, check_phi;
  py::handle step_session_type;  // drops.robot._StepSession, the session of System.step(x, u)
  std::shared_ptr<CallbackErrors> errors;
};

class PyTask final : public Task {
 public:
  PyTask(const Spec& s, Callbacks c) : s_(s), c_(std::move(c)) {}
  std::string name() const override { return s_.name; }
  int state_dim() const override { return s_.E; }
  int action_dim() const override { return s_.A; }
  int observation_dim() const override { return s_.O; }
  int horizon() const override { return s_.horizon; }
  double dt() const override { return s_.dt; }
  VectorXd initial_state() const override { return s_.x0; }
  void observe(const VectorXd& x, Eigen::Ref<VectorXd> obs) const override {
    MatrixXd o;
    observe_batch(x.transpose(), o);
    obs = o.row(0).transpose();
  }
  double reward(const VectorXd& x) const override {
    VectorXd r;
    reward_batch(x.transpose(), r);
    return r[0];
  }
  void observe_batch(const MatrixXd& X, MatrixXd& obs) const override {
    const std::string cb = s_.task_class + ".observe";
    obs = with_python(*c_.errors, cb, [&] {
      const py::object r = c_.observe(to_array(X));
      return matrix_of(checked(r, cb, {X.rows(), s_.O},
                               "B = " + std::to_string(X.rows()) +
                                   " states x O = " + std::to_string(s_.O) + " observations"));
    });
    require_finite(obs, X, cb);
  }
  void reward_batch(const MatrixXd& X, VectorXd& r) const override {
    const std::string cb = s_.task_class + ".reward";
    r = with_python(*c_.errors, cb, [&] {
      const py::object v = c_.reward(to_array(X));
      return vector_of(
          checked(v, cb, {X.rows()}, "one reward per state: B = " + std::to_string(X.rows())));
    });
    require_finite(r, X, cb);
    for (Eigen::Index b = 0; b < r.size(); ++b)
      if (std::abs(r[b]) > kMaxRewardMagnitude) {
        std::ostringstream o;
        o << cb << " returned " << r[b] << " in row " << b << " (for the state x = [" << X.row(b)
          << "]); a reward's magnitude must be at most 1e100, so that returns "
          << "(sums of rewards) stay finite";
        throw InvalidArgument(o.str());
      }
  }
  std::optional<Reflection> reflection() const override { return s_.reflection; }
  std::optional<Goal> goal() const override { return s_.goal; }
  bool solved(const Trajectory& tr) const override {
    return with_python(*c_.errors, s_.task_class + ".solved", [&] {
      return py::bool_(c_.solved(to_array(tr.states), to_array(tr.actions), to_array(tr.rewards)))
          .cast<bool>();
    });
  }

 private:
  Spec s_;
  Callbacks c_;
};

// One episode's session object (the Python System.begin_episode's result), released with the
// interpreter lock held.
class PySession final : public EpisodeSession {
 public:
  // Called with the interpreter lock held.
  PySession(py::object session, int E, const Callbacks& c)
      : session_(std::move(session)),
        E_(E),
        c_(c),
        repeatable_(py::isinstance(session_, c.step_session_type)) {}
  ~PySession() override {
    py::gil_scoped_acquire gil;
    session_ = py::object();
  }
  VectorXd step(const VectorXd& u, Rng&) override {
    const std::string cb = "the session's step (System.begin_episode(x0).step(u))";
    return with_python(
        *c_.errors, cb,
        [&] {
          const py::object r = session_.attr("step")(to_array(u));
          return vector_of(checked(r, cb, {E_}, "the next state: E = " + std::to_string(E_)));
        },
        repeatable_);
  }

 private:
  py::object session_;
  int E_;
  Callbacks c_;
  // The default session (drops.System.step(x, u)): a step can be made again (no side effect).
  bool repeatable_;
};

class PySystem final : public System {
 public:
  PySystem(int E, Callbacks c) : E_(E), c_(std::move(c)) {}
  VectorXd step(const VectorXd& x, const VectorXd& u, Rng& rng) const override {
    return begin_episode(x)->step(u, rng);
  }
  std::unique_ptr<EpisodeSession> begin_episode(const VectorXd& x0) const override {
    py::object session = begin(x0);
    py::gil_scoped_acquire gil;
    return std::make_unique<PySession>(std::move(session), E_, c_);
  }

 private:
  py::object begin(const VectorXd& x0) const {
    return with_python(*c_.errors, "System.begin_episode",
                       [&] { return c_.begin_episode(to_array(x0)); });
  }
  int E_;
  Callbacks c_;
};

class PyPrior final : public model::MeanFunction {
 public:
  PyPrior(const Spec& s, Callbacks c) : s_(s), c_(std::move(c)) {}
  int state_dim() const override { return s_.E; }
  int action_dim() const override { return s_.A; }
  std::vector<std::string> parameter_names() const override { return s_.phi_names; }
  void check_phi(const VectorXd& phi) const override {
    check_size("Prior: phi", static_cast<long>(s_.phi_names.size()), phi.size());
    if (!s_.has_check_phi) return;
    const std::string cb = s_.prior_class + ".check_phi";
    with_python(*c_.errors, cb, [&] {
      try {
        c_.check_phi(to_array(phi));
      } catch (py::error_already_set& e) {
        // ValueError: phi outside the simulator's domain (GP-MI scores it -inf and moves on).
        if (e.matches(PyExc_ValueError)) {
          std::ostringstream o;
          o << cb << " refused phi = [" << phi.transpose() << "]: " << describe_exception(e);
          throw InvalidArgument(o.str());
        }
        throw;
      }
    });
  }
  void evaluate(const VectorXd& x, const VectorXd& u, const VectorXd& phi,
                Eigen::Ref<VectorXd> dx) const override {
    MatrixXd dX;
    evaluate_batch(x.transpose(), u.transpose(), phi, dX);
    dx = dX.row(0).transpose();
  }
  void evaluate_batch(const MatrixXd& X, const MatrixXd& U, const VectorXd& phi,
                      MatrixXd& dX) const override {
    const std::string cb = "Prior.evaluate";
    // Non-finite rows are kept: the library counts them (the model's non-finite prior outputs)
    // and GP-MI rejects the phi that produced them, as for a C++ prior.
    dX = with_python(*c_.errors, cb, [&] {
      const py::object r = c_.evaluate(to_array(X), to_array(U), to_array(phi));
      return matrix_of(checked(r, cb, {X.rows(), s_.E},
                               "B = " + std::to_string(X.rows()) +
                                   " states x E = " + std::to_string(s_.E) + " state differences"));
    });
  }
  std::unique_ptr<model::MeanFunction> clone() const override {
    return std::make_unique<PyPrior>(*this);
  }

 private:
  Spec s_;
  Callbacks c_;
};

class PyTaskPlugin final : public ex::TaskPlugin {
 public:
  PyTaskPlugin(const py::dict& spec, py::object task, py::object system, py::object prior,
               std::shared_ptr<CallbackErrors> errors)
      : s_(read_spec(spec)),
        task_(std::move(task)),
        system_(std::move(system)),
        prior_(std::move(prior)) {
    // The bound methods, owned here (the Task, System and prior borrow them).
    for (const char* m : {"observe", "reward", "solved"}) owned_.push_back(task_.attr(m));
    owned_.push_back(system_.attr("begin_episode"));
    c_.observe = owned_[0];
    c_.reward = owned_[1];
    c_.solved = owned_[2];
    c_.begin_episode = owned_[3];
    owned_.push_back(py::module_::import("drops.robot").attr("_StepSession"));
    c_.step_session_type = owned_.back();
    if (!prior_.is_none()) {
      owned_.push_back(prior_.attr("evaluate"));
      c_.evaluate = owned_.back();
      owned_.push_back(prior_.attr("check_phi"));
      c_.check_phi = owned_.back();
    }
    c_.errors = std::move(errors);
  }
  std::string name() const override { return s_.name; }
  std::string description() const override { return s_.description; }
  // A generation's rollouts in one call per step (a CMA-ES generation of the policy search has
  // tens of candidates): a third of the calls of the library's 8, the same episodes
  // (docs/benchmarks.md, "A prior in Python").
  // Variances from a subset of 400 transitions once there are more, as the pendubot's: the
  // exact variance costs O(N^2) per prediction, so a policy search's time grew faster than the
  // data (docs/decisions/pendubot-variance-points.md; docs/python.md, "What a run costs").
  std::map<std::string, std::string> shared_defaults() const override {
    return {{"rollouts.batch", "64"}, {"model.variance_points", "400"}};
  }
  std::vector<ex::KeySpec> keys() const override {
    policy::NeuralNetPolicyOptions defaults;
    defaults.hidden_units = s_.hidden_units;  // the robot's own default
    return ex::neural_net_policy_key_table().specs(defaults);
  }
  ex::TaskSetup make(const ex::Settings& st) const override {
    ex::TaskSetup s;
    s.task = std::make_shared<PyTask>(s_, c_);
    s.real = std::make_unique<PySystem>(s_.E, c_);
    policy::NeuralNetPolicyOptions po;
    ex::neural_net_policy_key_table().apply(st, po);  // policy.hidden_units
    po.observation_dim = s_.O;
    po.action_dim = s_.A;
    po.input_scale = s_.observation_scale;
    po.max_action = s_.max_action;
    s.policy = std::make_unique<policy::NeuralNetPolicy>(po);
    if (!prior_.is_none()) {
      // A drops.DescriptionPrior: its C++ prior, called on every thread without the interpreter
      // lock; any other drops.Prior: its Python evaluate, once per batch.
      if (s_.native_prior)
        s.prior = std::shared_ptr<model::MeanFunction>(s_.native_prior->clone());
      else
        s.prior = std::make_shared<PyPrior>(s_, c_);
      auto& p = s.prior_parameters;
      p.names = s_.phi_names;
      p.values = s_.phi_values;
      std::vector<double> lo, hi;
      for (std::size_t i = 0; i < s_.phi_tunable.size(); ++i)
        if (s_.phi_tunable[i]) {
          p.tunable.push_back(static_cast<int>(i));
          lo.push_back(s_.phi_lower[static_cast<Eigen::Index>(i)]);
          hi.push_back(s_.phi_upper[static_cast<Eigen::Index>(i)]);
        }
      p.lower = Eigen::Map<const VectorXd>(lo.data(), static_cast<Eigen::Index>(lo.size()));
      p.upper = Eigen::Map<const VectorXd>(hi.data(), static_cast<Eigen::Index>(hi.size()));
      p.choices.assign(p.tunable.size(), {});
      s.phi_actual = s_.phi_actual;
    }
    s.prior_label = s_.prior_label;
    s.declaration = s_.declaration;
    s.state_names = s_.state_names;
    s.action_names = s_.action_names;
    return s;
  }
  std::string prior_label(const ex::Settings&) const override { return s_.prior_label; }
  ex::ReportInfo report_info(const ex::Settings&) const override {
    ex::ReportInfo r;
    r.panel.label = s_.prior_label;
    for (std::size_t i = 0; i < s_.phi_names.size(); ++i) {
      if (s_.phi_tunable[i]) r.phi_tunable.push_back(s_.phi_names[i]);
      r.phi_labels[s_.phi_names[i]] = {s_.phi_names[i], s_.phi_units[i]};
    }
    for (std::size_t i = 0; i < s_.state_names.size(); ++i)
      r.column_labels[s_.state_names[i]] = {s_.state_names[i], s_.state_units[i]};
    for (std::size_t i = 0; i < s_.action_names.size(); ++i)
      r.column_labels[s_.action_names[i]] = {s_.action_names[i], s_.action_units[i]};
    return r;
  }

 private:
  Spec s_;
  py::object task_, system_, prior_;
  std::vector<py::object> owned_;
  Callbacks c_;
};

}  // namespace

std::string describe_exception(const py::error_already_set& e) {
  // Never e.what(): pybind11 formats an exception whose __str__ raises by formatting the new
  // exception, which recurses until the stack overflows when it is of the same type.
  std::string type = "an exception";
  if (PyObject* t = e.type().ptr(); t && PyType_Check(t))
    type = reinterpret_cast<PyTypeObject*>(t)->tp_name;
  const std::string unprintable = "<unprintable " + type + " object: its __str__ raised>";
  PyObject* text = PyObject_Str(e.value().ptr());
  if (text == nullptr) {
    PyErr_Clear();
    return type + ": " + unprintable;
  }
  PyObject* bytes = PyUnicode_AsEncodedString(text, "utf-8", "backslashreplace");
  Py_DECREF(text);
  if (bytes == nullptr) {
    PyErr_Clear();
    return type + ": " + unprintable;
  }
  std::string message(PyBytes_AS_STRING(bytes), static_cast<std::size_t>(PyBytes_GET_SIZE(bytes)));
  Py_DECREF(bytes);
  return message.empty() ? type : type + ": " + message;
}

void CallbackErrors::raise(py::error_already_set&& e, const std::string& callback) {
  const std::string message = callback + " raised " + describe_exception(e);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!first_) first_.emplace(std::move(e));
  }
  throw CallbackError(message);
}

void CallbackErrors::interrupt(py::error_already_set&& e) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!interrupt_) interrupt_.emplace(std::move(e));
  interrupted_ = true;
}

std::optional<py::error_already_set> CallbackErrors::take_interrupt() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<py::error_already_set> e = std::move(interrupt_);
  interrupt_.reset();
  return e;
}

std::optional<py::error_already_set> CallbackErrors::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::optional<py::error_already_set> e = std::move(first_);
  first_.reset();
  return e;
}

std::unique_ptr<ex::TaskPlugin> make_python_task_plugin(const py::dict& spec, py::object task,
                                                        py::object system, py::object prior,
                                                        std::shared_ptr<CallbackErrors> errors) {
  return std::make_unique<PyTaskPlugin>(spec, std::move(task), std::move(system), std::move(prior),
                                        std::move(errors));
}

}  // namespace drops::python
