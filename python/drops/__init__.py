"""drops from Python: run the experiments of the drops command line and read their results.

Black-DROPS with GP-MI (Chatzilygeroudis & Mouret, ICRA 2018) as a library: every function here
calls the C++ library drops (the extension drops._drops), so a run from Python writes the same run
directory, with the same validation and messages, as ``drops run``. docs/python.md has the guide.

    import drops
    out = drops.run("configs/pendubot-gp_mi.yaml", ["episodes=3", "seed=2"])
    run = drops.read_run(out.directory)
    run.episodes["real_return"]          # (N,) the return of each real episode
    run.real(1).x                        # (T + 1, E) the states of episode 1

Errors are raised as drops.Error and its subclasses: ConfigError (also a ValueError) for a bad
configuration key or value, with the message of the command line; RunDirectoryBusy when another
process writes the run directory; RunDirectoryDamaged when a run directory does not match its
checkpoint; InvalidArgument; NumericalError.
"""

import os as _os
from collections.abc import Mapping as _Mapping

import numpy as _np

from . import _drops
from ._drops import (ConfigError, Error, InvalidArgument, NumericalError, RunDirectoryBusy,
                     RunDirectoryDamaged, RunOutcome)
from .robot import Goal, Parameter, Prior, Reflection, System, Task, _robot_spec, _unicode
from .description import DescriptionPrior
from .identify import IdentifyResult, _result as _identify_result

__version__ = _drops.__version__  # drops's version (CHANGELOG.md), the C++ library's

__all__ = [
    "run", "resume", "config", "schema", "schema_markdown", "tasks", "algorithms", "read_run",
    "read_trajectory", "read_policy", "read_log", "RecordedLog", "LogSegment", "Run", "Trajectory", "RunOutcome", "Error", "ConfigError",
    "InvalidArgument", "NumericalError", "RunDirectoryBusy", "RunDirectoryDamaged", "Task",
    "System", "Prior", "Parameter", "Reflection", "Goal", "DescriptionPrior", "identify",
    "IdentifyResult",
]


