"""drops.read_log: a robot's recorded log read by the C++ reader and returned as numpy arrays
(docs/logs.md). The numerics are tested in tests/test_recorded_log.cpp; here, what crosses the
boundary: shapes, values, the report, and each error's type and message."""

import math

import numpy as np
import pytest

import drops
from conftest import SOURCE_DIR


def write_log(path, t, columns):
    """A CSV log: time, then each (name, values) column."""
    header = "time," + ",".join(name for name, _ in columns)
    rows = [",".join(repr(float(v)) for v in [t[i]] + [c[i] for _, c in columns])
            for i in range(len(t))]
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def irregular_times(end, step, seed):
    rng = np.random.default_rng(seed)
    t = [0.0]
    while t[-1] < end:
        t.append(t[-1] + step * rng.uniform(0.5, 1.5))
    return np.array(t)


def test_a_known_signal_comes_back_as_transitions_with_its_values(tmp_path):
    t = irregular_times(3.0, 0.002, 1)
    theta = np.sin(2 * math.pi * 0.5 * t)
    u = np.where(t < 1.5, 0.25, -0.5)  # one step, at a row near 1.5 s
    p = write_log(tmp_path / "log.csv", t, [("theta", theta), ("u", u)])
    log = drops.read_log(p, state=[("theta", "angle"),
                                   {"kind": "velocity", "of": "theta", "name": "omega"}],
                         action=["u"], dt=0.01)
    n = int(math.floor(t[-1] / 0.01 + 1e-9))
    assert log.x.shape == (n, 2) and log.u.shape == (n, 1) and log.dx.shape == (n, 2)
    assert log.state_names == ["theta", "omega"] and log.action_names == ["u"]
    assert len(log.segments) == 1 and log.segments[0].x.shape == (n + 1, 2)
    k = np.arange(n) * 0.01
    # Linear interpolation at 3 ms at most: within 3e-3^2 / 8 * (pi^2) of the signal.
    np.testing.assert_allclose(log.x[:, 0], np.sin(math.pi * k), atol=1.2e-5)
    np.testing.assert_allclose(log.x[1:, 0] - log.x[:-1, 0], log.dx[:-1, 0], atol=1e-15)
    # The derived velocity: a 7-point Savitzky-Golay derivative of a noise-free sinusoid.
    np.testing.assert_allclose(log.x[:, 1], math.pi * np.cos(math.pi * k), atol=2e-3)
    # The held action averaged over each period: 0.25 before the step, -0.5 after, one period
    # in between.
    before = np.isclose(log.u[:, 0], 0.25, rtol=0, atol=1e-12)
    after = np.isclose(log.u[:, 0], -0.5, rtol=0, atol=1e-12)
    assert np.sum(before) + np.sum(after) == n - 1 and before[0] and after[-1]
    assert log.report["transitions"] == n and log.report["gaps"] == 0
    assert "transitions in 1 segment" in log.report["brief"]


def test_bad_input_raises_with_the_file_line_and_column(tmp_path):
    t = np.arange(50) * 0.01
    theta = np.sin(t)
    p = write_log(tmp_path / "log.csv", t, [("theta", theta), ("u", np.zeros(50))])
    with pytest.raises(drops.Error, match=r"no column 'tau' \(declared as an action\); its "
                                          r"columns are: 'time', 'theta', 'u'"):
        drops.read_log(p, state=["theta"], action=["tau"])
    text = p.read_text().splitlines()
    text[5] = "0.04,nan,0"
    p.write_text("\n".join(text) + "\n")
    with pytest.raises(drops.Error, match=r"log.csv line 6, column 'theta': .*not a finite number"):
        drops.read_log(p, state=["theta"], action=["u"])
    log = drops.read_log(p, state=["theta"], action=["u"], bad_rows="drop")
    assert log.report["dropped_nonfinite"] == 1 and log.x.shape == (49, 1)
    # A declaration that is not valid: drops.InvalidArgument, a ValueError.
    with pytest.raises(ValueError, match="is not a column name"):
        drops.read_log(p, state=["theta 1"], action=["u"])
    with pytest.raises(drops.InvalidArgument, match="dt = -1"):
        drops.read_log(p, state=["theta"], action=["u"], dt=-1.0)
    with pytest.raises(ValueError, match="kind 'angel'"):
        drops.read_log(p, state=[("theta", "angel")], action=["u"])
    with pytest.raises(ValueError, match="bad_rows"):
        drops.read_log(p, state=["theta"], action=["u"], bad_rows="skip")
    with pytest.raises(TypeError, match="state: expected a list"):
        drops.read_log(p, state="theta", action=["u"])
    with pytest.raises(TypeError, match="dt: expected a number"):
        drops.read_log(p, state=["theta"], action=["u"], dt="0.01")
    with pytest.raises(drops.Error, match="is not a regular file"):
        drops.read_log(tmp_path, state=["theta"], action=["u"])


def test_the_real_double_pendulums_log_reads_as_a_thousand_transitions():
    p = (SOURCE_DIR / ".." / "shared" / "data" / "double-pendulum-dfki" / "sys_id" /
         "trajectory_00.csv")
    if not p.exists():
        pytest.skip(f"{p} is absent")
    log = drops.read_log(p, state=[("pos_meas1", "angle", None, "q1"),
                                   ("pos_meas2", "angle", None, "q2"),
                                   ("vel_meas1", "velocity", "q1", "dq1"),
                                   ("vel_meas2", "velocity", "q2", "dq2")],
                         action=["tau_meas1", "tau_meas2"], dt=0.01)
    assert log.x.shape == (999, 4) and log.u.shape == (999, 2)
    assert np.all(np.abs(log.report["velocity_slope"][2:] - 1) < 0.01)
    assert np.all(np.isnan(log.report["velocity_slope"][:2]))
