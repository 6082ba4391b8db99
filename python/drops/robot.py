"""Your own robot in Python: the three things a user writes (docs/python.md, "Your own robot").

- a Task (subclass drops.Task): dimensions, horizon, control period, start state, observation,
  reward, success criterion, the bounds of the policy's action, and optionally a reflection
  symmetry of the robot (drops.Reflection) and a goal state for catch and balance (drops.Goal);
- a System (subclass drops.System): the "real" robot, either step(x, u) for a simulated one or
  begin_episode(x0) returning a session with step(u) for a physical one;
- a Prior (subclass drops.Prior, optional): a simulator with named tunable parameters phi and
  their bounds, evaluated on a whole batch of states at once.

drops.run(task=..., system=..., prior=...) registers them for that run under task.name and runs
any algorithm that needs nothing more (black_drops with model.type gp, gp_prior, gp_mi or mi, and
direct) with the library's policy, model and optimizer chosen by the configuration keys.

Shapes: E = len(state_names), A = len(action_names), O = observation_dim, P = len(parameters),
B = the number of states in a batch (the rollouts running at one step, rollouts.batch at most, or
a block of at most 64 recorded transitions). Every array drops passes is a new float64 array
that the callback may keep or modify.
"""

import math as _math
import re as _re
from dataclasses import dataclass as _dataclass

import numpy as _np


@_dataclass
class Parameter:
    """One named parameter of a simulator prior's phi.

    name: its name (reports, summary.json's phi columns).
    value: the prior's value: the start of GP-MI's and MI's search when tunable, else fixed.
      None (the default) only for a drops.DescriptionPrior, which takes the file's value.
    lower, upper: the interval GP-MI and MI search when tunable (lower <= value <= upper).
    tunable: whether GP-MI and MI may change it.
    actual: the real system's value in the prior's parametrisation (reports; NaN: unknown).
    unit: its unit, for figures (e.g. "kg"; "" for none).
    """
    name: str
    value: float = None
    lower: float = -_math.inf
    upper: float = _math.inf
    tunable: bool = True
    actual: float = _math.nan
    unit: str = ""


@_dataclass
class Reflection:
    """A reflection symmetry of the real robot's dynamics that a Task may declare (C++:
    drops::Reflection). It maps a state x (E,) to state_offset + state_sign * x, an action u (A,)
    to action_sign * u, and the one-step difference dx (E,) to state_sign * dx; the declaration
    claims that the robot stepped from the mapped state with the mapped action moves by the
    mapped difference. With model.reflect_transitions: true the GP models (gp, gp_prior, gp_mi)
    learn every recorded transition and its mirror image (docs/your-own-robot.md, "A symmetry";
    docs/decisions/pendubot-reflected-transitions.md). drops checks the shapes and values, not the
    claim: declare it only if the robot has the symmetry (a damaged leg, a cable on one side or a
    friction that differs with the direction breaks it).

    state_sign: E entries (any sequence of numbers), each +1 or -1.
    action_sign: A entries, each +1 or -1.
    state_offset: E finite entries in the state's units (None: zeros), e.g. 2 pi for an angle
      measured in [0, 2 pi) and mirrored about pi.

    drops.run and drops.resume raise ValueError naming the field for a wrong number of entries, a
    sign other than +1 or -1, or a non-finite offset, and TypeError when Task.reflection is
    neither a drops.Reflection nor None. Plain data: no thread constraints.
    """
    state_sign: object
    action_sign: object
    state_offset: object = None


