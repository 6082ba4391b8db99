"""Your own robot in Python (examples/python/pendulum.py): GP-MI identifies the example's wrong
prior and swings it up; a callback's exception comes out as itself and the run resumes; Ctrl-C
inside a callback stops the run after its step (a physical robot's step is never repeated); wrong
shapes and non-finite values are refused naming the callback; the same seed gives the same
episodes with 1 and 2 threads; the algorithms that need only a task, a system and a prior run; a
declared reflection reaches the model and a wrong one is refused naming the field; a declared
goal gives catch and balance the LQR of the learned model, and a wrong one is refused."""

import csv
import json
import re
import sys

import numpy as np
import pytest

import drops
from conftest import SOURCE_DIR

sys.path.insert(0, str(SOURCE_DIR / "examples" / "python"))
import pendulum  # noqa: E402

TIMING = {"model_learning_s", "policy_optimization_s"}
# A small budget: a few seconds per run.
SMALL = {"optimizer.max_evaluations": 300, "optimizer.prior_optimizations": 1}


def robot():
    return dict(task=pendulum.SwingUp(), system=pendulum.RealPendulum(),
                prior=pendulum.PendulumPrior())


def rows(directory):
    with open(directory / "episodes.csv", newline="") as f:
        return [{k: v for k, v in r.items() if k not in TIMING} for r in csv.DictReader(f)]


def test_gp_mi_identifies_the_examples_prior_and_swings_the_pendulum_up(tmp_path):
    settings = {"model.type": "gp_mi", "episodes": 4,
                "optimizer.max_evaluations": 1500, "optimizer.prior_optimizations": 1}
    out = drops.run(overrides=settings, seed=1, output=tmp_path, name="learn", quiet=True,
                    progress=lambda line: None, **robot())
    assert out.status == "complete"
    run = drops.read_run(out.directory)
    assert run.task == "pendulum" and run.phi_names == ["m", "l"]
    # Measured with seed 1: solved from episode 3 with a return of 20.2 (of at most 40); the
    # random first episode gets 0.04.
    assert run.episodes["solved"][-1], run.episodes["real_return"]
    assert out.best_real_return > 15
    np.testing.assert_allclose(run.episodes["phi"][-1], [1.0, 1.0], rtol=0.1)
    x = run.real(1).x
    assert x.shape == (41, 2) and run.state_names == ["dtheta", "theta"]
    # A task written in Python batches 64 rollouts per call by default (the built-in tasks 8).
    config = (tmp_path / "learn" / "config.yaml").read_text()
    assert re.search(r"\nrollouts:\n(  .*\n)*?  batch: 64\n", config), config


class Broken(Exception):
    pass


class FailingSystem(pendulum.RealPendulum):
    """The real pendulum, raising Broken at the start of its episode number `fail_at`."""

    def __init__(self, fail_at):
        self.fail_at, self.episodes = fail_at, 0

    def begin_episode(self, x0):
        self.episodes += 1
        if self.episodes == self.fail_at:
            raise Broken("the robot fell off the table")
        return super().begin_episode(x0)


def test_a_callbacks_exception_comes_out_as_itself_and_the_run_resumes(tmp_path):
    r = robot()
    r["system"] = FailingSystem(fail_at=3)
    with pytest.raises(Broken, match="the robot fell off the table"):
        drops.run(overrides={**SMALL, "episodes": 4}, output=tmp_path, name="f", quiet=True,
                  progress=lambda line: None, **r)
    summary = json.loads((tmp_path / "f" / "summary.json").read_text())
    assert summary["status"] == "failed" and len(summary["episodes"]) == 2
    assert "System.begin_episode raised Broken: the robot fell off the table" in summary["error"]
    more = drops.resume(tmp_path / "f", quiet=True, progress=lambda line: None, **robot())
    assert more.status == "complete" and more.episodes_done == 4
    # ... with the episodes of a run that never failed.
    drops.run(overrides={**SMALL, "episodes": 4}, output=tmp_path, name="g", quiet=True,
              progress=lambda line: None, **robot())
    assert rows(tmp_path / "f") == rows(tmp_path / "g")


class CtrlCPrior(pendulum.PendulumPrior):
    """The example's prior, in which KeyboardInterrupt is raised once after `arm()` was called
    (as Python raises it inside a callback when Ctrl-C arrives)."""
    armed = False

    def arm(self):
        self.armed = True

    def evaluate(self, x, u, phi):
        if self.armed:
            self.armed = False
            raise KeyboardInterrupt
        return super().evaluate(x, u, phi)