def _yaml_value(value):
    """A Python value as the YAML text of a key=value override (True -> true, [a, b] -> [a, b])."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_yaml_value(v) for v in value) + "]"
    return str(value)


def _overrides(overrides, extra):
    """key=value strings from a sequence of "key=value", a mapping {key: value}, or None, followed
    by the keyword arguments in `extra` that are not None (as the command line's --seed etc.)."""
    if overrides is None:
        result = []
    elif isinstance(overrides, str):
        raise TypeError("overrides: expected a list of 'key=value' strings or a dict, got the "
                        f"string {overrides!r} (write ['{overrides}'])")
    elif isinstance(overrides, _Mapping):
        result = [f"{k}={_yaml_value(v)}" for k, v in overrides.items()]
    else:
        result = []
        for o in overrides:
            if not isinstance(o, str) or "=" not in o:
                raise TypeError(f"overrides: expected 'key=value' strings, got {o!r}")
            result.append(o)
    for key, value in extra.items():
        if value is not None:
            if isinstance(value, _os.PathLike):
                value = _path(value, key)
            result.append(f"{key}={_yaml_value(value)}")
    for o in result:
        if "\0" in o:
            raise ValueError(f"overrides: {o[:80]!r} holds a NUL character")
        _unicode(o, "overrides")
    return result


def _path(p, what="path"):
    """A str or path-like as the str drops's C++ side takes; TypeError for another type,
    ValueError for a NUL character (no operating system takes one in a path)."""
    if p is None:
        return ""
    try:
        s = _os.fspath(p)
    except TypeError:
        raise TypeError(f"{what}: expected a str or path-like, got {type(p).__name__}") from None
    if isinstance(s, bytes):
        s = _os.fsdecode(s)
    if "\0" in s:
        raise ValueError(f"{what} = {s[:80]!r}: a path cannot hold a NUL character")
    return _unicode(s, what)


def _progress(progress):
    if progress is not None and not callable(progress):
        raise TypeError(f"progress: expected None or a callable taking each line (str), got "
                        f"{type(progress).__name__} {progress!r:.80}")
    return progress


def _builtin_tasks():
    return tuple(_drops._tasks())


def run(config=None, overrides=None, *, seed=None, threads=None, output=None, name=None,
        quiet=False, progress=None, task=None, system=None, prior=None):
    """Runs an experiment as ``drops run [config] [key=value ...]`` does; returns a RunOutcome.

    config: a YAML configuration file (str or path-like), or None for the defaults (the pendubot,
        Black-DROPS with GP-MI, 10 episodes, seed 1).
    overrides: key=value settings applied after the file: a list of "key=value" strings (values
        are YAML: "prior.bounds.m2=[0.1, 1.5]") or a dict {key: value}; `drops.schema()` lists the
        keys, with units and ranges.
    seed, threads, output, name: the same as the overrides seed=, threads= (0 = every core),
        output= (parent of the run directory, default "runs") and name= (the run directory's
        name; default "<task>-<variant>-<prior>-seed<seed>-<time>").
    quiet: print only the final line (and warnings a user must act on), as ``drops run -q``.
    progress: None to print the progress lines of ``drops run`` on sys.stderr (a status line
        updated in place when sys.stderr is a terminal), or a callable taking each line (str,
        without newline).

    Returns a RunOutcome: directory (the run directory), status ('complete' or 'interrupted'),
    episodes_done, first_solved_episode, best_real_return, seconds, brief, hint.
    Raises ConfigError (a ValueError) for an unknown key, a wrong type or an out-of-range value,
    with the command line's message; RunDirectoryBusy when another process writes the run
    directory; Error for other failures (the run directory then says "failed"); whatever the
    progress callable raises (the run stops after its current step). Ctrl-C stops the run after
    its current step with every finished episode on disk (status "interrupted", resumable with
    drops.resume), then raises KeyboardInterrupt.
    The interpreter lock is released while the C++ code runs and taken briefly for each progress
    line and each poll for Ctrl-C. One run at a time per process (drops's thread pool is shared).

    Your own robot (docs/python.md): task (a drops.Task), system (a drops.System) and prior (a
    drops.Prior, or None for model.type=gp and algorithm=direct) are registered for this run as
    the only task, under task.name (the configuration's task key is set to it); the other keys
    (algorithm, model.*, policy.*, optimizer.*, rollouts.*, episodes, ...) work as for the
    built-in tasks. The callbacks run on drops's threads, each call holding the interpreter lock;
    the batched ones (Task.observe, Task.reward, Prior.evaluate) take it once per batch. An
    exception a callback raises stops the run (summary.json says "failed", every finished episode
    stays on disk; drops.resume with the same objects continues it) and comes out of run() as
    itself. A callback returning an array of the wrong shape raises InvalidArgument naming the
    callback, the expected and the received shape; Task.observe or Task.reward returning a
    non-finite value raises InvalidArgument naming the callback and the state.
    """
    args = _overrides(overrides, {"seed": seed, "threads": threads, "output": output,
                                  "name": name})
    config, progress = _path(config, "config"), _progress(progress)
    if task is None:
        if system is not None or prior is not None:
            raise TypeError("system= and prior= need task= (your own robot: docs/python.md)")
        return _drops._run(config, args, bool(quiet), progress)
    spec = _robot_spec(task, system, prior, _builtin_tasks())
    return _drops._run_task(spec, task, system, prior, config, args, bool(quiet), progress)


def identify(config=None, overrides=None, *, threads=None, output=None, name=None, quiet=False,
             progress=None):
    """Learns a dynamics model from recorded logs and measures it on validation logs, as
    ``drops identify CONFIG [key=value ...]`` does (docs/identify.md); returns an IdentifyResult
    (phi and its intervals, the errors as numpy arrays, the output directory).

    config, overrides: as for run(); the keys identify.* name the logs and their columns, the
        task gives the prior and the state and action names, model.type the variant.
    threads, output, name: as the overrides threads=, output= and name= (the directory
        <output>/<name>, default name identify-<task>-<model.type>).
    quiet, progress: as for run() (progress lines of the reading, learning and validation).
    Raises ConfigError for a bad key or value and for a log without a declared column (the
    message names the file and the column); Error for a log's other errors (file, line,
    column) and the learning's; nothing is written before the learning is done. The
    interpreter lock is released while the C++ code runs. The figures of ``drops identify``
    are not drawn: ``/usr/bin/python3 python/drops_plot.py identify DIR`` draws them.
    """
    args = _overrides(overrides, {"threads": threads, "output": output, "name": name})
    config, progress = _path(config, "config"), _progress(progress)
    return _identify_result(_drops._identify(config, args, bool(quiet), progress))


def resume(directory, overrides=None, *, threads=None, quiet=False, progress=None, task=None,
           system=None, prior=None):
    """Continues the run in `directory` from its last finished episode, as
    ``drops run --resume DIR [episodes=N] [threads=N]``; returns a RunOutcome.

    directory: a run directory (str or path-like) of an interrupted or finished run.
    overrides: only episodes= (extend a run) and threads= may change ("key=value" list or dict).
    threads, quiet, progress: as for run().

    The resumed run produces exactly the episodes an uninterrupted run would have. A run that
    already has its episodes runs nothing (RunOutcome.nothing_to_do).
    Raises ConfigError when another key is overridden; Error when `directory` is not a run
    directory or is of another format version; RunDirectoryDamaged when its files do not match
    its checkpoint; RunDirectoryBusy; KeyboardInterrupt after Ctrl-C, as run().
    task, system, prior: for a run of your own robot, the same objects (same name, dimensions,
    parameters and behaviour) as the run was started with; ConfigError when task.name is not the
    run's task.
    """
    args = _overrides(overrides, {"threads": threads})
    directory, progress = _path(directory, "directory"), _progress(progress)
    if task is None:
        return _drops._resume(directory, args, bool(quiet), progress)
    spec = _robot_spec(task, system, prior, _builtin_tasks())
    return _drops._resume_task(spec, task, system, prior, directory, args, bool(quiet), progress)


def config(config=None, overrides=None):
    """The resolved configuration (defaults, the file and the overrides) as YAML text, every key
    of the task's schema, as ``drops config [config] [key=value ...]`` prints it.

    config, overrides: as for run(). Raises ConfigError as run() does.
    """
    return _drops._config(_path(config, "config"), _overrides(overrides, {}))


def schema(task=None):
    """The configuration keys of an experiment on `task` (None: the default task, the pendubot):
    a list of dicts with key (dotted name), type ("int", "double", "bool", "string", "enum",
    "names", "interval"), default (YAML text; "" = derived from the task), min and max (the
    inclusive numeric range, None when unbounded), allowed (enum values), unit and doc.

    Raises ConfigError when the task is unknown (the message lists the registered ones).
    """
    return _drops._schema("" if task is None else str(task))


def schema_markdown():
    """Every key of every task as Markdown tables (``drops config --markdown``,
    docs/configuration.md)."""
    return _drops._schema_markdown()


def tasks():
    """The names of the registered tasks (list of str), the default task first."""
    return list(_drops._tasks())


def algorithms():
    """The names of the registered algorithms (list of str), the default first."""
    return list(_drops._algorithms())


def read_trajectory(path):
    """Reads a trajectory file (episodes/NNN/real.csv or predicted.csv) with drops's reader.

    Returns (columns, data): the column names (list of str, C of them) and an array (R, C) of
    float64, one row per line, NaN for an empty cell. Raises Error naming the file when it cannot
    be read or a row has another number of cells than the header.
    """
    columns, data = _drops._read_trajectory(_path(path, "path"))
    return list(columns), data


def read_policy(path):
    """Reads a policy file (episodes/NNN/policy.csv): theta, an array (P,) of float64 (the policy's
    parameters, in [-policy.bound, policy.bound]). Raises Error naming the file (and the line)."""
    return _drops._read_policy(_path(path, "path"))


class LogSegment:
    """One stretch of a recorded log without a gap, resampled to dt (K transitions).

    Attributes: t0 (s): the time of x[0] in the log; x: (K + 1, E) the states at t0 + k dt;
    u: (K, U) the actions averaged over [t0 + k dt, t0 + (k + 1) dt); first_line, last_line: the
    file's lines of its first and last rows (1-based, the header is line 1).
    """

    def __init__(self, d):
        self.t0 = d["t0"]
        self.x = d["x"]
        self.u = d["u"]
        self.first_line = d["first_line"]
        self.last_line = d["last_line"]

    def __repr__(self):
        return (f"LogSegment(t0={self.t0:g}, transitions={len(self.u)}, "
                f"lines {self.first_line}-{self.last_line})")


class RecordedLog:
    """A robot's log resampled to dt by drops.read_log (docs/logs.md).

    Attributes:
      x: (N, E) the state before each of the N transitions, columns state_names.
      u: (N, U) the action averaged over each transition's period, columns action_names.
      dx: (N, E) x_{k+1} - x_k, what the models learn.
      segments: list of LogSegment (the log split at its gaps), in time order.
      state_names, action_names: lists of str; dt: the control period (s).
      report: dict of what resampling found and did (rows, dropped_nonfinite,
        dropped_repeated_time, gaps, longest_interval, median_interval, max_gap, grid_step,
        short_segments, short_segment_rows, segments, transitions, angle_wraps (per state),
        velocity_slope and velocity_rms_difference (per state, NaN where not checked), brief: one
        line).
    """

    def __init__(self, d):
        self.state_names = list(d["state_names"])
        self.action_names = list(d["action_names"])
        self.dt = d["dt"]
        self.segments = [LogSegment(s) for s in d["segments"]]
        self.report = dict(d["report"])
        E, U = len(self.state_names), len(self.action_names)
        self.x = _np.concatenate([s.x[:-1] for s in self.segments]) if self.segments \
            else _np.zeros((0, E))
        self.u = _np.concatenate([s.u for s in self.segments]) if self.segments \
            else _np.zeros((0, U))
        self.dx = _np.concatenate([_np.diff(s.x, axis=0) for s in self.segments]) \
            if self.segments else _np.zeros((0, E))

    def __repr__(self):
        return f"RecordedLog({self.report['brief']})"


_LOG_KINDS = ("angle", "velocity", "other")


def _log_state(entry, i):
    """One state of read_log's `state` as [column, kind, of, name]."""
    if isinstance(entry, str):
        entry = (entry,)
    if isinstance(entry, _Mapping):
        unknown = set(entry) - {"column", "kind", "of", "name"}
        if unknown:
            raise ValueError(f"state[{i}]: unknown field {sorted(unknown)[0]!r} (allowed: column, "
                             "kind, of, name)")
        entry = (entry.get("column"), entry.get("kind", "other"), entry.get("of"),
                 entry.get("name"))
    if not isinstance(entry, (tuple, list)) or not 1 <= len(entry) <= 4:
        raise TypeError(f"state[{i}]: expected a column name, a tuple (column, kind[, of[, name]]) "
                        f"or a dict, got {entry!r}")
    column, kind, of, name = (list(entry) + [None] * 3)[:4]
    kind = "other" if kind is None else kind
    if kind not in _LOG_KINDS:
        raise ValueError(f"state[{i}]: kind {kind!r}: expected one of {', '.join(_LOG_KINDS)}")
    fields = []
    for what, v in (("column", column), ("of", of), ("name", name)):
        if v is None:
            v = ""
        if not isinstance(v, str):
            raise TypeError(f"state[{i}]: {what}: expected a str, got {type(v).__name__}")
        fields.append(_unicode(v, f"state[{i}].{what}"))
    return [fields[0], kind, fields[1], fields[2]]


def read_log(path, state, action, time="time", dt=0.01, *, time_scale=1.0, max_gap=0.0,
             bad_rows="error", lowpass_hz=0.0, lowpass_order=2, derivative_window=0.01,
             max_angle_span=50.0, min_transitions=1):
    """Reads a robot's recorded log (CSV with a header) and resamples it to the control period dt
    with drops's reader (C++ read_log; docs/logs.md states the method and what it refuses).

    path: the CSV file. time: its time column (units: time_scale seconds).
    state: one entry per state, in drops's state order: a column name (an "other" quantity), a
      tuple (column, kind[, of[, name]]) or a dict with those keys. kind: "angle" (rad: unwrapped,
      checked for degrees), "velocity" (logged, checked against the derivative of the state named
      `of`; or, with column None or "", derived from `of` by a Savitzky-Golay derivative, and then
      `name` is required) or "other". name: the state's name (default: the column).
    action: the action's column names (list of str).
    dt: the control period (s). max_gap: a longer interval between rows splits the log (s; 0: the
      larger of dt and twice the median interval). bad_rows: "error" or "drop" (rows with a value
      that is not finite, or repeating the previous time: dropped and counted). lowpass_hz,
      lowpass_order: a zero-phase Butterworth low-pass of the states (0: off).
      derivative_window: the derivative's window (s). max_angle_span: an angle spanning more is
      refused (rad). min_transitions: fewer is an error.

    Returns a RecordedLog: x (N, E), u (N, U), dx (N, E), segments, report. Raises drops.Error
    naming the file, the line and the column for bad contents; drops.InvalidArgument (a
    ValueError) for a declaration or an option out of range; TypeError / ValueError for arguments
    of the wrong type.
    """
    if isinstance(state, (str, _Mapping)) or not hasattr(state, "__iter__"):
        raise TypeError(f"state: expected a list of states, got {type(state).__name__}")
    if isinstance(action, str) or not hasattr(action, "__iter__"):
        raise TypeError(f"action: expected a list of column names, got {type(action).__name__}")
    states = [_log_state(e, i) for i, e in enumerate(state)]
    actions = []
    for i, a in enumerate(action):
        if not isinstance(a, str):
            raise TypeError(f"action[{i}]: expected a str, got {type(a).__name__}")
        actions.append(_unicode(a, f"action[{i}]"))
    if not isinstance(time, str):
        raise TypeError(f"time: expected a str, got {type(time).__name__}")
    if bad_rows not in ("error", "drop"):
        raise ValueError(f"bad_rows = {bad_rows!r}: expected 'error' or 'drop'")
    numbers = {"dt": dt, "time_scale": time_scale, "max_gap": max_gap, "lowpass_hz": lowpass_hz,
               "derivative_window": derivative_window, "max_angle_span": max_angle_span}
    for k, v in numbers.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise TypeError(f"{k}: expected a number, got {type(v).__name__}")
    for k, v in (("lowpass_order", lowpass_order), ("min_transitions", min_transitions)):
        if isinstance(v, bool) or not isinstance(v, int):
            raise TypeError(f"{k}: expected an int, got {type(v).__name__}")
    return RecordedLog(_drops._read_log(
        _path(path, "path"), _unicode(time, "time"), states, actions, float(dt),
        float(time_scale), float(max_gap), bad_rows == "drop", float(lowpass_hz),
        int(lowpass_order), float(derivative_window), float(max_angle_span),
        int(min_transitions)))


class Trajectory:
    """One trajectory of a run directory (episodes/NNN/real.csv or predicted.csv), as arrays.

    A trajectory of T steps has T + 1 states. Attributes:
      columns: the file's column names (list of str, C of them); data: (T + 1, C) all of it.
      t: (T + 1,) time of each state (s).
      x: (T + 1, E) the states, columns state_names (units: the task's, docs/python.md).
      u: (T, A) the action applied after each state but the last, columns action_names.
      reward: (T,) the reward of each step (the reward that led to state k + 1).
      extras: dict name -> (T + 1,) the task's per-state extras (e.g. the pendubot's tip height).
      state_names, action_names: lists of str.
    """

    def __init__(self, columns, data, state_names, action_names):
        self.columns = list(columns)
        self.data = data
        self.state_names = list(state_names)
        self.action_names = list(action_names)
        index = {c: i for i, c in enumerate(self.columns)}

        def cols(names):
            missing = [n for n in names if n not in index]
            if missing:
                raise Error(f"trajectory: no column {missing[0]!r} (columns: {self.columns})")
            return data[:, [index[n] for n in names]]

        self.t = data[:, index["t"]] if "t" in index else _np.full(len(data), _np.nan)
        self.x = cols(self.state_names)
        self.u = cols(self.action_names)[:-1]
        self.reward = data[1:, index["reward"]] if "reward" in index else _np.full(
            max(len(data) - 1, 0), _np.nan)
        known = {"t", "reward", *self.state_names, *self.action_names}
        self.extras = {c: data[:, i] for c, i in index.items() if c not in known}

    def __repr__(self):
        return (f"Trajectory(steps={len(self.u)}, x={self.x.shape}, u={self.u.shape}, "
                f"columns={self.columns})")


class Run:
    """A run directory read back through drops's own reader (the reader of ``drops report``).

    Attributes (from summary.json and config.yaml):
      directory, name, status ("running", "complete", "interrupted", "failed", "not started" or
      "unreadable"), error, task, algorithm, model_type, variant, prior, uses_prior, uses_model,
      seed, episodes_planned, solved, first_solved_episode (None when never), first_solved_time_s
      (interaction time then, s; inf when never), task_settings (dict key -> YAML text).
      phi_names: (P names); phi_actual: (P,) the real system's phi; phi_tunable: names.
      state_names (E names), action_names (A names): the trajectory columns.
      episodes: dict of arrays over the N finished episodes:
        episode (N,) int, 1-based; interaction_time_s (N,) real time used so far (s);
        real_return (N,); predicted_return (N,) (NaN without a model); solved (N,) bool;
        random_policy (N,) bool; phi (N, P) the prior parameters the model used (NaN-padded);
        metrics: dict name -> (N,) the task's per-episode metrics.
    Methods real(k), predicted(k) give Trajectory objects and policy(k) theta (P_theta,) of
    episode k (1-based), when the run kept its files (a direct search keeps the improving ones).
    """

    def __init__(self, fields):
        self.__dict__.update(fields)

    def _file(self, episode, name):
        if not isinstance(episode, (int, _np.integer)) or episode < 1:
            raise InvalidArgument(f"episode: expected a 1-based episode number, got {episode!r}")
        return _os.path.join(_drops._episode_dir(self.directory, int(episode)), name)

    def real(self, episode):
        """The real trajectory of `episode` (1-based) as a Trajectory. Raises Error naming the
        file when the episode kept no trajectory or the file cannot be read."""
        return Trajectory(*read_trajectory(self._file(episode, "real.csv")), self.state_names,
                          self.action_names)

    def predicted(self, episode):
        """The trajectory the model predicted for the policy of `episode` (mean propagation) as
        a Trajectory. Raises Error naming the file when there is none (no model)."""
        return Trajectory(*read_trajectory(self._file(episode, "predicted.csv")),
                          self.state_names, self.action_names)

    def policy(self, episode):
        """The policy parameters theta of `episode` (1-based): an array (P_theta,). Raises Error
        naming the file when the episode kept none."""
        return read_policy(self._file(episode, "policy.csv"))

    @property
    def summary(self):
        """The run's summary as a dict: status, episodes_done, episodes_planned, solved,
        first_solved_episode, first_solved_time_s (s), best_real_return (NaN when no episode)."""
        returns = self.episodes["real_return"]
        finite = returns[_np.isfinite(returns)]
        return {
            "status": self.status,
            "episodes_done": int(len(returns)),
            "episodes_planned": self.episodes_planned,
            "solved": self.solved,
            "first_solved_episode": self.first_solved_episode,
            "first_solved_time_s": self.first_solved_time_s,
            "best_real_return": float(finite.max()) if len(finite) else float("nan"),
        }

    def __repr__(self):
        return (f"Run({self.name!r}, task={self.task!r}, variant={self.variant!r}, "
                f"status={self.status!r}, episodes={len(self.episodes['episode'])})")


def read_run(directory):
    """Reads a run directory (str or path-like) into a Run with numpy arrays, through drops's
    run-directory reader (read_run, as ``drops report`` reads it).

    Never raises for bad run files: a run whose summary.json or config.yaml cannot be parsed, or
    of another run-directory format version, has status "unreadable" and the reason in `error`.
    Raises Error only when `directory` is not a directory.
    """
    return Run(_drops._read_run(_path(directory, "directory")))
