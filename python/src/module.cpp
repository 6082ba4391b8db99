// drops._drops: the pybind11 extension under the Python package drops (python/drops/__init__.py,
// docs/python.md). It registers the built-in tasks and algorithms as the `drops` program does
// (apps/drops/main.cpp) and exposes drops::experiment: running and resuming an experiment
// (experiment::run_experiment, the run loop of `drops run`), the run-directory reader (read_run,
// read_trajectory_csv, read_policy_csv) with numpy arrays, a robot's recorded logs (read_log) and
// the configuration schema.
// drops's exceptions become Python exceptions of the same names (drops.Error and subclasses).

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cstring>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "drops/core/errors.hpp"
#include "drops/core/parallel.hpp"
#include "drops/experiment/config.hpp"
#include "drops/experiment/identify.hpp"
#include "drops/experiment/recorded_log.hpp"
#include "drops/experiment/registry.hpp"
#include "drops/experiment/run.hpp"
#include "drops/experiment/run_directory.hpp"
#include "drops/pendubot/plugin.hpp"
#include "drops/realaigym/plugin.hpp"
#include "python_robot.hpp"
#ifdef DROPS_WITH_HEXAPOD
#include "drops/hexapod/plugin.hpp"
#endif
#ifdef DROPS_WITH_MUJOCO
#include "drops/description/experiment_factory.hpp"
#endif

namespace py = pybind11;
namespace ex = drops::experiment;

namespace {

// The tasks and algorithms of the `drops` program, registered once when the module is imported.
std::unique_ptr<ex::Registry> g_registry;

const ex::Registry& registry() { return *g_registry; }

void register_builtins(ex::Registry& r) {
  ex::register_builtin_algorithms(r);
  drops::pendubot::register_task(r);  // the default task
  drops::realaigym::register_task(r);
#ifdef DROPS_WITH_HEXAPOD
  drops::hexapod::register_task(r);
#else
  r.add_unavailable_task("hexapod", "this drops was built without DART 6; run "
                                    "scripts/install-deps, then scripts/build again");
#endif
#ifdef DROPS_WITH_MUJOCO
  // prior.model: a URDF or MJCF file as a built-in task's prior (drops::description, MuJoCo),
  // as in the drops command line.
  r.set_description_prior_factory(drops::description::experiment_factory());
#endif
}

// The Python classes of drops's exceptions (created in the module's init).
struct ExceptionTypes {
  PyObject* error = nullptr;
  PyObject* config_error = nullptr;
  PyObject* invalid_argument = nullptr;
  PyObject* numerical_error = nullptr;
  PyObject* busy = nullptr;
  PyObject* damaged = nullptr;
} g_exc;

// Sets the Python error `type` with drops's message, whose bytes that are not UTF-8 (a binary
// file's content quoted in a message) are backslash-escaped instead of making the message empty.
void set_error(PyObject* type, const char* message) {
  PyObject* text = PyUnicode_DecodeUTF8(message, static_cast<Py_ssize_t>(std::strlen(message)),
                                        "backslashreplace");
  if (text == nullptr) {
    PyErr_Clear();
    text = PyUnicode_FromString("(a message that cannot be decoded)");
  }
  PyErr_SetObject(type, text);
  Py_XDECREF(text);
}

PyObject* add_exception(py::module_& m, const char* name, const char* doc, py::tuple bases) {
  const std::string qualified = std::string("drops.") + name;
  PyObject* type = PyErr_NewExceptionWithDoc(qualified.c_str(), doc, bases.ptr(), nullptr);
  if (type == nullptr) throw py::error_already_set();
  m.add_object(name, py::handle(type));  // the module keeps a reference for the process
  return type;
}

// A KeySpec as a dict (drops.schema()).
py::dict key_dict(const ex::KeySpec& k) {
  py::dict d;
  d["key"] = k.key;
  d["type"] = k.type;
  d["default"] = k.default_value;
  d["min"] = k.min < k.max ? py::object(py::float_(k.min)) : py::object(py::none());
  d["max"] = k.min < k.max ? py::object(py::float_(k.max)) : py::object(py::none());
  d["allowed"] = k.allowed;
  d["unit"] = k.unit;
  d["doc"] = k.doc;
  return d;
}

py::array_t<double> vector_array(const std::vector<double>& v) {
  py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), a.mutable_data());
  return a;
}