@_dataclass
class Goal:
    """A goal state that a Task may declare (C++: drops::Goal): where catch and balance
    (policy.balance.mode: lqr, docs/balance.md) hands over from the learned policy to an LQR
    computed from the learned model's mean linearised at (state, action). Without a goal the
    task refuses policy.balance.mode: lqr.

    state: E finite entries, the goal x* in the raw state's units (e.g. a pendulum upright at
      rest: [0, pi] for [dtheta, theta] with theta from hanging).
    action: A finite entries, the action that holds x* (None: zeros).
    angles: indices (0 to E - 1) of the state entries that are angles in rad: the controller's
      error x - x* wraps them into [-pi, pi) (default: none).
    action_limit: A entries > 0, the bounds |u_i| <= action_limit[i] that the controller's
      actions are clipped to (None: Task.max_action for each).

    drops.run and drops.resume raise ValueError naming the field for a wrong number of entries,
    a non-finite value, a limit <= 0 or an angle index out of range, and TypeError when
    Task.goal is neither a drops.Goal nor None. Plain data: no thread constraints.
    """
    state: object
    action: object = None
    angles: object = ()
    action_limit: object = None


class Task:
    """What an episode is (everything but the dynamics). Subclass it and set the attributes.

    Attributes (class or instance):
      name: the task's name, [a-z0-9_]+ (the value of the task key, run directory names).
      state_names: the E names of the raw state x (the trajectory files' columns).
      action_names: the A names of the action u.
      state_units, action_units: their units for figures (lists of str; default: none).
      observation_dim: O, the length of observe()'s rows (the policy's and the GP's input).
      dt: the control period (s): each action is held for dt.
      horizon: H, the steps per episode (an episode lasts H * dt s).
      max_action: the bound of the policy's action, |u_i| <= max_action (the action's unit).
      observation_scale: O divisors of the observation at the policy's input (None: ones), so
        that the network sees values of order 1 (e.g. 10 for an angular velocity in rad/s).
      hidden_units: the policy network's tanh units (the default of the key policy.hidden_units).
      reflection: a drops.Reflection, the robot's reflection symmetry, or None (default: none).
        model.reflect_transitions: true needs one.
      goal: a drops.Goal, the state that catch and balance stabilises, or None (default: none).
        policy.balance.mode: lqr needs one.

    Methods to write; they are called from drops's threads, one call at a time (the interpreter
    lock), and must not depend on the order of the calls:
      initial_state(): x_0, array (E,).
      observe(x): x (B, E) -> (B, O), the observation of each state (e.g. angles as cos, sin).
        Must be finite for finite states.
      reward(x): x (B, E) -> (B,), the reward of reaching each state (finite).
      solved(states, actions, rewards): one episode, states (H + 1, E), actions (H, A),
        rewards (H,) -> bool, whether it solved the task.
    """
    name = "python_task"
    state_names = ()
    action_names = ()
    state_units = None
    action_units = None
    observation_dim = 0
    dt = 0.1
    horizon = 0
    max_action = 1.0
    observation_scale = None
    hidden_units = 10
    reflection = None
    goal = None

    def initial_state(self):
        """x_0, an array (E,)."""
        raise NotImplementedError(f"{type(self).__name__}.initial_state()")

    def observe(self, x):
        """x (B, E) -> the observations (B, O). Default: the state itself (O = E)."""
        return x

    def reward(self, x):
        """x (B, E) -> the reward of reaching each state (B,)."""
        raise NotImplementedError(f"{type(self).__name__}.reward(x)")

    def solved(self, states, actions, rewards):
        """states (H + 1, E), actions (H, A), rewards (H,) -> whether the episode solved the
        task. Default: never (reports then show no success)."""
        return False


class _StepSession:
    """The session of a System that defines step(x, u): x <- step(x, u) from x_0."""

    def __init__(self, system, x0):
        self._system = system
        self._x = x0

    def step(self, u):
        self._x = self._system.step(self._x, u)
        return self._x


