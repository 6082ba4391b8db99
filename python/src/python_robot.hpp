#pragma once
// A robot defined in Python (drops.Task, drops.System, drops.Prior; python/drops/robot.py) as a
// drops task plugin: the C++ Task, System and MeanFunction below call the Python objects, taking
// the interpreter lock once per call. The batched callbacks (Task.observe, Task.reward,
// Prior.evaluate) receive a whole batch of rollouts at one step, so a generation's rollouts take
// the lock once per batch and step, never per rollout.

#include <pybind11/pybind11.h>

#include <atomic>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "drops/core/errors.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/model/mean_function.hpp"

namespace drops::python {

namespace py = pybind11;

/// "<type name>: <str(exception)>" (or the type alone for an empty message), for messages; an
/// exception whose __str__ raises gives "<type>: <unprintable <type> object: ...>" instead of
/// recursing (pybind11's what() does). Non-UTF-8 text is backslash-escaped. Called with the
/// interpreter lock held; raises nothing.
std::string describe_exception(const py::error_already_set& e);

/// A callback raised a Python exception: thrown through the C++ code (and the run loop, which
/// records the run as failed) while the Python exception itself waits in CallbackErrors.
class CallbackError : public Error {
 public:
  using Error::Error;
};

/// The first Python exception raised by one run's callbacks, so that the run call raises it again
/// with its type and message once the C++ side has unwound; and the first KeyboardInterrupt
/// (Ctrl-C) raised inside a callback that could be called again, which stops the run after its
/// current step instead (as Ctrl-C does on the command line). Thread-safe.
class CallbackErrors {
 public:
  /// Keeps `e` if it is the first and throws CallbackError("<callback> raised <type>: <msg>").
  /// Called with the interpreter lock held.
  [[noreturn]] void raise(py::error_already_set&& e, const std::string& callback);
  /// Moves out the kept exception (empty when no callback raised).
  std::optional<py::error_already_set> take();
  /// Keeps the KeyboardInterrupt `e` (the first) and makes interrupted() true. Called with the
  /// interpreter lock held.
  void interrupt(py::error_already_set&& e);
  /// Whether a callback was interrupted by Ctrl-C: the run should stop after its current step.
  bool interrupted() const { return interrupted_.load(); }
  /// Moves out the kept KeyboardInterrupt (empty when none).
  std::optional<py::error_already_set> take_interrupt();

 private:
  std::mutex mutex_;
  std::optional<py::error_already_set> first_;
  std::optional<py::error_already_set> interrupt_;
  std::atomic<bool> interrupted_{false};
};

/// The task plugin of a robot written in Python. `spec` is the dict drops/robot.py's
/// _robot_spec() builds (name, dimensions, horizon, dt, initial state, policy settings, prior
/// parameters, labels); task, system and prior are the user's objects (prior may be None). Built
/// and destroyed with the interpreter lock held; the objects it makes (Task, System, prior) hold
/// borrowed references, so the plugin must outlive the experiment built from it. make() and the
/// callbacks of what it builds take the lock themselves and may be called from any thread.
std::unique_ptr<experiment::TaskPlugin> make_python_task_plugin(
    const py::dict& spec, py::object task, py::object system, py::object prior,
    std::shared_ptr<CallbackErrors> errors);

/// Adds drops._drops._DescriptionPrior (python/src/description.cpp; nothing when drops is built
/// without MuJoCo). Called once from the module's initialisation.
void bind_description(py::module_& m);

/// A copy of the C++ prior held by the Python object `obj` (a _DescriptionPrior), or nullptr for
/// None: the prior a run of a Python task uses directly, without a Python callback. Throws
/// pybind11's cast_error for another type. Called with the interpreter lock held.
std::shared_ptr<const model::MeanFunction> native_prior(py::handle obj);

}  // namespace drops::python