def test_ctrl_c_inside_a_callback_stops_the_run_after_its_step_and_it_resumes(tmp_path):
    r = robot()
    r["prior"] = prior = CtrlCPrior()
    settings = {**SMALL, "episodes": 4}

    def progress(line):  # Ctrl-C during episode 2's model learning or policy search
        if line.startswith("episode  1/"):
            prior.arm()

    with pytest.raises(KeyboardInterrupt):
        drops.run(overrides=settings, output=tmp_path, name="c", progress=progress, **r)
    summary = json.loads((tmp_path / "c" / "summary.json").read_text())
    assert summary["status"] == "interrupted" and len(summary["episodes"]) == 1
    more = drops.resume(tmp_path / "c", quiet=True, progress=lambda line: None, **robot())
    assert more.status == "complete" and more.episodes_done == 4
    drops.run(overrides=settings, output=tmp_path, name="g", quiet=True,
              progress=lambda line: None, **robot())
    assert rows(tmp_path / "c") == rows(tmp_path / "g")


class CtrlCSession:
    """A physical robot's session whose step is interrupted by Ctrl-C."""
    steps = 0

    def step(self, u):
        CtrlCSession.steps += 1
        raise KeyboardInterrupt


class CtrlCRobot(pendulum.RealPendulum):
    """Episode 1 runs as the simulated pendulum; Ctrl-C arrives in episode 2's first step."""
    episodes = 0

    def begin_episode(self, x0):
        self.episodes += 1
        return super().begin_episode(x0) if self.episodes == 1 else CtrlCSession()


def test_ctrl_c_inside_a_physical_robots_step_is_not_repeated_and_fails_the_run(tmp_path):
    r = robot()
    r["system"] = CtrlCRobot()
    with pytest.raises(KeyboardInterrupt):
        drops.run(overrides={**SMALL, "episodes": 3}, output=tmp_path, name="p", quiet=True,
                  progress=lambda line: None, **r)
    assert CtrlCSession.steps == 1  # the robot's step is never made twice
    summary = json.loads((tmp_path / "p" / "summary.json").read_text())
    assert summary["status"] == "failed" and len(summary["episodes"]) == 1
    more = drops.resume(tmp_path / "p", quiet=True, progress=lambda line: None, **robot())
    assert more.status == "complete" and more.episodes_done == 3


class RaisingPrior(pendulum.PendulumPrior):
    def evaluate(self, x, u, phi):
        raise KeyError("no such joint")


def test_an_exception_in_the_prior_on_drops_threads_comes_out_as_itself(tmp_path):
    r = robot()
    r["prior"] = RaisingPrior()
    with pytest.raises(KeyError, match="no such joint"):
        drops.run(overrides={**SMALL, "episodes": 2, "model.type": "gp_prior"}, threads=2,
                  output=tmp_path, name="k", quiet=True, progress=lambda line: None, **r)


class ShortPrior(pendulum.PendulumPrior):
    def evaluate(self, x, u, phi):
        return super().evaluate(x, u, phi)[:, :1]


class ShortObservation(pendulum.SwingUp):
    def observe(self, x):
        return x


class NanReward(pendulum.SwingUp):
    def reward(self, x):
        r = super().reward(x)
        r[0] = np.nan
        return r


def test_wrong_shapes_and_non_finite_values_are_refused_naming_the_callback(tmp_path):
    cases = [
        ("prior", ShortPrior(), r"Prior\.evaluate returned an array of shape \((\d+), 1\), "
                                r"expected \(\1, 2\) \(B = \1 states x E = 2 state differences\)"),
        ("task", ShortObservation(), r"ShortObservation\.observe returned an array of shape "
                                     r"\((\d+), 2\), expected \(\1, 3\)"),
        ("task", NanReward(), r"NanReward\.reward returned a non-finite value in row 0"),
    ]
    for i, (what, obj, message) in enumerate(cases):
        r = robot()
        r[what] = obj
        with pytest.raises(drops.InvalidArgument, match=message):
            drops.run(overrides={**SMALL, "episodes": 2, "model.type": "gp_prior"},
                      output=tmp_path, name=f"s{i}", quiet=True, progress=lambda line: None, **r)
    with pytest.raises(ValueError, match=r"SwingUp.initial_state\(\) returned shape \(3,\)"):
        task = pendulum.SwingUp()
        task.initial_state = lambda: np.zeros(3)
        drops.run(output=tmp_path, task=task, system=pendulum.RealPendulum())


def test_the_same_seed_gives_the_same_episodes_with_1_and_2_threads(tmp_path):
    for threads in (1, 2):
        drops.run(overrides={**SMALL, "episodes": 3, "model.type": "gp_mi"}, threads=threads,
                  seed=4, output=tmp_path, name=f"t{threads}", quiet=True,
                  progress=lambda line: None, **robot())
    assert rows(tmp_path / "t1") == rows(tmp_path / "t2")
    for k in (1, 2, 3):
        for name in ("real.csv", "policy.csv"):
            a = (tmp_path / "t1" / "episodes" / f"{k:03d}" / name).read_text()
            assert a == (tmp_path / "t2" / "episodes" / f"{k:03d}" / name).read_text()


