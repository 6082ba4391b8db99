"""The cost of a simulator prior written in Python: the pendubot in vectorised numpy against the
built-in C++ pendubot, Black-DROPS with GP-MI, same settings and seed (docs/benchmarks.md,
"A prior in Python").

The Python side is the whole robot (drops.Task, drops.System, drops.Prior): the same equations,
integrator, observation, reward and success test as the C++ task (tasks/pendubot), with Table I's
prior A (m1 = 0.65, l2 = 0.4; m1, m2, l1, l2 tunable in [0.05, 1]). Both runs use the pendubot's
defaults (the default `drops run`); the numpy run passes the one default the pendubot task sets
for itself (model.gp_mi.score = sum_likelihoods). Prints, per run: the whole run's wall time,
the policy search's evaluations per second on the model learned from N = 100 transitions
(episode 3's search, after two episodes of 50 steps), and the time spent inside the Python
callbacks.

Run from the repository after scripts/build:

    PYTHONPATH=build/python /usr/bin/python3 bench/python_prior.py [--repeats 2] [--batch 8 64]
        [--variants numpy numba]

The numba variant needs Debian's python3-numba (scripts/install-deps installs it).
"""

import argparse
import csv
import pathlib
import tempfile
import time

import numpy as np

import drops

G = 9.82           # gravity (m/s^2), the C++ task's Params::g
DT = 0.05          # control period (s)
HORIZON = 50       # 2.5 s
SUBSTEPS = 5       # RK4 substeps per control period
MAX_TORQUE = 3.5   # |u| bound (N m)
ACTUAL = {"m1": 0.5, "m2": 0.5, "l1": 0.5, "l2": 0.5, "b1": 0.1, "b2": 0.1}


def derivative(s, u, m1, m2, l1, l2, b1, b2):
    """d/dt of the states s = (dth1, dth2, th1, th2), four arrays (B,), under torques u (B,) at
    joint 1; the parameters are floats. Returns four arrays (B,)."""
    dth1, dth2, th1, th2 = s
    i1, i2 = m1 * l1 * l1 / 12.0, m2 * l2 * l2 / 12.0
    s1, c1, s2, c2 = np.sin(th1), np.cos(th1), np.sin(th2), np.cos(th2)
    s12, c12 = s1 * c2 - c1 * s2, c1 * c2 + s1 * s2
    a11 = l1 * l1 * (0.25 * m1 + m2) + i1
    a12 = (0.5 * m2 * l1 * l2) * c12
    a22 = 0.25 * l2 * l2 * m2 + i2
    f1 = (G * l1 * (0.5 * m1 + m2)) * s1 - (0.5 * m2 * l1 * l2) * dth2 * dth2 * s12 + u - b1 * dth1
    f2 = (0.5 * m2 * l2) * (l1 * dth1 * dth1 * s12 + G * s2) - b2 * dth2
    det = a11 * a22 - a12 * a12
    return (a22 * f1 - a12 * f2) / det, (a11 * f2 - a12 * f1) / det, dth1, dth2


def step(x, u, phi):
    """One control period for a batch in vectorised numpy: x (B, 4), u (B, 1) N m,
    phi [m1, m2, l1, l2, b1, b2] -> the next states (B, 4). RK4, SUBSTEPS steps."""
    p = [float(v) for v in phi]
    u = np.clip(u[:, 0], -MAX_TORQUE, MAX_TORQUE)
    h = DT / SUBSTEPS
    s = tuple(x.T)
    for _ in range(SUBSTEPS):
        k1 = derivative(s, u, *p)
        k2 = derivative(tuple(a + 0.5 * h * k for a, k in zip(s, k1)), u, *p)
        k3 = derivative(tuple(a + 0.5 * h * k for a, k in zip(s, k2)), u, *p)
        k4 = derivative(tuple(a + h * k for a, k in zip(s, k3)), u, *p)
        s = tuple(a + h / 6.0 * (q1 + 2 * q2 + 2 * q3 + q4)
                  for a, q1, q2, q3, q4 in zip(s, k1, k2, k3, k4))
    return np.stack(s, axis=1)