class System:
    """The "real" robot. Subclass it and write one of:

      step(x, u): a simulated robot whose recorded state is its whole state: x (E,), u (A,) ->
        the next state (E,) after holding u for one control period dt.
      begin_episode(x0): a physical robot (state the record does not carry, a real clock): bring
        it to its start x0 (E,) and return a session whose step(u) applies u (A,) for dt and
        returns the measured state (E,). One session per episode; episodes run one at a time
        (one thread) for algorithm=black_drops, in parallel for algorithm=direct.

    A next state with a NaN or an infinity ends the episode there (drops's policy for a real
    system that returns a non-finite state: the episode's later rows repeat the last finite
    state with action 0 and reward 0, and the run prints a warning); the run goes on.
    """

    def step(self, x, u):
        """x (E,), u (A,) -> the next state (E,)."""
        raise NotImplementedError(f"{type(self).__name__}.step(x, u) or begin_episode(x0)")

    def begin_episode(self, x0):
        """x0 (E,) -> a session with step(u) -> (E,). Default: steps with self.step(x, u)."""
        return _StepSession(self, x0)


class Prior:
    """A simulator prior M(x, u; phi) -> dx with named parameters phi. Subclass it and set:

      parameters: a list of drops.Parameter (P of them), in phi's order.
      label: a short name of the starting prior (run directory names; default "prior").

    and write evaluate(x, u, phi): x (B, E) raw states, u (B, A) actions, phi (P,) -> the state
    differences dx (B, E) = x_{t+1} - x_t predicted over one control period. One call serves a
    whole batch (vectorise it with numpy): the rollouts of a policy search at one step, or the
    recorded transitions GP-MI scores a phi on. Rows may be NaN or infinite for states or phi the
    simulator cannot handle: drops counts them and GP-MI rejects that phi, as for a C++ prior.
    check_phi(phi) (optional) raises ValueError for a phi outside the simulator's domain (GP-MI
    then scores it -inf).
    """
    parameters = ()
    label = "prior"

    def evaluate(self, x, u, phi):
        """x (B, E), u (B, A), phi (P,) -> dx (B, E)."""
        raise NotImplementedError(f"{type(self).__name__}.evaluate(x, u, phi)")

    def check_phi(self, phi):
        """Raises ValueError when phi (P,) is outside the simulator's domain. Default: any."""


# drops's grammars (C++: drops::experiment::is_column_name, is_directory_name), checked here so
# that the error names the attribute.
_COLUMN_NAME = _re.compile(r"[A-Za-z_][A-Za-z0-9_.]{0,63}")
_DIRECTORY_NAME = _re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,199}")
_TASK_NAME = _re.compile(r"[a-z0-9_]{1,64}")
_RESERVED_COLUMNS = ("t", "reward")
# The ranges of a Task's integers (policy.hidden_units: the key's range).
_MAX_HORIZON = 1_000_000
_MAX_DIM = 100_000
_MAX_HIDDEN_UNITS = 1000


def _shown(value):
    """repr(value), at most 80 characters, for messages."""
    r = repr(value)
    return r if len(r) <= 80 else r[:77] + "..."


def _unicode(value, what):
    """value (a str) when it encodes as UTF-8; ValueError naming `what` for a lone surrogate,
    which no file or C++ string can hold."""
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise ValueError(f"{what} = {_shown(value)}: not valid Unicode text (a lone surrogate)") \
            from None
    return value


def _text(value, what, limit=200):
    """A str that encodes as UTF-8 (no lone surrogate), without NUL or a line break."""
    if not isinstance(value, str):
        raise TypeError(f"{what}: expected a str, got {type(value).__name__} {_shown(value)}")
    _unicode(value, what)
    if any(c in value for c in "\0\n\r") or len(value) > limit:
        raise ValueError(f"{what} = {_shown(value)}: expected at most {limit} characters, without "
                         "NUL or a line break")
    return value


def _names(value, what, seen, trajectory=True):
    """A list of column names (drops's grammar), each new to `seen` (name -> where it was);
    `trajectory`: columns of the trajectory files, where "t" and "reward" are taken."""
    if isinstance(value, (str, bytes)) or value is None:
        raise TypeError(f"{what}: expected a list of names, got {_shown(value)}")
    names = list(value)
    if not names:
        raise ValueError(f"{what}: expected at least one name")
    for n in names:
        if not isinstance(n, str) or not _COLUMN_NAME.fullmatch(n):
            raise ValueError(f"{what}: {_shown(n)} is not a column name: 1 to 64 of A-Z a-z 0-9 _ "
                             ". (the first a letter or _); the run's files name their columns "
                             "with it")
        if trajectory and n in _RESERVED_COLUMNS:
            raise ValueError(f"{what}: {n!r} is reserved (the trajectory files' own columns are "
                             f"{', '.join(_RESERVED_COLUMNS)})")
        if n in seen:
            raise ValueError(f"{what}: {n!r} is named twice (already in {seen[n]}); each name "
                             "must be distinct")
        seen[n] = what
    return names