// An Eigen matrix as a numpy array (rows, cols) of its own (row-major copy).
py::array_t<double> matrix_array(const drops::MatrixXd& m) {
  py::array_t<double> a({static_cast<py::ssize_t>(m.rows()), static_cast<py::ssize_t>(m.cols())});
  auto am = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) am(i, j) = m(i, j);
  return a;
}

// read_log's result as a dict of lists, numbers and arrays (drops.read_log builds its object).
py::dict recorded_log_dict(const ex::RecordedLog& log) {
  py::dict d;
  d["state_names"] = log.state_names;
  d["action_names"] = log.action_names;
  d["dt"] = log.dt;
  py::list segments;
  for (const auto& s : log.segments) {
    py::dict seg;
    seg["t0"] = s.t0;
    seg["x"] = matrix_array(s.x);
    seg["u"] = matrix_array(s.u);
    seg["first_line"] = s.first_line;
    seg["last_line"] = s.last_line;
    segments.append(seg);
  }
  d["segments"] = segments;
  const ex::LogReport& r = log.report;
  py::dict report;
  report["source"] = r.source;
  report["rows"] = r.rows;
  report["dropped_nonfinite"] = r.dropped_nonfinite;
  report["dropped_repeated_time"] = r.dropped_repeated_time;
  report["gaps"] = r.gaps;
  report["longest_interval"] = r.longest_interval;
  report["median_interval"] = r.median_interval;
  report["max_gap"] = r.max_gap;
  report["grid_step"] = r.grid_step;
  report["short_segments"] = r.short_segments;
  report["short_segment_rows"] = r.short_segment_rows;
  report["segments"] = r.segments;
  report["transitions"] = r.transitions;
  report["angle_wraps"] = r.angle_wraps;
  report["velocity_slope"] = vector_array(r.velocity_slope);
  report["velocity_rms_difference"] = vector_array(r.velocity_rms_difference);
  report["brief"] = r.BriefReport();
  d["report"] = report;
  return d;
}

// What the Python side of one run shares with its callbacks (called on the calling thread, which
// released the interpreter lock: each callback takes it for its own duration).
struct PythonOutput {
  py::object progress;  // a callable taking one line, or None: sys.stderr
  py::object stderr_;   // sys.stderr when progress is None
  // The first exception the progress callable or sys.stderr raised: nothing more is printed, the
  // run stops after its current step and the exception is raised again from drops.run /
  // drops.resume once the run directory is closed.
  std::optional<py::error_already_set> error;
  // KeyboardInterrupt (Ctrl-C, seen by PyErr_CheckSignals or raised in the progress callable): the
  // run stops after its current step, its final lines are printed, then it is raised again.
  std::optional<py::error_already_set> interrupt;
  // The run's Python callbacks' errors (a run of a task written in Python), or null: Ctrl-C
  // inside a callback also stops the run after its current step.
  const drops::python::CallbackErrors* callback_errors = nullptr;

  void write(const std::string& text, bool newline) {
    if (error) return;  // the output already failed: say nothing more
    py::gil_scoped_acquire gil;
    try {
      if (!progress.is_none()) {
        progress(text);
      } else {
        stderr_.attr("write")(newline ? text + "\n" : text);
        stderr_.attr("flush")();
      }
    } catch (py::error_already_set& e) {
      if (e.matches(PyExc_KeyboardInterrupt)) {
        if (!interrupt) interrupt.emplace(std::move(e));
      } else {
        error.emplace(std::move(e));
      }
    }
  }

  bool should_stop() {
    if (error || interrupt || (callback_errors && callback_errors->interrupted())) return true;
    py::gil_scoped_acquire gil;
    // Runs Python's signal handlers: Ctrl-C raises KeyboardInterrupt here (main thread only).
    if (PyErr_CheckSignals() != 0) {
      py::error_already_set e;
      if (e.matches(PyExc_KeyboardInterrupt))
        interrupt.emplace(std::move(e));
      else
        error.emplace(std::move(e));  // another signal handler's exception
    }
    return error || interrupt;
  }
};

/// The result of drops.run / drops.resume.
struct PyRunOutcome {
  std::string directory, status, hint, brief;
  bool nothing_to_do = false;
  int episodes_done = 0;
  std::optional<int> first_solved_episode;
  double best_real_return = 0, seconds = 0;
};