def compiled_step():
    """The same step, compiled by numba (Debian's python3-numba): a loop over the rows, each a
    scalar RK4 - what a prior with many small operations per state gains from compilation."""
    import numba

    @numba.njit(cache=False)
    def deriv(d1, d2, t1, t2, u, m1, m2, l1, l2, b1, b2):
        i1, i2 = m1 * l1 * l1 / 12.0, m2 * l2 * l2 / 12.0
        s1, c1, s2, c2 = np.sin(t1), np.cos(t1), np.sin(t2), np.cos(t2)
        s12, c12 = s1 * c2 - c1 * s2, c1 * c2 + s1 * s2
        a11 = l1 * l1 * (0.25 * m1 + m2) + i1
        a12 = 0.5 * m2 * l1 * l2 * c12
        a22 = 0.25 * l2 * l2 * m2 + i2
        f1 = G * l1 * s1 * (0.5 * m1 + m2) - 0.5 * m2 * l1 * l2 * d2 * d2 * s12 + u - b1 * d1
        f2 = 0.5 * m2 * l2 * (l1 * d1 * d1 * s12 + G * s2) - b2 * d2
        det = a11 * a22 - a12 * a12
        return (a22 * f1 - a12 * f2) / det, (a11 * f2 - a12 * f1) / det, d1, d2

    @numba.njit(cache=False)
    def rows(x, u, phi):
        m1, m2, l1, l2, b1, b2 = phi[0], phi[1], phi[2], phi[3], phi[4], phi[5]
        h = DT / SUBSTEPS
        out = np.empty_like(x)
        for r in range(x.shape[0]):
            tq = min(max(u[r, 0], -MAX_TORQUE), MAX_TORQUE)
            s = (x[r, 0], x[r, 1], x[r, 2], x[r, 3])
            for _ in range(SUBSTEPS):
                k1 = deriv(s[0], s[1], s[2], s[3], tq, m1, m2, l1, l2, b1, b2)
                k2 = deriv(s[0] + 0.5 * h * k1[0], s[1] + 0.5 * h * k1[1], s[2] + 0.5 * h * k1[2],
                           s[3] + 0.5 * h * k1[3], tq, m1, m2, l1, l2, b1, b2)
                k3 = deriv(s[0] + 0.5 * h * k2[0], s[1] + 0.5 * h * k2[1], s[2] + 0.5 * h * k2[2],
                           s[3] + 0.5 * h * k2[3], tq, m1, m2, l1, l2, b1, b2)
                k4 = deriv(s[0] + h * k3[0], s[1] + h * k3[1], s[2] + h * k3[2], s[3] + h * k3[3],
                           tq, m1, m2, l1, l2, b1, b2)
                s = (s[0] + h / 6.0 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
                     s[1] + h / 6.0 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]),
                     s[2] + h / 6.0 * (k1[2] + 2 * k2[2] + 2 * k3[2] + k4[2]),
                     s[3] + h / 6.0 * (k1[3] + 2 * k2[3] + 2 * k3[3] + k4[3]))
            out[r, 0], out[r, 1], out[r, 2], out[r, 3] = s
        return out

    return rows


class Clock:
    """Seconds and calls spent inside the Python callbacks."""
    seconds = 0.0
    calls = 0

    @classmethod
    def timed(cls, f):
        def wrapped(*args):
            t = time.perf_counter()
            try:
                return f(*args)
            finally:
                cls.seconds += time.perf_counter() - t
                cls.calls += 1
        return wrapped


class SwingUp(drops.Task):
    """The pendubot swing-up (tasks/pendubot's SwingUpTask)."""
    name = "pendubot_numpy"
    state_names = ["dtheta1", "dtheta2", "theta1", "theta2"]
    action_names = ["u"]
    observation_dim = 6
    observation_scale = [10, 10, 1, 1, 1, 1]
    dt = DT
    horizon = HORIZON
    max_action = MAX_TORQUE

    def initial_state(self):
        return np.array([0.0, 0.0, np.pi, np.pi])

    @Clock.timed
    def observe(self, x):
        return np.stack([x[:, 0], x[:, 1], np.cos(x[:, 2]), np.sin(x[:, 2]),
                         np.cos(x[:, 3]), np.sin(x[:, 3])], axis=1)

    @staticmethod
    def goal_distance(x):
        l1, l2 = ACTUAL["l1"], ACTUAL["l2"]
        tx = -l1 * np.sin(x[:, 2]) - l2 * np.sin(x[:, 3])
        ty = l1 * np.cos(x[:, 2]) + l2 * np.cos(x[:, 3])
        return np.hypot(tx, ty - (l1 + l2))

    @Clock.timed
    def reward(self, x):
        d = self.goal_distance(x)
        r = np.exp(-0.5 * d * d / 0.25)
        return np.where(np.isfinite(r), r, 0.0)

    def solved(self, states, actions, rewards):
        return bool(np.all(self.goal_distance(states[-10:]) <= 0.15))


class RealPendubot(drops.System):
    def step(self, x, u):
        return step(x[None, :], u[None, :], list(ACTUAL.values()))[0]


class PriorA(drops.Prior):
    """Table I's prior A: m1 = 0.65 and l2 = 0.4 instead of 0.5."""
    label = "tunable-useful"
    parameters = [
        drops.Parameter("m1", 0.65, 0.05, 1.0, unit="kg", actual=ACTUAL["m1"]),
        drops.Parameter("m2", 0.5, 0.05, 1.0, unit="kg", actual=ACTUAL["m2"]),
        drops.Parameter("l1", 0.5, 0.05, 1.0, unit="m", actual=ACTUAL["l1"]),
        drops.Parameter("l2", 0.4, 0.05, 1.0, unit="m", actual=ACTUAL["l2"]),
        drops.Parameter("b1", 0.1, tunable=False, actual=ACTUAL["b1"]),
        drops.Parameter("b2", 0.1, tunable=False, actual=ACTUAL["b2"]),
    ]

    def __init__(self, step_function=step):
        self.step = step_function

    @Clock.timed
    def evaluate(self, x, u, phi):
        return self.step(x, u, phi) - x

    def check_phi(self, phi):
        if np.any(phi[:4] < 0.01) or np.any(phi[4:] < 0):
            raise ValueError(f"masses and lengths must be >= 0.01, frictions >= 0: {phi}")


