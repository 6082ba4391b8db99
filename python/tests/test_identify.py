"""drops.identify and `drops identify` end to end (docs/identify.md): a model learned from the
logs of two pendubot runs' random first episodes (drops run episodes=1, seeds 1 and 2: fit on
one, validate on the other), the same numbers from Python and from the command line, and a log
without a declared column refused with exit code 2 naming the file and the column."""

import csv
import pathlib

import numpy as np
import pytest

import drops
from conftest import run_cli


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """The real.csv of two one-episode pendubot runs (t, dtheta1, dtheta2, theta1, theta2, u,
    reward; the last row has no action)."""
    root = tmp_path_factory.mktemp("identify-logs")
    paths = []
    for seed in (1, 2):
        out = drops.run(overrides={"episodes": 1}, seed=seed, threads=1, output=root,
                        name=f"seed{seed}", quiet=True)
        paths.append(pathlib.Path(out.directory) / "episodes" / "001" / "real.csv")
    return paths


def write_config(path, fit, validation):
    path.write_text(
        "task: pendubot\n"
        "model:\n  type: gp_mi\n"
        "identify:\n"
        f"  logs: [{fit}]\n"
        f"  validation: [{validation}]\n"
        "  columns:\n    time: t\n    angles: [theta1, theta2]\n"
        "  bad_rows: drop\n"
        "  horizons: [0.1, 0.5, 1.0]\n"
        "  start_spacing: 0.25\n")
    return path


def test_identify_beats_the_prior_and_returns_what_the_files_hold(logs, tmp_path):
    config = write_config(tmp_path / "identify.yaml", *logs)
    r = drops.identify(config, output=tmp_path / "out", threads=2, quiet=True)
    assert isinstance(r, drops.IdentifyResult)
    assert r.model_type == "gp_mi"
    assert r.state_names == ["dtheta1", "dtheta2", "theta1", "theta2"]
    assert r.dt == pytest.approx(0.05)
    assert r.transitions == 49 and r.points == 49  # 50 steps, the last row (no action) dropped
    P = len(r.phi_names)
    assert r.phi_names[:4] == ["m1", "m2", "l1", "l2"]
    for a in (r.phi_start, r.phi, r.phi_lower95, r.phi_upper95):
        assert a.shape == (P,)
    assert r.phi_tunable.dtype == bool
    t = r.phi_tunable
    assert np.all(np.isfinite(r.phi_lower95[t])) and np.all(r.phi_lower95[t] < r.phi[t])
    assert np.all(r.phi[t] < r.phi_upper95[t])
    assert np.all(np.isnan(r.phi_lower95[~t]))
    np.testing.assert_allclose(r.horizons, [0.05, 0.1, 0.5, 1.0])
    assert r.median.shape == (1, 4, 4) and r.p90.shape == (1, 4, 4) and r.n.shape == (1, 4)
    assert r.n[0, 0] == 49
    # The learned model against the prior at its start phi, at 0.5 s on both angles (measured:
    # medians 0.0004 and 0.004 rad against 0.14 and 0.14); it fails if learning breaks.
    for dim in (2, 3):
        assert r.median[0, 2, dim] < 0.25 * r.prior_median[0, 2, dim]
    # The arrays are the files' numbers.
    d = pathlib.Path(r.directory)
    assert d == tmp_path / "out" / "identify-pendubot-gp_mi"
    for name in ("phi.csv", "errors.csv", "model.json", "data.csv", "report.md",
                 "validation-01.csv", "summary.json", "config.yaml"):
        assert (d / name).is_file(), name
    rows = [x for x in csv.DictReader(open(d / "errors.csv")) if x["model"] == "learned"]
    assert len(rows) == 16
    for k, row in enumerate(rows):
        assert float(row["median"]) == pytest.approx(r.median[0, k // 4, int(row["dim"])],
                                                     rel=1e-12)
    phi = {x["name"]: float(x["value"]) for x in csv.DictReader(open(d / "phi.csv"))}
    np.testing.assert_allclose([phi[n] for n in r.phi_names], r.phi, rtol=1e-12)

    # The command line gives the same phi (one code path, deterministic).
    cli = run_cli("identify", "-q", config, f"output={tmp_path / 'cli'}", "threads=1")
    assert cli.returncode == 0, cli.stderr
    out = pathlib.Path(cli.stdout.strip())
    assert out == tmp_path / "cli" / "identify-pendubot-gp_mi"
    assert (out / "phi.csv").read_text() == (d / "phi.csv").read_text()
    # ... and draws the figures (python/drops_plot.py identify): PNG files, not empty.
    for name in ("validation-01.png", "phi.png"):
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name


def test_a_log_without_a_declared_column_is_refused_naming_the_file_and_column(logs, tmp_path):
    text = logs[0].read_text().splitlines()
    cut = tmp_path / "no_u.csv"
    cut.write_text("\n".join(",".join(c for i, c in enumerate(line.split(",")) if i != 5)
                             for line in text) + "\n")
    config = write_config(tmp_path / "identify.yaml", cut, logs[1])
    cli = run_cli("identify", "-q", config, f"output={tmp_path / 'out'}")
    assert cli.returncode == 2, cli.stderr
    assert str(cut) in cli.stderr and "no column 'u' (declared as an action)" in cli.stderr
    with pytest.raises(drops.ConfigError, match=r"no_u\.csv: no column 'u'"):
        drops.identify(config, output=tmp_path / "out", quiet=True)
    assert not (tmp_path / "out").exists()  # nothing written


def test_a_logged_velocity_in_degrees_per_second_is_refused_by_its_units_check(logs, tmp_path):
    """identify.columns.state: VEL=d/dt(STATE) checks the logged velocity against the derivative
    of STATE; the pendubot's own velocities pass it, the same in deg/s do not."""
    states = "identify.columns.state=[dtheta1=d/dt(theta1), dtheta2=d/dt(theta2), theta1, theta2]"
    config = write_config(tmp_path / "identify.yaml", *logs)
    r = drops.identify(config, [states, "model.type=mi"], output=tmp_path / "out", quiet=True)
    assert r.points == 49
    rows = [line.split(",") for line in logs[0].read_text().splitlines()]
    deg = tmp_path / "deg.csv"
    deg.write_text("\n".join(",".join(row) if k == 0 else
                             ",".join([row[0], repr(float(row[1]) * 180 / np.pi)] + row[2:])
                             for k, row in enumerate(rows)) + "\n")
    config = write_config(tmp_path / "identify-deg.yaml", deg, logs[1])
    with pytest.raises(drops.Error, match=r"deg\.csv, column 'dtheta1' \(the velocity of "
                                          r"'theta1'\): the derivative of 'theta1' is 0\.017"):
        drops.identify(config, [states], output=tmp_path / "out2", quiet=True)
    with pytest.raises(drops.ConfigError, match=r"'dtheta1=theta1' is not COLUMN=d/dt\(STATE\)"):
        drops.identify(config, ["identify.columns.state=[dtheta1=theta1, dtheta2, theta1, "
                                "theta2]"], output=tmp_path / "out3", quiet=True)
    assert not (tmp_path / "out2").exists() and not (tmp_path / "out3").exists()
