"""A run from Python is the command line's run: the same episodes.csv, trajectories and policies
for the same config, overrides and seed; its run directory reads back into arrays that match the
files; it resumes and extends like `drops run --resume`."""

import csv
import json
import os
import pathlib
import subprocess

import numpy as np
import pytest

import drops
from conftest import DROPS_BINARY, GP_MI_CONFIG, TINY, run_cli

TIMING = {"model_learning_s", "policy_optimization_s"}


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


@pytest.fixture(scope="module")
def runs(tmp_path_factory, drops_program):
    out = tmp_path_factory.mktemp("runs")
    cli = run_cli("run", GP_MI_CONFIG, *TINY, "--seed", 2, "--output", out, "--name", "cli", "-q")
    assert cli.returncode == 0, cli.stderr
    lines = []
    outcome = drops.run(GP_MI_CONFIG, TINY, seed=2, output=out, name="py", progress=lines.append)
    return out, outcome, lines


def test_a_python_run_writes_the_episodes_of_the_command_line_with_the_same_seed(runs):
    out, outcome, _ = runs
    assert outcome.status == "complete" and outcome.episodes_done == 3
    assert pathlib.Path(outcome.directory) == out / "py"
    cli, py = read_csv(out / "cli" / "episodes.csv"), read_csv(out / "py" / "episodes.csv")
    assert len(py) == 3
    assert [{k: v for k, v in r.items() if k not in TIMING} for r in py] == \
           [{k: v for k, v in r.items() if k not in TIMING} for r in cli]
    for k in (1, 2, 3):
        for name in ("real.csv", "predicted.csv", "policy.csv"):
            a = (out / "cli" / "episodes" / f"{k:03d}" / name).read_text()
            b = (out / "py" / "episodes" / f"{k:03d}" / name).read_text()
            assert a == b, f"episode {k} {name}"
    assert (out / "cli" / "config.yaml").read_text().replace("name: cli", "name: py") == \
           (out / "py" / "config.yaml").read_text()


def test_progress_lines_are_the_command_lines(runs):
    _, outcome, lines = runs
    assert lines[0].startswith("drops run: pendubot with gp_mi (prior ")
    assert lines[1] == "run directory: " + outcome.directory
    assert [l.split()[1] for l in lines if l.startswith("episode ")] == ["1/3", "2/3", "3/3"]
    assert lines[-1].startswith("done: 3 episodes") and lines[-1].endswith(outcome.directory)


def test_quiet_gives_only_the_final_line(tmp_path):
    lines = []
    drops.run(GP_MI_CONFIG, TINY[1:] + ["episodes=1"], output=tmp_path, name="q", quiet=True,
              progress=lines.append)
    assert len(lines) == 1 and lines[0].startswith("done: 1 episodes")


def test_a_run_directory_reads_into_arrays_that_match_its_csv_files(runs):
    out, _, _ = runs
    run = drops.read_run(out / "py")
    assert run.status == "complete" and run.task == "pendubot" and run.variant == "gp_mi"
    assert run.seed == 2 and run.episodes_planned == 3
    rows = read_csv(out / "py" / "episodes.csv")
    ep = run.episodes
    assert ep["episode"].tolist() == [int(r["episode"]) for r in rows]
    np.testing.assert_allclose(ep["real_return"], [float(r["real_return"]) for r in rows],
                               atol=1e-6)
    np.testing.assert_allclose(ep["predicted_return"],
                               [float(r["predicted_return"]) for r in rows], atol=1e-6)
    np.testing.assert_allclose(ep["interaction_time_s"],
                               [float(r["interaction_time_s"]) for r in rows], atol=1e-3)
    assert ep["solved"].tolist() == [r["solved"] == "1" for r in rows]
    phi = np.array([[float(v) for v in r["phi"].split()] for r in rows])
    assert ep["phi"].shape == (3, len(run.phi_names)) == phi.shape
    np.testing.assert_allclose(ep["phi"], phi, rtol=1e-5)
    assert run.summary["episodes_done"] == 3
    assert run.summary["best_real_return"] == pytest.approx(max(ep["real_return"]))

    E, A = len(run.state_names), len(run.action_names)
    for k in (1, 2, 3):
        folder = out / "py" / "episodes" / f"{k:03d}"
        table = read_csv(folder / "real.csv")
        cell = lambda r, c: float(r[c]) if r[c] != "" else np.nan  # noqa: E731
        real = run.real(k)
        T = len(table) - 1
        assert real.x.shape == (T + 1, E) and real.u.shape == (T, A)
        assert real.reward.shape == (T,) and real.t.shape == (T + 1,)
        np.testing.assert_allclose(real.x, [[cell(r, c) for c in run.state_names]
                                            for r in table])
        np.testing.assert_allclose(real.u, [[cell(r, c) for c in run.action_names]
                                            for r in table[:-1]])
        np.testing.assert_allclose(real.reward, [cell(r, "reward") for r in table[1:]])
        predicted = run.predicted(k)
        assert predicted.x.shape[1] == E
        theta = [float(v) for v in (folder / "policy.csv").read_text().split()]
        np.testing.assert_array_equal(run.policy(k), theta)  # written with 17 digits