def check_port(directory, steps):
    """Replays the C++ run's first real episode (its actions, from its start state) through each
    Python pendubot of `steps` (name -> step function) and checks it reproduces the states: the
    port's check. The CSV files hold about 10 significant digits, hence the tolerance."""
    real = drops.read_run(directory).real(1)
    for name, f in steps.items():
        x = real.x[:1]
        for k in range(real.u.shape[0]):
            x = f(x, real.u[k:k + 1], np.array(list(ACTUAL.values())))
            if not np.allclose(x[0], real.x[k + 1], rtol=1e-6, atol=1e-6):
                raise SystemExit(f"the {name} pendubot differs from the C++ one at step {k + 1}: "
                                 f"{x[0]} against {real.x[k + 1]}")
            x = real.x[k + 1:k + 2]  # the next step from the recorded state


def measure(output, overrides, robot, steps):
    Clock.seconds, Clock.calls = 0.0, 0
    t = time.perf_counter()
    out = drops.run(overrides=overrides, seed=1, output=output, quiet=True, **robot)
    wall = time.perf_counter() - t
    if not robot:
        check_port(out.directory, steps)
    ep = drops.read_run(out.directory).episodes
    # Episode 3's policy was searched on the model of episodes 1-2 (N = 100 transitions); the
    # search's time and evaluations are episodes.csv columns.
    with open(pathlib.Path(out.directory) / "episodes.csv") as f:
        third = list(csv.DictReader(f))[2]
    eval_per_s = float(third["evaluations"]) / float(third["policy_optimization_s"])
    return {"wall": wall, "eval_per_s": eval_per_s,
            "callbacks": Clock.seconds, "calls": Clock.calls,
            "returns": ep["real_return"], "solved": int(np.argmax(ep["solved"])) + 1
            if np.any(ep["solved"]) else None}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeats", type=int, default=1, help="runs of each configuration")
    parser.add_argument("--batch", type=int, nargs="+", default=[8],
                        help="values of rollouts.batch to measure (default: 8, the default)")
    parser.add_argument("--threads", type=int, default=0, help="threads (0 = every core)")
    parser.add_argument("--variants", nargs="+", default=["numpy", "numba"],
                        choices=["numpy", "numba"], help="the Python priors to measure")
    args = parser.parse_args()
    steps = {v: compiled_step() if v == "numba" else step for v in args.variants}
    rows = []
    with tempfile.TemporaryDirectory() as output:
        for batch in args.batch:
            common = {"episodes": 10, "threads": args.threads, "rollouts.batch": batch}
            for _ in range(args.repeats):  # alternate, so that a busy moment hits every variant
                cpp = measure(output, {**common, "task": "pendubot"}, {}, steps)
                print(f"rollouts.batch={batch}: C++ prior {cpp['wall']:.1f} s, evaluations/s at "
                      f"N=100: {cpp['eval_per_s']:.0f}, first solved {cpp['solved']}", flush=True)
                for variant in args.variants:
                    py = measure(output, {**common, "model.gp_mi.score": "sum_likelihoods"},
                                 {"task": SwingUp(), "system": RealPendubot(),
                                  "prior": PriorA(steps[variant])}, steps)
                    rows.append((batch, variant, cpp, py))
                    print(f"  {variant} prior {py['wall']:.1f} s ({py['wall'] / cpp['wall']:.2f}x), "
                          f"evaluations/s at N=100: {py['eval_per_s']:.0f}, Python callbacks "
                          f"{py['callbacks']:.1f} s in {py['calls']} calls, first solved "
                          f"{py['solved']}", flush=True)
    print("\n| rollouts.batch | prior | run (s) | C++ prior's run (s) | ratio | evaluations/s at "
          "N=100 (C++ prior's) | in Python callbacks (s) | callback calls | first solved |")
    print("|---|---|---|---|---|---|---|---|---|")
    for batch, variant, cpp, py in rows:
        print(f"| {batch} | {variant} | {py['wall']:.1f} | {cpp['wall']:.1f} | "
              f"{py['wall'] / cpp['wall']:.2f} | {py['eval_per_s']:.0f} ({cpp['eval_per_s']:.0f}) "
              f"| {py['callbacks']:.1f} | {py['calls']} | {py['solved']} ({cpp['solved']}) |")


if __name__ == "__main__":
    main()
