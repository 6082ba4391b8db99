"""Your own robot in Python: the three things a user writes (docs/python.md, "Your own robot").

- a Task (subclass drops.Task): dimensions, horizon, control period, start state, observation,
  reward, success criterion, the bounds of the policy's action, and optionally a reflection
  symmetry of the robot (drops.Reflection);
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
from dataclasses import dataclass as _dataclass

import numpy as _np


@_dataclass
class Parameter:
    """One named parameter of a simulator prior's phi.

    name: its name (reports, summary.json's phi columns).
    value: the prior's value: the start of GP-MI's and MI's search when tunable, else fixed.
    lower, upper: the interval GP-MI and MI search when tunable (lower <= value <= upper).
    tunable: whether GP-MI and MI may change it.
    actual: the real system's value in the prior's parametrisation (reports; NaN: unknown).
    unit: its unit, for figures (e.g. "kg"; "" for none).
    """
    name: str
    value: float
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


def _names(value, what):
    names = [str(n) for n in (value or ())]
    if not names:
        raise ValueError(f"{what}: expected at least one name")
    return names


def _reflection_spec(value, E, A, tname):
    """Task.reflection checked: None, or a dict of lists for the C++ side; raises TypeError or
    ValueError naming the field."""
    if value is None:
        return None
    if not isinstance(value, Reflection):
        raise TypeError(f"{tname}.reflection: expected a drops.Reflection or None, got "
                        f"{type(value).__name__}")

    def field(v, n, what, signs):
        a = _np.zeros(n) if v is None else _np.asarray(v, dtype=float).reshape(-1)
        if a.shape != (n,):
            raise ValueError(f"{tname}.reflection.{what}: expected {n} entries, got {a.size}")
        if signs and not _np.all(_np.abs(a) == 1):
            raise ValueError(f"{tname}.reflection.{what}: expected +1 or -1 entries, got "
                             f"{a.tolist()}")
        if not _np.all(_np.isfinite(a)):
            raise ValueError(f"{tname}.reflection.{what}: expected finite entries, got "
                             f"{a.tolist()}")
        return a.tolist()

    return {"state_sign": field(value.state_sign, E, "state_sign", True),
            "state_offset": field(value.state_offset, E, "state_offset", False),
            "action_sign": field(value.action_sign, A, "action_sign", True)}


def _robot_spec(task, system, prior):
    """Checks the user's objects and returns what the C++ side reads (a dict); raises TypeError
    or ValueError naming the attribute."""
    tname = type(task).__name__
    if not isinstance(task, Task):
        raise TypeError(f"task: expected a drops.Task (subclass it), got {tname}")
    if system is None or not callable(getattr(system, "begin_episode", None)):
        raise TypeError("system: expected a drops.System (with step(x, u) or begin_episode(x0)), "
                        f"got {type(system).__name__}")
    if prior is not None and not isinstance(prior, Prior):
        raise TypeError(f"prior: expected a drops.Prior or None, got {type(prior).__name__}")
    name = str(task.name)
    if not name or not all(c.isdigit() or c == "_" or ("a" <= c <= "z") for c in name):
        raise ValueError(f"{tname}.name = {name!r}: expected [a-z0-9_]+")
    state_names = _names(task.state_names, f"{tname}.state_names")
    action_names = _names(task.action_names, f"{tname}.action_names")
    E, A = len(state_names), len(action_names)

    def units(value, n, what):
        u = [""] * n if value is None else [str(v) for v in value]
        if len(u) != n:
            raise ValueError(f"{tname}.{what}: expected {n} units, got {len(u)}")
        return u

    O = int(task.observation_dim)
    if O < 1:
        raise ValueError(f"{tname}.observation_dim = {task.observation_dim}: expected >= 1")
    dt, H = float(task.dt), int(task.horizon)
    if not dt > 0:
        raise ValueError(f"{tname}.dt = {task.dt}: expected a control period > 0 (s)")
    if H < 1:
        raise ValueError(f"{tname}.horizon = {task.horizon}: expected >= 1 steps")
    x0 = _np.asarray(task.initial_state(), dtype=float)
    if x0.shape != (E,) or not _np.all(_np.isfinite(x0)):
        raise ValueError(f"{tname}.initial_state() returned shape {x0.shape}, expected ({E},) "
                         "finite values")
    scale = _np.ones(O) if task.observation_scale is None else \
        _np.asarray(task.observation_scale, dtype=float)
    if scale.shape != (O,) or _np.any(scale == 0):
        raise ValueError(f"{tname}.observation_scale: expected {O} non-zero divisors, got "
                         f"{scale.tolist()}")
    if not float(task.max_action) > 0:
        raise ValueError(f"{tname}.max_action = {task.max_action}: expected > 0")
    reflection = _reflection_spec(task.reflection, E, A, tname)
    params = list(prior.parameters) if prior is not None else []
    pname = type(prior).__name__
    for p in params:
        if not isinstance(p, Parameter):
            raise TypeError(f"{pname}.parameters: expected drops.Parameter, got {p!r}")
        if p.tunable and not (p.lower <= p.value <= p.upper and _math.isfinite(p.lower)
                              and _math.isfinite(p.upper)):
            raise ValueError(f"{pname}.parameters: {p.name} = {p.value} must lie in finite bounds "
                             f"[{p.lower}, {p.upper}]")
    if prior is not None and not params:
        raise ValueError(f"{pname}.parameters: expected at least one drops.Parameter")
    actual = [float(p.actual) for p in params]
    return {
        "name": name,
        "description": f"a task written in Python ({tname})",
        "task_class": tname,
        "prior_label": str(getattr(prior, "label", "prior")) if prior is not None else "none",
        "state_names": state_names, "action_names": action_names,
        "state_units": units(task.state_units, E, "state_units"),
        "action_units": units(task.action_units, A, "action_units"),
        "observation_dim": O, "horizon": H, "dt": dt, "initial_state": x0.tolist(),
        "max_action": float(task.max_action), "observation_scale": scale.tolist(),
        "hidden_units": int(task.hidden_units),
        "reflection": reflection,
        "phi_names": [p.name for p in params], "phi_units": [p.unit for p in params],
        "phi_values": [float(p.value) for p in params],
        "phi_lower": [float(p.lower) for p in params],
        "phi_upper": [float(p.upper) for p in params],
        "phi_tunable": [bool(p.tunable) for p in params],
        "phi_actual": [] if any(_math.isnan(a) for a in actual) else actual,
        "has_check_phi": prior is not None and type(prior).check_phi is not Prior.check_phi,
    }