def test_a_missing_trajectory_is_an_error_naming_the_file(runs):
    out, _, _ = runs
    run = drops.read_run(out / "py")
    with pytest.raises(drops.Error, match="004"):
        run.real(4)


def test_resume_extends_a_run_to_the_episodes_of_an_uninterrupted_one(tmp_path, drops_program):
    config = [*TINY[1:], "episodes=2"]
    drops.run(GP_MI_CONFIG, config, seed=3, output=tmp_path, name="short", quiet=True,
              progress=lambda line: None)
    again = drops.resume(tmp_path / "short", progress=lambda line: None)
    assert again.nothing_to_do and again.episodes_done == 2
    more = drops.resume(tmp_path / "short", {"episodes": 3}, progress=lambda line: None)
    assert more.status == "complete" and not more.nothing_to_do and more.episodes_done == 3
    cli = run_cli("run", GP_MI_CONFIG, *TINY[1:], "episodes=3", "--seed", 3, "--output", tmp_path,
                  "--name", "long", "-q")
    assert cli.returncode == 0, cli.stderr
    strip = lambda rows: [{k: v for k, v in r.items() if k not in TIMING}  # noqa: E731
                          for r in rows]
    assert strip(read_csv(tmp_path / "short" / "episodes.csv")) == \
           strip(read_csv(tmp_path / "long" / "episodes.csv"))


def test_a_run_starts_from_recorded_logs_and_records_them(tmp_path, drops_program):
    # A log: the real trajectory of one run's random first episode (seed 5); its last row holds
    # no action, so identify.bad_rows=drop drops it (one transition fewer).
    drops.run(None, ["model.type=gp", "episodes=1"], seed=5, output=tmp_path, name="log",
              quiet=True, progress=lambda line: None)
    log = tmp_path / "log" / "episodes" / "001" / "real.csv"
    rows = len(log.read_text().splitlines()) - 1
    config = [*TINY[1:], "episodes=2", f"data.logs=[{log}]", "identify.columns.time=t",
              "identify.bad_rows=drop"]
    lines = []
    outcome = drops.run(GP_MI_CONFIG, config, seed=3, output=tmp_path, name="fromlogs",
                        progress=lines.append)
    assert outcome.status == "complete" and outcome.episodes_done == 2
    # Episode 1 learned a model (on the log) and predicted its return: not the prior-only one.
    first = read_csv(tmp_path / "fromlogs" / "episodes.csv")[0]
    assert first["episode"] == "1" and float(first["model_learning_s"]) > 0
    assert any("recorded data: 1 log(s)" in l for l in lines), lines
    checkpoint = json.loads((tmp_path / "fromlogs" / "checkpoint.json").read_text())
    declared = checkpoint["validation"]["task"]["declaration"]
    assert declared["data.log.1"] == str(log)
    assert declared["data.log.1.rows"] == str(rows)
    assert declared["data.log.1.transitions"] == str(rows - 2)
    assert len(declared["data.log.1.sha256"]) == 64
    # A log without a declared column is refused before anything runs, naming file and column.
    with pytest.raises(drops.ConfigError, match="time"):
        drops.run(GP_MI_CONFIG, [*TINY[1:], f"data.logs=[{log}]"], output=tmp_path, name="bad",
                  quiet=True, progress=lambda line: None)
    assert not (tmp_path / "bad").exists()


def test_the_gp_kernel_variant_named_in_the_environment_gives_the_same_episodes(tmp_path,
                                                                               drops_program):
    """DROPS_GP_KERNEL picks the prediction kernel's variant (docs/benchmarks.md); every variant
    computes the same bits, so the episodes equal the default's; a name that is not a variant is
    reported once and ignored."""
    def run(name, kernel):
        env = dict(os.environ, DROPS_GP_KERNEL=kernel)
        p = subprocess.run([DROPS_BINARY, "run", GP_MI_CONFIG, *TINY, "--output", tmp_path,
                            "--name", name, "-q"], capture_output=True, text=True, env=env,
                           timeout=600)
        assert p.returncode == 0, p.stderr
        rows = [{k: v for k, v in r.items() if k not in TIMING}
                for r in read_csv(tmp_path / name / "episodes.csv")]
        return rows, p.stderr

    default, _ = run("default", "")
    generic, said = run("generic", "generic")
    assert generic == default and "DROPS_GP_KERNEL" not in said
    bogus, said = run("bogus", "avx3")
    assert bogus == default
    assert "DROPS_GP_KERNEL=avx3 is not avx512, avx2 or generic" in said