def test_every_algorithm_that_needs_only_the_three_pieces_runs_and_the_others_are_refused(tmp_path):
    model_based = {**SMALL, "episodes": 2}
    runs = {"gp": {**model_based, "model.type": "gp"},
            "gp_prior": {**model_based, "model.type": "gp_prior"},
            "mi": {**model_based, "model.type": "mi"},
            "direct": {"algorithm": "direct", "optimizer.max_evaluations": 12}}  # 12 episodes
    for name, settings in runs.items():
        out = drops.run(overrides=settings, output=tmp_path, name=name, quiet=True,
                        progress=lambda line: None, **robot())
        run = drops.read_run(out.directory)
        assert out.status == "complete" and run.algorithm == settings.get("algorithm",
                                                                          "black_drops")
        assert len(run.episodes["episode"]) == (12 if name == "direct" else 2)
        # MI moves phi from the prior's start on the first episode's data; gp_prior keeps it.
        if name == "mi":
            assert not np.allclose(run.episodes["phi"][-1], [0.6, 0.7])
        if name == "gp_prior":
            np.testing.assert_array_equal(run.episodes["phi"][-1], [0.6, 0.7])
    # A task written in Python declares no IT&E behaviour descriptor and no PILCO task model.
    for algorithm in ("ite", "pilco"):
        with pytest.raises(drops.ConfigError, match=f"'algorithm' = '{algorithm}'"):
            drops.run(overrides={"algorithm": algorithm}, output=tmp_path, quiet=True,
                      progress=lambda line: None, **robot())


def test_a_declared_reflection_is_learned_and_a_wrong_one_is_refused_naming_the_field(tmp_path):
    # The example's pendulum declares its mirror about the vertical; with the key on, the GPs
    # learn each recorded transition and its mirror image (C++ Models tests check that the
    # predictions become equivariant), so the policies differ from the second episode on, and
    # the run still learns the swing-up.
    for name, reflect in (("off", False), ("on", True)):
        drops.run(overrides={"model.type": "gp_mi", "episodes": 4,
                             "optimizer.max_evaluations": 1500,
                             "optimizer.prior_optimizations": 1,
                             "model.reflect_transitions": reflect},
                  seed=1, output=tmp_path, name=name, quiet=True, progress=lambda line: None,
                  **robot())
    off, on = rows(tmp_path / "off"), rows(tmp_path / "on")
    assert on[0] == off[0]  # the random first episode
    assert on[1]["real_return"] != off[1]["real_return"]
    run = drops.read_run(tmp_path / "on")
    assert run.episodes["solved"][-1], run.episodes["real_return"]
    np.testing.assert_allclose(run.episodes["phi"][-1], [1.0, 1.0], rtol=0.1)

    bad = [(drops.Reflection(state_sign=[-1, 0.5], action_sign=[-1]), ValueError,
            r"SwingUp\.reflection\.state_sign: expected \+1 or -1 entries, got \[-1\.0, 0\.5\]"),
           (drops.Reflection(state_sign=[-1, -1, 1], action_sign=[-1]), ValueError,
            r"SwingUp\.reflection\.state_sign: expected 2 entries, got 3"),
           (drops.Reflection(state_sign=[-1, -1], action_sign=[-1], state_offset=[0, np.inf]),
            ValueError, r"SwingUp\.reflection\.state_offset: expected finite entries"),
           (drops.Reflection(state_sign=[-1, -1], action_sign=[]), ValueError,
            r"SwingUp\.reflection\.action_sign: expected 1 entries, got 0"),
           ((-1, -1), TypeError, r"SwingUp\.reflection: expected a drops\.Reflection or None, "
                                 r"got tuple")]
    for reflection, error, message in bad:
        task = pendulum.SwingUp()
        task.reflection = reflection
        with pytest.raises(error, match=message):
            drops.run(output=tmp_path, task=task, system=pendulum.RealPendulum())
    # The key needs a declared reflection.
    task = pendulum.SwingUp()
    task.reflection = None
    with pytest.raises(drops.InvalidArgument, match="model.reflect_transitions"):
        drops.run(overrides={**SMALL, "model.reflect_transitions": True}, output=tmp_path,
                  name="none", quiet=True, progress=lambda line: None, task=task,
                  system=pendulum.RealPendulum(), prior=pendulum.PendulumPrior())