PyRunOutcome run_impl(const ex::Registry& reg, const ex::Settings& settings,
                      const std::string& source, const std::string& resume_dir, bool quiet,
                      py::object progress,
                      drops::python::CallbackErrors* callback_errors = nullptr) {
  PythonOutput py_out;
  py_out.progress = std::move(progress);
  py_out.callback_errors = callback_errors;
  ex::RunOutput out;
  out.quiet = quiet;
  if (py_out.progress.is_none()) {
    py_out.stderr_ = py::module_::import("sys").attr("stderr");
    try {
      out.live = !quiet && py_out.stderr_.attr("isatty")().cast<bool>();
    } catch (py::error_already_set&) {
      out.live = false;  // a replaced sys.stderr without isatty()
    }
  }
  out.line = [&](const std::string& text) { py_out.write(text, true); };
  out.status = [&](const std::string& text) { py_out.write("\r\033[K" + text, false); };
  out.clear_status = [&] { py_out.write("\r\033[K", false); };
  out.should_stop = [&] { return py_out.should_stop(); };
  ex::RunOutcome r;
  try {
    py::gil_scoped_release release;
    r = ex::run_experiment(reg, settings, source, resume_dir, out);
  } catch (...) {
    // A Python callback's exception comes out as itself (the run directory says "failed", with
    // every finished episode kept).
    if (callback_errors)
      if (auto e = callback_errors->take()) throw std::move(*e);
    throw;
  }
  if (py_out.error) throw std::move(*py_out.error);
  if (py_out.interrupt) throw std::move(*py_out.interrupt);
  if (callback_errors)
    if (auto e = callback_errors->take_interrupt()) throw std::move(*e);
  PyRunOutcome o;
  o.directory = r.directory.string();
  o.status = r.status;
  o.hint = r.hint;
  o.brief = r.summary.BriefReport();
  o.nothing_to_do = r.nothing_to_do;
  o.episodes_done = r.summary.episodes_done;
  if (r.summary.first_solved_episode > 0) o.first_solved_episode = r.summary.first_solved_episode;
  o.best_real_return = r.summary.best_real_return;
  o.seconds = r.summary.seconds;
  return o;
}

ex::Settings settings_of(const std::string& config, const std::vector<std::string>& overrides) {
  if (config.empty()) return ex::load_settings(registry(), "", overrides);
  return ex::load_settings_file(registry(), config, overrides);
}

py::dict run_dict(const ex::RunResult& r) {
  py::dict d;
  d["name"] = r.name;
  d["directory"] = r.dir.string();
  d["status"] = r.status;
  d["error"] = r.error;
  d["task"] = r.task;
  d["algorithm"] = r.algorithm;
  d["model_type"] = r.model_type;
  d["variant"] = r.variant;
  d["prior"] = r.prior;
  d["uses_prior"] = r.uses_prior;
  d["uses_model"] = r.uses_model;
  d["seed"] = r.seed;
  d["episodes_planned"] = r.episodes_planned;
  d["phi_names"] = r.phi_names;
  d["phi_actual"] = vector_array(r.phi_actual);
  d["phi_tunable"] = r.phi_tunable;
  d["state_names"] = r.state_names;
  d["action_names"] = r.action_names;
  d["task_settings"] = r.task_settings;
  d["solved"] = r.solved;
  d["first_solved_episode"] =
      r.first_solved_episode ? py::object(py::int_(*r.first_solved_episode)) : py::none();
  d["first_solved_time_s"] = r.first_solved_time_s;

  const auto n = static_cast<py::ssize_t>(r.episodes.size());
  std::size_t phi_dim = r.phi_names.size();
  for (const auto& e : r.episodes) phi_dim = std::max(phi_dim, e.phi.size());
  py::array_t<long long> episode(n);
  py::array_t<double> time(n), real(n), predicted(n);
  py::array_t<bool> solved(n), random(n);
  py::array_t<double> phi({n, static_cast<py::ssize_t>(phi_dim)});
  std::vector<std::string> metric_names;
  for (const auto& e : r.episodes)
    for (const auto& [k, v] : e.metrics)
      if (std::find(metric_names.begin(), metric_names.end(), k) == metric_names.end())
        metric_names.push_back(k);
  py::dict metrics;
  std::vector<py::array_t<double>> metric_arrays;
  for (std::size_t k = 0; k < metric_names.size(); ++k) metric_arrays.emplace_back(n);
  auto phi_m = phi.mutable_unchecked<2>();
  for (py::ssize_t i = 0; i < n; ++i) {
    const ex::EpisodeResult& e = r.episodes[static_cast<std::size_t>(i)];
    episode.mutable_at(i) = e.episode;
    time.mutable_at(i) = e.interaction_time_s;
    real.mutable_at(i) = e.real_return;
    predicted.mutable_at(i) = e.predicted_return;
    solved.mutable_at(i) = e.solved;
    random.mutable_at(i) = e.random_policy;
    for (std::size_t j = 0; j < phi_dim; ++j)
      phi_m(i, static_cast<py::ssize_t>(j)) =
          j < e.phi.size() ? e.phi[j] : std::numeric_limits<double>::quiet_NaN();
    for (std::size_t m = 0; m < metric_names.size(); ++m)
      metric_arrays[m].mutable_at(i) = e.metric(metric_names[m]);
  }
  for (std::size_t m = 0; m < metric_names.size(); ++m) metrics[py::str(metric_names[m])] =
      metric_arrays[m];
  py::dict episodes;
  episodes["episode"] = episode;
  episodes["interaction_time_s"] = time;
  episodes["real_return"] = real;
  episodes["predicted_return"] = predicted;
  episodes["solved"] = solved;
  episodes["random_policy"] = random;
  episodes["phi"] = phi;
  episodes["metrics"] = metrics;
  d["episodes"] = episodes;
  return d;
}