def _integer(value, what, lo, hi):
    """An int in [lo, hi]: an int or an integral number (not a bool), never truncated."""
    if isinstance(value, bool) or not isinstance(value, (int, float, _np.integer, _np.floating)):
        raise TypeError(f"{what} = {_shown(value)}: expected an integer")
    if isinstance(value, (float, _np.floating)) and not float(value).is_integer():
        raise ValueError(f"{what} = {_shown(value)}: expected an integer (drops does not round)")
    n = int(value)
    if not lo <= n <= hi:
        raise ValueError(f"{what} = {_shown(value)}: expected an integer in [{lo}, {hi}]")
    return n


def _real(value, what, lo=-_math.inf, hi=_math.inf, positive=False):
    """A finite float in [lo, hi] (> 0 when `positive`)."""
    if isinstance(value, bool):
        raise TypeError(f"{what} = {value}: expected a number")
    try:
        x = float(value)
    except OverflowError:
        raise ValueError(f"{what} = {_shown(value)}: too large for a float64") from None
    except (TypeError, ValueError):
        raise TypeError(f"{what} = {_shown(value)}: expected a number") from None
    if not _math.isfinite(x) or not lo <= x <= hi or (positive and not x > 0):
        bound = "> 0 and finite" if positive else f"finite, in [{lo}, {hi}]"
        raise ValueError(f"{what} = {_shown(value)}: expected a number {bound}")
    return x


def _array(value, what, n, default=None):
    """A finite float64 array of n entries; None gives n copies of default when one is given.
    Raises ValueError naming `what` (the count, or the entries that are not finite)."""
    if value is None:
        if default is not None:
            return _np.full(n, default, dtype=float)
        raise ValueError(f"{what}: expected {n} finite numbers, got None")
    try:
        a = _np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{what}: expected {n} finite numbers, got {_shown(value)}") from None
    if a.shape != (n,):
        raise ValueError(f"{what}: expected {n} entries, got {a.size}")
    if not _np.all(_np.isfinite(a)):
        raise ValueError(f"{what}: expected finite entries, got {a.tolist()}")
    return a


def _declared(value, cls, what):
    """Whether the optional declaration `what` (Task.reflection, Task.goal) is given: False for
    None, True for a cls; TypeError naming it otherwise."""
    if value is None:
        return False
    if not isinstance(value, cls):
        raise TypeError(f"{what}: expected a drops.{cls.__name__} or None, got "
                        f"{type(value).__name__}")
    return True


def _reflection_spec(value, E, A, tname):
    """Task.reflection checked: None, or a dict of lists for the C++ side; raises TypeError or
    ValueError naming the field."""
    if not _declared(value, Reflection, f"{tname}.reflection"):
        return None

    def field(v, n, what, signs):
        a = _array(v, f"{tname}.reflection.{what}", n, 0.0)
        if signs and not _np.all(_np.abs(a) == 1):
            raise ValueError(f"{tname}.reflection.{what}: expected +1 or -1 entries, got "
                             f"{a.tolist()}")
        return a.tolist()

    return {"state_sign": field(value.state_sign, E, "state_sign", True),
            "state_offset": field(value.state_offset, E, "state_offset", False),
            "action_sign": field(value.action_sign, A, "action_sign", True)}


