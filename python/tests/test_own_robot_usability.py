"""What a new user's own robot in Python tripped over: phi shown with significant digits, a run
repeated from its config.yaml, Black-DROPS without a prior in the prior's report panel, defaults
whose cost scales with the data."""

import csv
import json
import re
import sys

import drops
from conftest import SOURCE_DIR, run_cli

sys.path.insert(0, str(SOURCE_DIR / "examples" / "python"))
import pendulum  # noqa: E402

QUIET = dict(quiet=True, progress=lambda line: None)
SMALL = {"optimizer.max_evaluations": 60, "optimizer.prior_optimizations": 1, "episodes": 2}
TIMING = {"model_learning_s", "policy_optimization_s"}


class DampedPrior(pendulum.PendulumPrior):
    """The example's prior with a third, tiny tunable parameter: the joint's damping (N m s/rad),
    started at 0.00025."""
    label = "damped"
    parameters = [*pendulum.PendulumPrior.parameters,
                  drops.Parameter("b", 0.00025, 0.0001, 0.001, unit="N m s/rad", actual=0.1)]

    def evaluate(self, x, u, phi):
        m, l, b = phi
        return pendulum.pendulum_step(x, u, m, l, b, pendulum.SwingUp.dt) - x

    def check_phi(self, phi):
        super().check_phi(phi[:2])


def robot(prior=None):
    return dict(task=pendulum.SwingUp(), system=pendulum.RealPendulum(), prior=prior)


def rows(directory):
    with open(directory / "episodes.csv", newline="") as f:
        return [{k: v for k, v in r.items() if k not in TIMING} for r in csv.DictReader(f)]


def test_phi_is_shown_with_significant_digits_in_progress_lines_and_reports(tmp_path,
                                                                          drops_program):
    lines = []
    drops.run(overrides={**SMALL, "model.type": "gp_prior"}, output=tmp_path / "runs",
              name="b", progress=lines.append, **robot(DampedPrior()))
    episode_lines = [x for x in lines if x.startswith("episode ")]
    # gp_prior keeps the starting phi: b = 0.00025 is shown as such, not as 0.000.
    assert episode_lines and all("b=0.00025" in x for x in episode_lines), episode_lines
    r = run_cli("report", tmp_path / "runs", "--output", tmp_path / "report")
    assert r.returncode == 0, r.stderr
    report = (tmp_path / "report" / "report.md").read_text()
    assert re.search(r"\| 0\.00025 \|", report), report


def test_a_python_run_is_repeated_from_its_config_yaml_with_the_same_objects(tmp_path):
    first = drops.run(overrides={**SMALL, "model.type": "gp_mi"}, seed=4, output=tmp_path,
                      name="first", **QUIET, **robot(pendulum.PendulumPrior()))
    config = tmp_path / "first" / "config.yaml"
    again = drops.run(config, name="again", **QUIET, **robot(pendulum.PendulumPrior()))
    assert rows(tmp_path / "first") == rows(tmp_path / "again")
    assert first.best_real_return == again.best_real_return
    # What config.yaml cannot hold is in summary.json: the robot's declared shape and its prior.
    record = json.loads((tmp_path / "first" / "summary.json").read_text())["task_record"]
    assert record["dt"] == 0.1 and record["horizon"] == 40
    assert [(p["name"], p["value"], p["lower"], p["upper"]) for p in
            record["prior_parameters"]] == [("m", 0.6, 0.2, 2.0), ("l", 0.7, 0.2, 2.0)]


def test_black_drops_without_a_prior_is_drawn_in_the_priors_panel(tmp_path, drops_program):
    runs = tmp_path / "runs"
    prior = pendulum.PendulumPrior()
    drops.run(overrides={**SMALL, "model.type": "gp_mi"}, output=runs, name="mi", **QUIET,
              **robot(prior))
    # model.type gp uses no prior; given one, its runs join that prior's panel as the baseline.
    drops.run(overrides={**SMALL, "model.type": "gp"}, output=runs, name="gp", **QUIET,
              **robot(prior))
    r = run_cli("report", runs, "--output", tmp_path / "report")
    assert r.returncode == 0, r.stderr
    with open(tmp_path / "report" / "returns.csv", newline="") as f:
        panels = {(row["variant"], row["prior"]) for row in csv.DictReader(f)}
    assert panels == {("gp_mi", prior.label), ("gp", prior.label)}, panels


def test_a_python_task_gets_defaults_whose_cost_scales(tmp_path):
    # Variances from a subset of 400 transitions once there are more (the exact variance costs
    # O(N^2) per prediction: the policy search's time grew faster than the data), and 64
    # rollouts per callback.
    drops.run(overrides={"episodes": 1, "model.type": "gp"}, output=tmp_path, name="d", **QUIET,
              **robot())
    config = (tmp_path / "d" / "config.yaml").read_text()
    assert re.search(r"\nmodel:\n(  .*\n)*?  variance_points: 400\n", config), config
    assert re.search(r"\nrollouts:\n(  .*\n)*?  batch: 64\n", config), config