def lqr_gain(m, l, b=pendulum.PendulumPrior.b, dt=pendulum.SwingUp.dt, h=1e-5):
    """The oracle: the LQR gain (Q = I, R = 1) of the example pendulum with mass m and length l
    linearised upright at rest by central differences, the Riccati recursion run to a fixed
    point."""
    xs = np.array([0.0, np.pi])

    def f(x, u):
        return pendulum.pendulum_step(x[None, :], np.array([[u]]), m, l, b, dt)[0]

    A = np.stack([(f(xs + d, 0.0) - f(xs - d, 0.0)) / (2 * h) for d in np.eye(2) * h], axis=1)
    B = ((f(xs, h) - f(xs, -h)) / (2 * h))[:, None]
    P = np.eye(2)
    for _ in range(10000):
        K = np.linalg.solve(1.0 + B.T @ P @ B, B.T @ P @ A)
        P_next = np.eye(2) + A.T @ P @ (A - B @ K)
        done = np.max(np.abs(P_next - P)) < 1e-13 * np.max(np.abs(P))
        P = P_next
        if done:
            break
    return np.linalg.solve(1.0 + B.T @ P @ B, B.T @ P @ A)[0]


def test_a_declared_goal_lets_catch_and_balance_run_and_a_wrong_one_is_refused_naming_the_field(
        tmp_path):
    # The pendulum upright at rest (theta from hanging, an angle). With policy.balance.mode lqr,
    # each episode's LQR comes from the model it plans on: episode 1's from the prior (m = 0.6,
    # l = 0.7), the later ones' from GP-MI's model of the real pendulum (m = l = 1). The oracle
    # is the LQR of each pendulum's own linearisation.
    task = pendulum.SwingUp()
    task.goal = drops.Goal(state=[0, np.pi], angles=[1])
    out = drops.run(overrides={"model.type": "gp_mi", "episodes": 4,
                               "optimizer.max_evaluations": 1500,
                               "optimizer.prior_optimizations": 1, "policy.balance.mode": "lqr"},
                    seed=1, output=tmp_path, name="lqr", quiet=True, progress=lambda line: None,
                    task=task, system=pendulum.RealPendulum(), prior=pendulum.PendulumPrior())
    assert out.status == "complete"
    episodes = json.loads((tmp_path / "lqr" / "summary.json").read_text())["episodes"]

    def gain(e):
        return np.array([e["details"]["balance_k_0_0"], e["details"]["balance_k_0_1"]])

    # Measured with seed 1: K = [1.8881, 6.9730] in episode 1 and [5.3932, 17.0239] from
    # episode 2 on, against the oracle's [1.8881, 6.9730] and [5.3931, 17.0238].
    np.testing.assert_allclose(gain(episodes[0]), lqr_gain(0.6, 0.7), rtol=1e-3)
    np.testing.assert_allclose(gain(episodes[-1]), lqr_gain(1.0, 1.0), rtol=1e-2)
    assert all(e["details"]["balance_usable"] == 1 for e in episodes)
    # The real episode hands over (measured: at step 26, 14 steps under the LQR) and is solved.
    last = episodes[-1]
    assert last["details"]["balance_first_step"] >= 0 and last["details"]["balance_steps"] > 0
    assert last["solved"], [e["real_return"] for e in episodes]

    bad = [(drops.Goal(state=[0, np.pi, 0]), ValueError,
            r"SwingUp\.goal\.state: expected 2 entries, got 3"),
           (drops.Goal(state=None), ValueError,
            r"SwingUp\.goal\.state: expected 2 finite numbers, got None"),
           (drops.Goal(state=[0, np.nan]), ValueError,
            r"SwingUp\.goal\.state: expected finite entries"),
           (drops.Goal(state=[0, np.pi], angles=[2]), ValueError,
            r"SwingUp\.goal\.angles: expected state indices in \[0, 1\], got \[2\]"),
           (drops.Goal(state=[0, np.pi], action_limit=[0]), ValueError,
            r"SwingUp\.goal\.action_limit: expected entries > 0"),
           (drops.Goal(state=[0, np.pi], action=[0, 0]), ValueError,
            r"SwingUp\.goal\.action: expected 1 entries, got 2"),
           ([0, np.pi], TypeError, r"SwingUp\.goal: expected a drops\.Goal or None, got list")]
    for goal, error, message in bad:
        task = pendulum.SwingUp()
        task.goal = goal
        with pytest.raises(error, match=message):
            drops.run(output=tmp_path, task=task, system=pendulum.RealPendulum())
    # lqr needs a declared goal.
    with pytest.raises(drops.ConfigError, match="declares no goal state"):
        drops.run(overrides={**SMALL, "policy.balance.mode": "lqr"}, output=tmp_path,
                  name="no-goal", quiet=True, progress=lambda line: None, **robot())
