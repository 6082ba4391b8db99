"""A robot's URDF or MJCF file as the simulator prior, its physical parameters as named phi
(issue 64; C++: drops::description::DescriptionPrior; docs/your-own-robot.md, "From a URDF or
MJCF file").
"""

import dataclasses as _dataclasses
import math as _math
import os as _os
import re as _re
import warnings as _warnings

import numpy as _np

from . import _drops
from .robot import Parameter, Prior, _shown, _unicode


def _native_class():
    cls = getattr(_drops, "_DescriptionPrior", None)
    if cls is None:
        raise _drops.Error("drops.DescriptionPrior: this drops was built without MuJoCo "
                           "(DROPS_WITH_MUJOCO off; scripts/install-deps installs libmujoco-dev)")
    return cls


def _name_list(value, what):
    if value is None:
        return []
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{what}: expected a list of names, got {_shown(value)}")
    names = list(value)
    for i, n in enumerate(names):
        if not isinstance(n, str):
            raise TypeError(f"{what}[{i}]: expected a str, got {_shown(n)}")
        _unicode(n, f"{what}[{i}]")
        if "\0" in n:
            raise ValueError(f"{what}[{i}] = {_shown(n)}: holds a NUL character")
    return names


class DescriptionPrior(Prior):
    """A URDF or MJCF file as the simulator prior M(x, u; phi) -> dx, loaded by MuJoCo and
    evaluated in C++: a run uses the C++ prior directly, on every thread, without the interpreter
    lock and without a Python call per batch.

    file: the URDF (<robot>) or MJCF (<mujoco>) file (str or path-like).
    joints: the n joints of the state, in this order (None: every joint of the file, from the
      base). The state is x = [q, qd] (E = 2n): the joints' positions (rad, or m for a slide
      joint), then their velocities (rad/s or m/s), in this order; the Task's state_names must
      follow it (drops.run refuses a Task whose E or A differ).
    actuated: the m joints the action drives, in the order of u (None: the state's joints); u is
      their torques (N m, or N for a slide joint), times their gear.
    parameters: phi, each a drops.Parameter or a plain name. Names: `<body>.mass` (kg),
      `<body>.com.x|y|z` (m, in the body's frame), `<body>.inertia` (a scale of the file's
      inertia), `<joint>.damping` (N m s/rad), `<joint>.friction` (Coulomb, N m),
      `<joint>.armature` (kg m^2), `<joint>.gear` (driven joints only), `gravity` (m/s^2);
      available_parameters() lists the file's. A Parameter whose value is None takes the file's
      value (default_phi()); an empty unit takes the parameter's unit; a tunable one needs
      finite bounds inside the physical domain (parameter_domain). A plain name is a fixed
      parameter (tunable=False) at the file's value.
    substeps: RK4 steps per control period (>= 1); dt comes from the Task at drops.run.
    coulomb_velocity: v_s of the smooth Coulomb friction f_c tanh(qd / v_s) (rad/s, > 0).
    label: the run directories' prior label (default: the file's name without its suffix).

    Attributes: parameters (the resolved drops.Parameter list, P of them), label, file,
    joint_names (n), actuated_joint_names (m), warnings (what loading found that does not stop
    the prior, e.g. missing mesh files; each also issued as a UserWarning).

    Raises drops.InvalidArgument (a ValueError) naming the file and the item, before anything
    runs, for: a file that cannot be read or does not parse (with MuJoCo's message); a joint,
    body or parameter name not in it (the message lists the names it has); a floating base or a
    ball joint; bounds that are not finite, reversed, or outside the parameter's physical domain
    (a negative mass, an inertia scale <= 0, ...); a value outside its bounds or domain. TypeError
    for arguments of the wrong type; drops.Error when drops was built without MuJoCo. MuJoCo's
    fatal errors later raise drops.NumericalError naming the file (never an exit).

    Thread safety: evaluate and check_phi may be called from several threads; they release the
    interpreter lock while MuJoCo runs.
    """

    def __init__(self, file, joints=None, actuated=None, parameters=(), substeps=10,
                 coulomb_velocity=0.01, label=None):
        try:
            path = _os.fsdecode(_os.fspath(file))
        except TypeError:
            raise TypeError(f"file: expected a str or path-like, got {type(file).__name__}") \
                from None
        if "\0" in path:
            raise ValueError(f"file = {path[:80]!r}: a path cannot hold a NUL character")
        self.file = _unicode(path, "file")
        self._joints = _name_list(joints, "joints")
        self._actuated = _name_list(actuated, "actuated")
        if isinstance(parameters, (str, bytes, Parameter)):
            raise TypeError("parameters: expected a list of drops.Parameter or names, got "
                            f"{_shown(parameters)}")
        entries = list(parameters)
        names = []
        for i, p in enumerate(entries):
            if isinstance(p, str):
                names.append(p)
            elif isinstance(p, Parameter):
                if not isinstance(p.name, str):
                    raise TypeError(f"parameters[{i}].name: expected a str, got {_shown(p.name)}")
                names.append(p.name)
            else:
                raise TypeError(f"parameters[{i}]: expected a drops.Parameter or a name, got "
                                f"{_shown(p)}")
        self._names = _name_list(names, "parameters")
        if isinstance(substeps, bool) or not isinstance(substeps, (int, _np.integer)):
            raise TypeError(f"substeps = {_shown(substeps)}: expected an int")
        self._substeps = int(substeps)
        if isinstance(coulomb_velocity, bool) or \
                not isinstance(coulomb_velocity, (int, float, _np.integer, _np.floating)):
            raise TypeError(f"coulomb_velocity = {_shown(coulomb_velocity)}: expected a number")
        self._coulomb_velocity = float(coulomb_velocity)
        self._natives = {}
        native = self._native(0.01)  # names, file and options checked here, before any run
        self.joint_names = list(native.joint_names())
        self.actuated_joint_names = list(native.actuated_joint_names())
        self.warnings = list(native.warnings())
        for w in self.warnings:
            _warnings.warn(w, UserWarning, stacklevel=2)
        defaults = native.default_phi()
        where = f"description prior '{self.file}'"
        resolved = []
        for i, p in enumerate(entries):
            if isinstance(p, str):
                p = Parameter(p, tunable=False)
            lower, upper, lower_open, unit, what = native.parameter_domain(i)
            changes = {}
            if p.value is None:
                changes["value"] = float(defaults[i])
            if not p.unit:
                changes["unit"] = unit
            p = _dataclasses.replace(p, **changes)
            if p.tunable:
                native.check_bounds(i, float(p.lower), float(p.upper))
                if not p.lower <= p.value <= p.upper:
                    raise _drops.InvalidArgument(
                        f"{where}: {p.name} = {p.value}: the value must lie in its bounds "
                        f"[{p.lower}, {p.upper}]")
            resolved.append(p)
        self.parameters = resolved
        native.check_phi(_np.array([float(p.value) for p in resolved]))
        if label is None:
            stem = _os.path.splitext(_os.path.basename(self.file))[0]
            label = _re.sub(r"[^A-Za-z0-9_.-]", "_", stem).lstrip(".-") or "description"
        self.label = label

    def _native(self, dt):
        """The C++ prior for the control period dt (s), made once per dt."""
        dt = float(dt)
        if dt not in self._natives:
            self._natives[dt] = _native_class()(
                self.file, self._joints, self._actuated, self._names, dt, self._substeps,
                self._coulomb_velocity)
        return self._natives[dt]

    def _native_for_run(self, E, A, dt, tname):
        """The C++ prior a run of a task with E states, A actions and period dt uses; ValueError
        when the task's dimensions are not the prior's (drops.run, before anything runs)."""
        n, m = len(self.joint_names), len(self.actuated_joint_names)
        if E != 2 * n or A != m:
            raise ValueError(
                f"{tname} and DescriptionPrior('{self.file}'): the task has E = {E} states and "
                f"A = {A} actions, the prior E = {2 * n} (the positions then the velocities of "
                f"{', '.join(self.joint_names)}, in this order) and A = {m} (the torques of "
                f"{', '.join(self.actuated_joint_names)})")
        return self._native(dt)

    def evaluate(self, x, u, phi=None, dt=0.01):
        """x (B, E) states [q, qd], u (B, A) torques, phi (P,) (None: the parameters' values)
        -> dx (B, E), the change of the state over one control period dt (s). A run uses the
        Task's dt; the default 0.01 s is the C++ prior's. A non-finite state gives a non-finite
        row. Raises drops.InvalidArgument for a wrong shape (naming it). Releases the
        interpreter lock while MuJoCo runs."""
        if phi is None:
            phi = [p.value for p in self.parameters]
        x = _np.asarray(x, dtype=float)
        u = _np.asarray(u, dtype=float)
        phi = _np.asarray(phi, dtype=float)
        E, A, P = 2 * len(self.joint_names), len(self.actuated_joint_names), len(self._names)
        if x.ndim != 2 or x.shape[1] != E or u.ndim != 2 or u.shape != (x.shape[0], A) or \
                phi.shape != (P,):
            raise _drops.InvalidArgument(
                f"DescriptionPrior.evaluate: expected x (B, {E}), u (B, {A}) and phi ({P},), got "
                f"x {x.shape}, u {u.shape}, phi {phi.shape}")
        if not (isinstance(dt, (int, float, _np.integer, _np.floating)) and
                _math.isfinite(dt) and dt > 0) or isinstance(dt, bool):
            raise ValueError(f"dt = {_shown(dt)}: expected a number > 0 (s)")
        return self._native(dt).evaluate(x, u, phi)

    def check_phi(self, phi):
        """Raises drops.InvalidArgument (a ValueError) naming the file and the parameter when phi
        (P,) has the wrong size or a value outside its physical domain."""
        self._native(0.01).check_phi(_np.asarray(phi, dtype=float).reshape(-1))

    def default_phi(self):
        """The file's values of the parameters (P,) (gear and inertia scale 1)."""
        return self._native(0.01).default_phi()

    def body_names(self):
        """The file's bodies (links), the world excluded (list of str)."""
        return list(self._native(0.01).body_names())

    def available_parameters(self):
        """Every parameter name the file offers (bodies, then joints, then gravity)."""
        return list(self._native(0.01).available_parameters())

    def _index(self, name_or_index):
        if isinstance(name_or_index, str):
            i = self._names.index(name_or_index) if name_or_index in self._names else -1
            if i < 0:
                raise _drops.InvalidArgument(
                    f"description prior '{self.file}': '{name_or_index}' is not one of its "
                    f"parameters ({', '.join(self._names) or 'none'})")
            return i
        return int(name_or_index)

    def parameter_domain(self, name_or_index):
        """The physical domain of a parameter (its name or index in phi): a dict with lower,
        upper, lower_open (True: lower itself excluded, as for an inertia scale), unit, what."""
        lower, upper, lower_open, unit, what = \
            self._native(0.01).parameter_domain(self._index(name_or_index))
        return {"lower": lower, "upper": upper, "lower_open": lower_open, "unit": unit,
                "what": what}

    def check_bounds(self, name_or_index, lower, upper):
        """Raises drops.InvalidArgument naming the file and the parameter when [lower, upper] is
        not finite, reversed, or leaves the parameter's physical domain."""
        self._native(0.01).check_bounds(self._index(name_or_index), float(lower), float(upper))

    def __repr__(self):
        return (f"DescriptionPrior({self.file!r}, joints={self.joint_names}, "
                f"actuated={self.actuated_joint_names}, parameters={self._names})")