def _goal_spec(value, E, A, max_action, tname):
    """Task.goal checked: None, or a dict of lists for the C++ side; raises TypeError or
    ValueError naming the field."""
    if not _declared(value, Goal, f"{tname}.goal"):
        return None
    state = _array(value.state, f"{tname}.goal.state", E)
    action = _array(value.action, f"{tname}.goal.action", A, 0.0)
    limit = _array(value.action_limit, f"{tname}.goal.action_limit", A, max_action)
    if _np.any(limit <= 0):
        raise ValueError(f"{tname}.goal.action_limit: expected entries > 0, got {limit.tolist()}")
    if isinstance(value.angles, (str, bytes)):
        raise TypeError(f"{tname}.goal.angles: expected a list of state indices, got "
                        f"{_shown(value.angles)}")
    angles = []
    for a in value.angles:
        if isinstance(a, bool) or not isinstance(a, (int, _np.integer)) or not 0 <= a < E:
            raise ValueError(f"{tname}.goal.angles: expected state indices in [0, {E - 1}], got "
                             f"{_shown(list(value.angles))}")
        angles.append(int(a))
    return {"state": state.tolist(), "action": action.tolist(), "action_limit": limit.tolist(),
            "angles": angles}


def _robot_spec(task, system, prior, builtin_tasks=()):
    """Checks the user's objects and returns what the C++ side reads (a dict); raises TypeError
    or ValueError naming the attribute (docs/python.md, "What drops refuses"). builtin_tasks: the
    names a Python task may not take."""
    tname = type(task).__name__
    if not isinstance(task, Task):
        raise TypeError(f"task: expected a drops.Task (subclass it), got {tname}")
    if system is None or not callable(getattr(system, "begin_episode", None)):
        raise TypeError("system: expected a drops.System (with step(x, u) or begin_episode(x0)), "
                        f"got {type(system).__name__}")
    if prior is not None and not isinstance(prior, Prior):
        raise TypeError(f"prior: expected a drops.Prior or None, got {type(prior).__name__}")
    name = task.name
    if not isinstance(name, str) or not _TASK_NAME.fullmatch(name):
        raise ValueError(f"{tname}.name = {_shown(name)}: expected 1 to 64 of [a-z0-9_] (it names "
                         "the task key and run directories)")
    if name in builtin_tasks:
        raise ValueError(f"{tname}.name = {name!r}: the name of a built-in task (reports would "
                         f"mix their runs); choose another (built-in: {', '.join(builtin_tasks)})")
    columns = {}
    state_names = _names(task.state_names, f"{tname}.state_names", columns)
    action_names = _names(task.action_names, f"{tname}.action_names", columns)
    E, A = len(state_names), len(action_names)

    def units(value, n, what):
        if value is None:
            return [""] * n
        if isinstance(value, (str, bytes)):
            raise TypeError(f"{tname}.{what}: expected a list of {n} units, got {_shown(value)}")
        u = [_text(v, f"{tname}.{what}[{i}]", 64) for i, v in enumerate(value)]
        if len(u) != n:
            raise ValueError(f"{tname}.{what}: expected {n} units, got {len(u)}")
        return u

    O = _integer(task.observation_dim, f"{tname}.observation_dim", 1, _MAX_DIM)
    dt = _real(task.dt, f"{tname}.dt (the control period, s)", positive=True)
    H = _integer(task.horizon, f"{tname}.horizon (steps per episode)", 1, _MAX_HORIZON)
    hidden = _integer(task.hidden_units, f"{tname}.hidden_units", 1, _MAX_HIDDEN_UNITS)
    max_action = _real(task.max_action, f"{tname}.max_action", positive=True)
    x0 = task.initial_state()
    try:
        x0 = _np.asarray(x0, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{tname}.initial_state() returned {_shown(x0)}, expected ({E},) finite "
                         "values") from None
    if x0.shape != (E,) or not _np.all(_np.isfinite(x0)):
        raise ValueError(f"{tname}.initial_state() returned shape {x0.shape}, expected ({E},) "
                         "finite values")
    scale = _np.ones(O) if task.observation_scale is None else \
        _array(task.observation_scale, f"{tname}.observation_scale", O)
    if _np.any(scale == 0):
        raise ValueError(f"{tname}.observation_scale: expected {O} non-zero divisors, got "
                         f"{scale.tolist()}")
    reflection = _reflection_spec(task.reflection, E, A, tname)
    goal = _goal_spec(task.goal, E, A, max_action, tname)
    pname = type(prior).__name__
    params = []
    if prior is not None:
        if isinstance(prior.parameters, (str, bytes)):
            raise TypeError(f"{pname}.parameters: expected a list of drops.Parameter")
        params = list(prior.parameters)
        if not params:
            raise ValueError(f"{pname}.parameters: expected at least one drops.Parameter")
        label = prior.label
        if not isinstance(label, str) or not _DIRECTORY_NAME.fullmatch(label):
            raise ValueError(f"{pname}.label = {_shown(label)}: expected 1 to 200 of A-Z a-z 0-9 "
                             "_ . - (the first a letter, a digit or _): it names run "
                             "directories")
    seen_params = {}
    values, lower, upper, actual = [], [], [], []
    for i, p in enumerate(params):
        if not isinstance(p, Parameter):
            raise TypeError(f"{pname}.parameters[{i}]: expected drops.Parameter, got {_shown(p)}")
        _names([p.name], f"{pname}.parameters", seen_params, trajectory=False)
        what = f"{pname}.parameters: {p.name}"
        if p.value is None:
            raise TypeError(f"{what}.value: None (only a drops.DescriptionPrior takes a value "
                            "from its file); give a number")
        values.append(_real(p.value, f"{what}.value"))
        lower.append(-_math.inf if p.lower == -_math.inf else _real(p.lower, f"{what}.lower"))
        upper.append(_math.inf if p.upper == _math.inf else _real(p.upper, f"{what}.upper"))
        if p.tunable and not (_math.isfinite(lower[-1]) and _math.isfinite(upper[-1])
                              and lower[-1] <= values[-1] <= upper[-1]):
            raise ValueError(f"{pname}.parameters: {p.name} = {p.value} must lie in finite bounds "
                             f"[{p.lower}, {p.upper}]")
        a = float(p.actual) if not isinstance(p.actual, bool) else _math.nan
        actual.append(a if _math.isfinite(a) else _math.nan)
        _text(p.unit, f"{what}.unit", 64)
    # A prior with a C++ side (drops.DescriptionPrior): the run calls it directly; its
    # dimensions are checked against the task's here, before anything runs.
    native_for_run = getattr(prior, "_native_for_run", None)
    native = native_for_run(E, A, dt, tname) if callable(native_for_run) else None
    # What the library cannot read from the task, the policy and the prior (TaskSetup::
    # declaration): recorded in the run and compared on resume.
    declaration = {
        "python.max_action": repr(max_action),
        "python.observation_scale": repr(scale.tolist()),
    }
    if reflection is not None:
        declaration["python.reflection"] = repr(reflection)
    if goal is not None:
        declaration["python.goal"] = repr(goal)
    return {
        "name": name,
        "description": f"a task written in Python ({tname})",
        "task_class": tname,
        "prior_class": pname if prior is not None else "Prior",
        "declaration": declaration,
        "prior_label": prior.label if prior is not None else "none",
        "state_names": state_names, "action_names": action_names,
        "state_units": units(task.state_units, E, "state_units"),
        "action_units": units(task.action_units, A, "action_units"),
        "observation_dim": O, "horizon": H, "dt": dt, "initial_state": x0.tolist(),
        "max_action": max_action, "observation_scale": scale.tolist(),
        "hidden_units": hidden,
        "reflection": reflection,
        "goal": goal,
        "phi_names": [p.name for p in params], "phi_units": [p.unit for p in params],
        "phi_values": values, "phi_lower": lower, "phi_upper": upper,
        "phi_tunable": [bool(p.tunable) for p in params],
        "phi_actual": [] if any(_math.isnan(a) for a in actual) else actual,
        "has_check_phi": prior is not None and type(prior).check_phi is not Prior.check_phi,
        "native_prior": native,
    }
