"""A torque-limited pendulum swing-up as your own robot in Python (docs/python.md).

The pendulum (a point mass m at the end of a massless rod of length l, viscous friction b at the
joint) hangs at rest and must be swung up and balanced with a torque too weak to lift it
directly (|u| <= 5 N m < m g l = 9.81 N m). The simulator prior is the same physics in
vectorised numpy with the wrong mass and length (0.6 kg, 0.7 m instead of 1 kg, 1 m): Black-DROPS
with GP-MI tunes them from the real episodes while it learns the policy.

Run it from the repository (after scripts/build):

    PYTHONPATH=build/python /usr/bin/python3 examples/python/pendulum.py --output /tmp/runs

It prints drops's progress lines, the identified phi, and writes learning-curve.png next to the
run directory.
"""

import argparse
import pathlib

import numpy as np

import drops

G = 9.81  # gravity, m/s^2


def pendulum_step(x, u, m, l, b, dt, substeps=4):
    """One control period of the pendulum for a batch: x (B, 2) = [dtheta (rad/s), theta (rad,
    0 hanging)], u (B, 1) torque (N m, held), m (kg), l (m), b (N m s/rad) scalars -> the next
    states (B, 2). RK4 with `substeps` steps."""
    torque = u[:, 0]

    def f(s):
        dtheta, theta = s[:, 0], s[:, 1]
        ddtheta = (torque - b * dtheta - m * G * l * np.sin(theta)) / (m * l * l)
        return np.stack([ddtheta, dtheta], axis=1)

    h = dt / substeps
    for _ in range(substeps):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


class SwingUp(drops.Task):
    """Swing the pendulum up from hanging at rest and balance it: 4 s at 10 Hz."""
    name = "pendulum"
    state_names = ["dtheta", "theta"]
    state_units = ["rad/s", "rad"]
    action_names = ["torque"]
    action_units = ["N·m"]
    observation_dim = 3          # [dtheta, cos theta, sin theta]
    observation_scale = [10, 1, 1]
    dt = 0.1
    horizon = 40
    max_action = 5.0
    # The pendulum mirrored about the vertical (theta -> -theta, dtheta -> -dtheta, torque ->
    # -torque) moves as the mirror image of the original: model.reflect_transitions=true lets
    # the GP learn every swing to the left as a swing to the right too.
    reflection = drops.Reflection(state_sign=[-1, -1], action_sign=[-1])
    length = 1.0                 # the real rod's length, for the tip in the reward (m)
    sigma = 0.5                  # width of the reward (m)

    def initial_state(self):
        return np.zeros(2)

    def observe(self, x):
        return np.stack([x[:, 0], np.cos(x[:, 1]), np.sin(x[:, 1])], axis=1)

    def tip_distance(self, x):
        """Distance (m) of the tip to the upright tip, for states x (B, 2)."""
        dx = self.length * np.sin(x[:, 1])
        dy = -self.length * np.cos(x[:, 1]) - self.length
        return np.hypot(dx, dy)

    def reward(self, x):
        return np.exp(-self.tip_distance(x) ** 2 / (2 * self.sigma ** 2))

    def solved(self, states, actions, rewards):
        # The tip within 0.2 m of upright for the last second.
        return bool(np.all(self.tip_distance(states[-10:]) < 0.2))


class RealPendulum(drops.System):
    """The "real" pendulum: m = 1 kg, l = 1 m, b = 0.1 N m s/rad."""
    m, l, b = 1.0, 1.0, 0.1

    def step(self, x, u):
        return pendulum_step(x[None, :], u[None, :], self.m, self.l, self.b, SwingUp.dt)[0]


class PendulumPrior(drops.Prior):
    """The simulator prior: the same physics with phi = [m, l] wrong and tunable."""
    label = "m0.6-l0.7"
    parameters = [
        drops.Parameter("m", 0.6, 0.2, 2.0, unit="kg", actual=RealPendulum.m),
        drops.Parameter("l", 0.7, 0.2, 2.0, unit="m", actual=RealPendulum.l),
    ]
    b = 0.1

    def evaluate(self, x, u, phi):
        m, l = phi
        return pendulum_step(x, u, m, l, self.b, SwingUp.dt) - x

    def check_phi(self, phi):
        if np.any(phi <= 0):
            raise ValueError(f"mass and length must be > 0, got {phi}")


def plot_learning_curve(run, path):
    """Draws the return of each real episode and the identified phi of a run (drops.read_run)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ep = run.episodes
    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.5))
    a.plot(ep["episode"], ep["real_return"], "o-", label="real episode")
    a.plot(ep["episode"], ep["predicted_return"], "x--", label="predicted by the model")
    a.set_xlabel("episode")
    a.set_ylabel("return (sum of rewards)")
    a.set_title("learning curve")
    a.legend()
    for j, name in enumerate(run.phi_names):
        line, = b.plot(ep["episode"], ep["phi"][:, j], "o-", label=f"{name} (GP-MI)")
        b.axhline(run.phi_actual[j], color=line.get_color(), ls=":", label=f"{name} (real)")
    b.set_xlabel("episode")
    b.set_ylabel("phi (kg, m)")
    b.set_title("prior parameters")
    b.legend()
    for ax in (a, b):
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))  # episodes
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", default="runs", help="parent of the run directory")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--episodes", type=int, default=5)
    parser.add_argument("--reflect", action="store_true",
                        help="learn every transition and its mirror image "
                             "(model.reflect_transitions, SwingUp.reflection)")
    parser.add_argument("--balance", action="store_true",
                        help="catch and balance: near upright an LQR of the learned model takes "
                             "over (policy.balance.mode lqr, SwingUp's goal)")
    parser.add_argument("--dt", type=float, default=SwingUp.dt,
                        help="control period (s; default %(default)s)")
    parser.add_argument("--horizon", type=int, default=SwingUp.horizon,
                        help="steps per episode (default %(default)s)")
    # A smaller policy-search budget than the pendubot's suffices for this 51-parameter policy.
    parser.add_argument("--evaluations", type=int, default=2000,
                        help="optimizer.max_evaluations (default %(default)s; drops's: 10000)")
    parser.add_argument("--threads", type=int, default=0, help="threads (0 = every core)")
    parser.add_argument("--variance-points", type=int, default=None,
                        help="model.variance_points (default: the Python task's, 400)")
    args = parser.parse_args()
    # The task, the real pendulum and the prior read the control period and the horizon from
    # the class.
    SwingUp.dt, SwingUp.horizon = args.dt, args.horizon
    settings = {"model.type": "gp_mi", "episodes": args.episodes, "threads": args.threads,
                "optimizer.max_evaluations": args.evaluations,
                "model.reflect_transitions": args.reflect}
    if args.variance_points is not None:
        settings["model.variance_points"] = args.variance_points
    task = SwingUp()
    if args.balance:
        # Upright at rest (theta from hanging is an angle): the state the LQR holds.
        task.goal = drops.Goal(state=[0.0, np.pi], angles=[1])
        settings["policy.balance.mode"] = "lqr"
    out = drops.run(overrides=settings,
                    seed=args.seed, output=args.output,
                    task=task, system=RealPendulum(), prior=PendulumPrior())
    run = drops.read_run(out.directory)
    print("identified phi:", dict(zip(run.phi_names, run.episodes["phi"][-1])))
    png = pathlib.Path(out.directory) / "learning-curve.png"
    plot_learning_curve(run, png)
    print("learning curve:", png)


if __name__ == "__main__":
    main()