// A registry of one task written in Python (drops.run(task=...)) and the built-in algorithms.
// Destroyed with the interpreter lock held, after the run.
struct PythonTaskRun {
  std::shared_ptr<drops::python::CallbackErrors> errors =
      std::make_shared<drops::python::CallbackErrors>();
  ex::Registry registry;
  PythonTaskRun(const py::dict& spec, py::object task, py::object system, py::object prior) {
    ex::register_builtin_algorithms(registry);
    registry.add_task(drops::python::make_python_task_plugin(spec, std::move(task),
                                                             std::move(system), std::move(prior),
                                                             errors));
  }
};

}  // namespace

PYBIND11_MODULE(_drops, m) {
  m.doc() = "The C++ core of the Python package drops (use the package: import drops).";
  m.attr("__version__") = DROPS_VERSION;  // the CMake project's version (CHANGELOG.md)
  drops::use_single_threaded_blas();
  g_registry = std::make_unique<ex::Registry>();
  register_builtins(*g_registry);

  const py::handle runtime_error(PyExc_RuntimeError), value_error(PyExc_ValueError),
      arithmetic_error(PyExc_ArithmeticError);
  g_exc.error = add_exception(m, "Error", "Base class of every error drops raises.",
                              py::make_tuple(runtime_error));
  const py::handle error(g_exc.error);
  g_exc.config_error = add_exception(
      m, "ConfigError",
      "A configuration (file, key=value override, argument) is invalid; the message names the key, "
      "the value and what is allowed, as the drops command line says it.",
      py::make_tuple(error, value_error));
  g_exc.invalid_argument = add_exception(
      m, "InvalidArgument", "An argument of the wrong size or value (\"expected X, got Y\").",
      py::make_tuple(error, value_error));
  g_exc.numerical_error = add_exception(
      m, "NumericalError", "A numerical procedure failed (e.g. a Cholesky factorization).",
      py::make_tuple(error, arithmetic_error));
  g_exc.busy = add_exception(m, "RunDirectoryBusy",
                             "Another process holds the run directory (drops run exits with 3).",
                             py::make_tuple(error));
  g_exc.damaged = add_exception(
      m, "RunDirectoryDamaged",
      "A run directory does not match its checkpoint (a file missing, cut or edited); the "
      "message names the file.",
      py::make_tuple(error));
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const ex::RunDirectoryBusy& e) {
      set_error(g_exc.busy, e.what());
    } catch (const ex::RunDirectoryDamaged& e) {
      set_error(g_exc.damaged, e.what());
    } catch (const drops::ConfigError& e) {
      set_error(g_exc.config_error, e.what());
    } catch (const drops::InvalidArgument& e) {
      set_error(g_exc.invalid_argument, e.what());
    } catch (const drops::NumericalError& e) {
      set_error(g_exc.numerical_error, e.what());
    } catch (const drops::Error& e) {
      set_error(g_exc.error, e.what());
    } catch (const py::error_already_set&) {
      throw;  // pybind11's own translation
    } catch (const py::builtin_exception&) {
      throw;
    } catch (const std::bad_alloc&) {
      PyErr_SetString(PyExc_MemoryError, "drops: out of memory");
    } catch (const std::exception& e) {
      set_error(PyExc_RuntimeError, e.what());
    }
  });

  drops::python::bind_description(m);  // drops.DescriptionPrior's C++ side (with MuJoCo)

  py::class_<PyRunOutcome>(m, "RunOutcome",
                           "What drops.run or drops.resume did (the run's files are in directory).")
      .def_readonly("directory", &PyRunOutcome::directory, "The run directory (str).")
      .def_readonly("status", &PyRunOutcome::status,
                    "summary.json's final status: 'complete' or 'interrupted'.")
      .def_readonly("nothing_to_do", &PyRunOutcome::nothing_to_do,
                    "True when a resumed run already had its episodes (nothing was run).")
      .def_readonly("hint", &PyRunOutcome::hint,
                    "For an interrupted run: how to continue it; '' otherwise.")
      .def_readonly("episodes_done", &PyRunOutcome::episodes_done,
                    "Real episodes finished, earlier sessions of a resumed run included.")
      .def_readonly("first_solved_episode", &PyRunOutcome::first_solved_episode,
                    "First episode (1-based) that solved the task, None when none did.")
      .def_readonly("best_real_return", &PyRunOutcome::best_real_return,
                    "Best return of a real episode (the task's reward summed over the episode).")
      .def_readonly("seconds", &PyRunOutcome::seconds, "Wall-clock time of this call (s).")
      .def_readonly("brief", &PyRunOutcome::brief,
                    "One line: '10 episodes, best return 19.81, first solved at episode 4, "
                    "83.2 s'.")
      .def("__repr__", [](const PyRunOutcome& o) {
        return "RunOutcome(status='" + o.status + "', directory='" + o.directory + "', " +
               o.brief + ")";
      });

  m.def(
      "_run",
      [](const std::string& config, const std::vector<std::string>& overrides, bool quiet,
         py::object progress) {
        const ex::Settings s = settings_of(config, overrides);
        return run_impl(registry(), s, config, "", quiet, std::move(progress));
      },
      py::arg("config"), py::arg("overrides"), py::arg("quiet"), py::arg("progress"),
      "drops.run's C++ side: load the settings (config: a YAML file or ''), run, return a "
      "RunOutcome. Raises ConfigError for a bad key or value.");
  m.def(
      "_resume",
      [](const std::string& directory, const std::vector<std::string>& overrides, bool quiet,
         py::object progress) {
        const ex::Settings s = ex::resume_settings(registry(), directory, overrides);
        const std::string source = (std::filesystem::path(directory) / "config.yaml").string();
        return run_impl(registry(), s, source, directory, quiet, std::move(progress));
      },
      py::arg("directory"), py::arg("overrides"), py::arg("quiet"), py::arg("progress"),
      "drops.resume's C++ side: continue the run in directory (episodes= and threads= overrides "
      "only).");
  m.def(
      "_run_task",
      [](const py::dict& spec, py::object task, py::object system, py::object prior,
         const std::string& config, std::vector<std::string> overrides, bool quiet,
         py::object progress) {
        PythonTaskRun run(spec, std::move(task), std::move(system), std::move(prior));
        overrides.insert(overrides.begin(), "task=" + spec["name"].cast<std::string>());
        const ex::Settings s =
            config.empty() ? ex::load_settings(run.registry, "", overrides)
                           : ex::load_settings_file(run.registry, config, overrides);
        return run_impl(run.registry, s, config, "", quiet, std::move(progress),
                        run.errors.get());
      },
      py::arg("spec"), py::arg("task"), py::arg("system"), py::arg("prior"), py::arg("config"),
      py::arg("overrides"), py::arg("quiet"), py::arg("progress"),
      "drops.run(task=...)'s C++ side: the robot of drops/robot.py's spec and objects registered "
      "as the only task, then as _run.");
  m.def(
      "_resume_task",
      [](const py::dict& spec, py::object task, py::object system, py::object prior,
         const std::string& directory, const std::vector<std::string>& overrides, bool quiet,
         py::object progress) {
        PythonTaskRun run(spec, std::move(task), std::move(system), std::move(prior));
        const ex::Settings s = ex::resume_settings(run.registry, directory, overrides);
        const std::string source = (std::filesystem::path(directory) / "config.yaml").string();
        return run_impl(run.registry, s, source, directory, quiet, std::move(progress),
                        run.errors.get());
      },
      py::arg("spec"), py::arg("task"), py::arg("system"), py::arg("prior"), py::arg("directory"),
      py::arg("overrides"), py::arg("quiet"), py::arg("progress"),
      "drops.resume(task=...)'s C++ side: as _resume, with the robot registered as for _run_task.");
  m.def(
      "_identify",
      [](const std::string& config, const std::vector<std::string>& overrides, bool quiet,
         py::object progress) {
        const ex::Settings s = settings_of(config, overrides);
        // Progress lines go to the callable (or sys.stderr), the interpreter lock taken for each.
        auto say = [&](const std::string& line) {
          if (quiet) return;
          py::gil_scoped_acquire gil;
          if (progress.is_none())
            py::module_::import("sys").attr("stderr").attr("write")("drops identify: " + line +
                                                                   "\n");
          else
            progress(line);
        };
        std::optional<ex::IdentifyRun> run;
        {
          py::gil_scoped_release release;
          run.emplace(ex::identify_from_settings(
              registry(), s, say, [&](const std::string& phase, int evaluations, double best) {
                say(phase + " " + std::to_string(evaluations) + " evaluations, best " +
                    std::to_string(best));
              }));
        }
        const ex::IdentifySummary& r = run->result.summary;
        auto vec = [](const drops::VectorXd& v) {
          py::array_t<double> a(static_cast<py::ssize_t>(v.size()));
          if (v.size() > 0) std::memcpy(a.mutable_data(), v.data(), sizeof(double) * v.size());
          return a;
        };
        auto rows = [](const std::vector<ex::PredictionErrors>& v) {
          py::list l;
          for (const auto& e : v)
            l.append(py::make_tuple(e.file, e.horizon, e.steps, e.dim, e.median, e.p90, e.n));
          return l;
        };
        py::dict d;
        d["directory"] = run->directory.string();
        d["model_type"] = r.model_type;
        d["state_names"] = r.state_names;
        d["action_names"] = r.action_names;
        d["dt"] = r.dt;
        d["transitions"] = r.transitions;
        d["points"] = r.points;
        d["phi_names"] = r.phi_names;
        d["phi_start"] = vec(r.phi_start);
        d["phi"] = vec(r.phi);
        d["phi_lower95"] = vec(r.phi_lower95);
        d["phi_upper95"] = vec(r.phi_upper95);
        d["phi_tunable"] = std::vector<bool>(r.phi_tunable.begin(), r.phi_tunable.end());
        d["errors"] = rows(r.errors);
        d["prior_errors"] = rows(r.prior_errors);
        d["validation"] = run->options.validation.size();
        std::vector<std::string> files;
        for (const auto& f : run->options.validation) files.push_back(f.string());
        d["validation_files"] = files;
        d["horizons"] = run->options.horizons;
        d["learn_seconds"] = r.learn_seconds;
        d["brief"] = r.BriefReport();
        return d;
      },
      py::arg("config"), py::arg("overrides"), py::arg("quiet"), py::arg("progress"),
      "drops.identify's C++ side (experiment::identify_from_settings, as `drops identify`): "
      "returns a dict of the summary (phi as arrays, error rows as tuples).");
  m.def(
      "_config",
      [](const std::string& config, const std::vector<std::string>& overrides) {
        const ex::Settings s = settings_of(config, overrides);
        ex::make_experiment(registry(), s, config);  // full validation, as `drops config`
        return ex::to_yaml(registry(), s);
      },
      py::arg("config"), py::arg("overrides"),
      "The resolved configuration as YAML text (drops config). Raises ConfigError.");
  m.def(
      "_schema",
      [](const std::string& task) {
        py::list keys;
        for (const auto& k :
             ex::schema(registry(), task.empty() ? registry().default_task() : task))
          keys.append(key_dict(k));
        return keys;
      },
      py::arg("task"), "The keys of the schema of task ('' = the default task), as dicts.");
  m.def(
      "_schema_markdown", [] { return ex::schema_markdown(registry()); },
      "Every key of every task as Markdown tables (drops config --markdown).");
  m.def(
      "_tasks", [] { return registry().task_names(); },
      "The registered tasks' names, the default first.");
  m.def(
      "_algorithms", [] { return registry().algorithm_names(); },
      "The registered algorithms' names, the default first.");
  m.def(
      "_read_run",
      [](const std::string& directory) {
        // A directory that holds none of a run's files is no run (the library's reader calls it
        // "not started", which a campaign's runs that have not begun are).
        const std::filesystem::path d(directory);
        std::error_code ec;
        if (!std::filesystem::is_directory(d, ec))
          throw drops::Error(directory + " is not a run directory (not a directory)");
        bool any = false;
        for (const char* f : {"config.yaml", "summary.json", "episodes.csv"})
          any = any || std::filesystem::exists(d / f, ec);
        if (!any)
          throw drops::Error(directory +
                             " is not a run directory (no config.yaml, summary.json or "
                             "episodes.csv)");
        return run_dict(ex::read_run(directory, &registry()));
      },
      py::arg("directory"), "read_run as a dict of fields and numpy arrays.");
  m.def(
      "_read_trajectory",
      [](const std::string& path) {
        const ex::TrajectoryTable t = ex::read_trajectory_csv(path);
        py::array_t<double> a({static_cast<py::ssize_t>(t.rows.size()),
                               static_cast<py::ssize_t>(t.columns.size())});
        auto am = a.mutable_unchecked<2>();
        for (std::size_t i = 0; i < t.rows.size(); ++i)
          for (std::size_t j = 0; j < t.columns.size(); ++j)
            am(static_cast<py::ssize_t>(i), static_cast<py::ssize_t>(j)) = t.rows[i][j];
        return py::make_tuple(t.columns, a);
      },
      py::arg("path"), "read_trajectory_csv: (column names, array (rows, columns)).");
  m.def(
      "_read_log",
      [](const std::string& path, const std::string& time,
         const std::vector<std::vector<std::string>>& states,
         const std::vector<std::string>& actions, double dt, double time_scale, double max_gap,
         bool drop_bad_rows, double lowpass_hz, int lowpass_order, double derivative_window,
         double max_angle_span, int min_transitions) {
        ex::LogColumns columns;
        columns.time = time;
        for (const auto& s : states) {
          if (s.size() != 4) throw drops::InvalidArgument("a state: expected 4 fields");
          ex::LogQuantity q = ex::LogQuantity::kOther;
          if (s[1] == "angle")
            q = ex::LogQuantity::kAngle;
          else if (s[1] == "velocity")
            q = ex::LogQuantity::kVelocity;
          else if (s[1] != "other")
            throw drops::InvalidArgument("a state's kind '" + s[1] +
                                         "': expected angle, velocity or other");
          columns.state.push_back({s[0], q, s[2], s[3]});
        }
        columns.action = actions;
        ex::LogOptions o;
        o.dt = dt;
        o.time_scale = time_scale;
        o.max_gap = max_gap;
        o.bad_rows = drop_bad_rows ? ex::BadRows::kDrop : ex::BadRows::kError;
        o.lowpass_hz = lowpass_hz;
        o.lowpass_order = lowpass_order;
        o.derivative_window = derivative_window;
        o.max_angle_span = max_angle_span;
        o.min_transitions = min_transitions;
        ex::RecordedLog log;
        {
          py::gil_scoped_release release;
          log = ex::read_log(path, columns, o);
        }
        return recorded_log_dict(log);
      },
      py::arg("path"), py::arg("time"), py::arg("states"), py::arg("actions"), py::arg("dt"),
      py::arg("time_scale"), py::arg("max_gap"), py::arg("drop_bad_rows"), py::arg("lowpass_hz"),
      py::arg("lowpass_order"), py::arg("derivative_window"), py::arg("max_angle_span"),
      py::arg("min_transitions"),
      "read_log: states are [column, kind, of, name] (kind angle | velocity | other); a dict of "
      "state_names, action_names, dt, segments (t0, x (K + 1, E), u (K, U), first_line, "
      "last_line) and report.");
  m.def(
      "_read_policy",
      [](const std::string& path) { return vector_array(ex::read_policy_csv(path)); },
      py::arg("path"), "read_policy_csv: theta as an array (P,).");
  m.def(
      "_episode_dir",
      [](const std::string& run_dir, int episode) {
        return ex::episode_dir(run_dir, episode).string();
      },
      py::arg("run_dir"), py::arg("episode"), "The folder of an episode's files (episodes/NNN).");
}
