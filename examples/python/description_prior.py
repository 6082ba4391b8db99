"""A robot from its URDF in about 30 lines: the DFKI double pendulum (both joints driven) as the
simulator prior, its second link's mass and its shoulder's damping as phi (docs/your-own-robot.md,
"From a URDF or MJCF file").

The "real" robot here is the same file with other values (a heavier second link, 0.9 kg instead of
the file's 0.63 kg; more shoulder damping, 0.25 instead of 0.081 N m s/rad): Black-DROPS with GP-MI
tunes phi toward them from the real episodes while it learns to swing the pendulum up.

    PYTHONPATH=build/python /usr/bin/python3 examples/python/description_prior.py --output /tmp/runs
"""

import argparse
import pathlib

import numpy as np

import drops

URDF = pathlib.Path(__file__).resolve().parents[2] / "tests/data/double-pendulum-dfki/double_pendulum.urdf"
REAL = {"Link2.mass": 0.9, "Joint1.damping": 0.25}  # the real robot's values


# --- The task and the parameters: 30 lines. ---
class SwingUp(drops.Task):
    """Swing the tip (0.3 m and 0.2 m links, joints about x) from hanging to upright in 3 s."""
    name = "dfki_double_pendulum"
    state_names = ["q1", "q2", "dq1", "dq2"]  # the prior's order: positions, then velocities
    action_names = ["tau1", "tau2"]
    observation_dim, observation_scale = 6, [1, 1, 1, 1, 10, 10]
    dt, horizon, max_action = 0.05, 60, 2.0

    def initial_state(self):
        return np.zeros(4)

    def observe(self, x):
        return np.column_stack([np.cos(x[:, :2]), np.sin(x[:, :2]), x[:, 2:]])

    def reward(self, x):
        y = 0.3 * np.sin(x[:, 0]) + 0.2 * np.sin(x[:, 0] + x[:, 1])
        z = -0.3 * np.cos(x[:, 0]) - 0.2 * np.cos(x[:, 0] + x[:, 1])
        return np.exp(-(y ** 2 + (z - 0.5) ** 2) / (2 * 0.25 ** 2))


def parameters():
    return [drops.Parameter("Link2.mass", lower=0.3, upper=1.5, actual=REAL["Link2.mass"]),
            drops.Parameter("Joint1.damping", lower=0.0, upper=0.5, actual=REAL["Joint1.damping"])]


prior = drops.DescriptionPrior(URDF, parameters=parameters(), label="dfki-urdf")
# --- End of the 30 lines. ---


class RealPendulum(drops.System):
    """The "real" robot: the same file with REAL's values (the prior's C++ side, dt of the task)."""

    def step(self, x, u):
        phi = [REAL[p.name] for p in prior.parameters]
        return x + prior.evaluate(x[None, :], u[None, :], phi, dt=SwingUp.dt)[0]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--output", default="runs", help="parent of the run directory")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--episodes", type=int, default=4)
    parser.add_argument("--evaluations", type=int, default=2000,
                        help="optimizer.max_evaluations (default %(default)s)")
    parser.add_argument("--threads", type=int, default=0, help="threads (0 = every core)")
    args = parser.parse_args()
    out = drops.run(overrides={"model.type": "gp_mi", "episodes": args.episodes,
                               "optimizer.max_evaluations": args.evaluations,
                               "threads": args.threads},
                    seed=args.seed, output=args.output,
                    task=SwingUp(), system=RealPendulum(), prior=prior)
    run = drops.read_run(out.directory)
    print("returns:", np.round(run.episodes["real_return"], 2))
    print("phi (file -> identified, real):")
    for j, name in enumerate(run.phi_names):
        print(f"  {name}: {run.episodes['phi'][0, j]:.3f} -> {run.episodes['phi'][-1, j]:.3f}, "
              f"{run.phi_actual[j]:.3f}")


if __name__ == "__main__":
    main()
