"""Fault injection on the Python API and the command line: each class of bad input a careful user
or an attacker may give gets a clear error naming the item (or drops's documented policy, in
docs/python.md "What drops refuses"), before anything is written; nothing crashes, hangs or
writes outside the run's directory.

Cases that crashed or hung an earlier drops run in a child process with a time and memory limit,
so that a regression fails its test instead of the test session."""

import json
import os
import pathlib
import resource
import subprocess
import sys
import textwrap

import numpy as np
import pytest

import drops
from conftest import GP_MI_CONFIG, SOURCE_DIR, TINY, run_cli

sys.path.insert(0, str(SOURCE_DIR / "examples" / "python"))
import pendulum  # noqa: E402

QUIET = dict(quiet=True, progress=lambda line: None)
SMALL = {"optimizer.max_evaluations": 40, "optimizer.prior_optimizations": 1, "episodes": 2}
MEMORY_LIMIT = 3 << 30  # bytes of address space for a child (drops itself needs well under 1 GB)


def robot(**task_attrs):
    task = pendulum.SwingUp()
    for k, v in task_attrs.items():
        setattr(task, k, v)
    return dict(task=task, system=pendulum.RealPendulum(), prior=pendulum.PendulumPrior())


def tree(path):
    """Every file and directory under path (relative), to show that nothing was written."""
    return sorted(str(p.relative_to(path)) for p in pathlib.Path(path).rglob("*"))


def limited():
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))


def child(code, timeout=120):
    """Runs `code` (Python, after `import drops` and the example's import) in a child process with
    a memory and time limit; returns the CompletedProcess. A hang fails the calling test."""
    prelude = ("import sys, json, numpy as np, drops\n"
               f"sys.path.insert(0, {str(SOURCE_DIR / 'examples' / 'python')!r})\n"
               "import pendulum\n")
    return subprocess.run([sys.executable, "-c", prelude + textwrap.dedent(code)],
                          capture_output=True, text=True, timeout=timeout, preexec_fn=limited,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})


def cli(*args, timeout=60):
    """The drops program with the child's limits."""
    from conftest import DROPS_BINARY
    return subprocess.run([DROPS_BINARY, *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, preexec_fn=limited)


# 1. A callback's exception that cannot be printed ------------------------------------------------

UNPRINTABLE = """
class Evil({base}):
    def __str__(self):
        raise Evil("and again")

class Task(pendulum.SwingUp):
    def reward(self, x):
        if {where!r} == "reward":
            raise Evil("boom")
        return super().reward(x)

class System(pendulum.RealPendulum):
    def step(self, x, u):
        if {where!r} == "step":
            raise Evil("boom")
        return super().step(x, u)

try:
    drops.run(overrides={{"episodes": 2, "optimizer.max_evaluations": 40}}, output={out!r},
              name="r", quiet=True, progress=lambda line: None, task=Task(),
              system=System(), prior=pendulum.PendulumPrior())
except BaseException as e:
    print("raised", type(e).__name__)
summary = json.load(open({out!r} + "/r/summary.json"))
print("status", summary["status"])
print("error", summary["error"])
"""


@pytest.mark.parametrize("base", ["Exception", "BaseException"])
@pytest.mark.parametrize("where", ["reward", "step"])
def test_an_exception_whose_str_raises_comes_out_as_itself_and_fails_the_run(tmp_path, base,
                                                                            where):
    r = child(UNPRINTABLE.format(base=base, where=where, out=str(tmp_path)))
    assert r.returncode == 0, f"the interpreter died ({r.returncode}): {r.stderr[-2000:]}"
    lines = dict(line.split(" ", 1) for line in r.stdout.splitlines())
    assert lines["raised"] == "Evil"
    assert lines["status"] == "failed"
    callback = "Task.reward raised Evil" if where == "reward" else "step(u)) raised Evil"
    assert callback in lines["error"], lines["error"]
    assert "unprintable" in lines["error"]


# 2. Files that never end, and files that are not files -------------------------------------------

@pytest.mark.parametrize("call", ["drops.read_policy", "drops.read_trajectory", "drops.config",
                                  "drops.run", "drops.read_run"])
def test_a_device_or_a_directory_is_refused_as_a_file_without_reading_it(tmp_path, call):
    for path in ("/dev/zero", str(tmp_path)):
        if call == "drops.read_run" and path == str(tmp_path):
            continue  # a directory is what read_run takes
        code = f"""
        try:
            {call}({path!r}{', output=' + repr(str(tmp_path / 'o')) if call == 'drops.run' else ''})
        except drops.Error as e:
            print(type(e).__name__, e)
        """
        r = child(code, timeout=60)
        assert r.returncode == 0, r.stderr[-2000:]
        assert "not a regular file" in r.stdout or "not a run directory" in r.stdout, r.stdout
    assert not (tmp_path / "o").exists()


def test_the_command_line_refuses_a_device_or_a_directory_as_its_configuration(tmp_path,
                                                                             drops_program):
    for path in ("/dev/zero", tmp_path):
        for command in ("config", "run"):
            r = cli(command, path, *(["--output", tmp_path / "o"] if command == "run" else []))
            assert r.returncode == 2, (command, path, r.returncode, r.stderr)
            assert "not a regular file" in r.stderr and str(path) in r.stderr
    assert not (tmp_path / "o").exists()


def test_a_file_over_the_size_limit_is_refused_before_it_is_read(tmp_path):
    big = tmp_path / "big.yaml"
    with open(big, "wb") as f:
        f.truncate(1 << 31)  # sparse: 2 GiB that take no disk
    for call in (drops.config, drops.read_policy, drops.read_trajectory):
        with pytest.raises(drops.Error, match=r"is larger than"):
            call(big)


# 3. Resuming with another robot -------------------------------------------------------------------

@pytest.mark.parametrize("attr,value", [("horizon", 30), ("dt", 0.05), ("max_action", 4.0),
                                        ("state_names", ["w", "theta"]),
                                        ("observation_dim", 2)])
def test_resume_refuses_a_task_of_another_shape_and_leaves_the_run_as_it_was(tmp_path, attr,
                                                                            value):
    out = drops.run(overrides=SMALL, output=tmp_path, name="r", **QUIET, **robot())
    assert out.status == "complete"
    before = {p: (tmp_path / "r" / p).read_bytes() for p in tree(tmp_path / "r")
              if (tmp_path / "r" / p).is_file() and p != ".lock"}
    other = robot(**{attr: value})
    if attr == "observation_dim":
        other["task"].observe = lambda x: x
        other["task"].observation_scale = None
    with pytest.raises(drops.ConfigError, match=rf"{attr}"):
        drops.resume(tmp_path / "r", {"episodes": 3}, **QUIET, **other)
    after = {p: (tmp_path / "r" / p).read_bytes() for p in before}
    assert after == before
    assert json.loads(before["summary.json"])["status"] == "complete"


def test_resume_refuses_a_prior_of_other_parameters(tmp_path):
    drops.run(overrides=SMALL, output=tmp_path, name="r", **QUIET, **robot())
    other = robot()

    class Other(pendulum.PendulumPrior):
        parameters = [drops.Parameter("m", 0.6, 0.2, 3.0), drops.Parameter("l", 0.7, 0.2, 2.0)]

    other["prior"] = Other()
    with pytest.raises(drops.ConfigError, match=r"m.*upper|bounds"):
        drops.resume(tmp_path / "r", {"episodes": 3}, **QUIET, **other)
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["status"] == "complete"


# 4. Run names and labels that leave the output directory ------------------------------------------

# ABSOLUTE stands for an absolute path under the test's own directory.
BAD_RUN_NAMES = ["..", ".", "../x", "a/b", "ABSOLUTE", "x\0y", "-x", ""]


@pytest.mark.parametrize("name", [n for n in BAD_RUN_NAMES if n])
def test_a_run_name_that_is_not_one_directory_name_is_refused(tmp_path, name, drops_program):
    out = tmp_path / "out"
    escape = tmp_path / "escape"
    name = str(escape) if name == "ABSOLUTE" else name
    # ConfigError (a ValueError); a NUL is refused before the C++ side sees it (ValueError).
    with pytest.raises(ValueError, match="name"):
        drops.run(GP_MI_CONFIG, TINY, output=out, name=name, **QUIET)
    if "\0" not in name:
        if not name.startswith("-"):  # the command line takes "-x" as an option
            r = cli("run", GP_MI_CONFIG, *TINY, "--output", out, "--name", name)
            assert r.returncode == 2 and "name" in r.stderr, r.stderr
        r = cli("run", GP_MI_CONFIG, *TINY, "--output", out, f"name={name}")
        assert r.returncode == 2 and "name" in r.stderr, r.stderr
    assert not out.exists() and not escape.exists() and tree(tmp_path) == []


@pytest.mark.parametrize("label", ["../../x", "a/b", "..", "", "x y"])
def test_a_prior_label_that_is_not_a_name_is_refused(tmp_path, label):
    r = robot()
    r["prior"].label = label
    with pytest.raises(ValueError, match="label"):
        drops.run(overrides=SMALL, output=tmp_path / "o", **QUIET, **r)
    assert not (tmp_path / "o").exists()


# 5. is covered by test_the_command_line_refuses_a_device_or_a_directory_as_its_configuration and
# test_a_device_or_a_directory_is_refused_as_a_file_without_reading_it (drops.run, drops.config).

# 6. Names that break the files --------------------------------------------------------------------

@pytest.mark.parametrize("attrs,match", [
    ({"state_names": ["a,b", "theta"]}, "state_names"),
    ({"state_names": ["dtheta\n", "theta"]}, "state_names"),
    ({"state_names": ["theta", "theta"]}, "twice"),
    ({"action_names": ["theta"]}, "twice"),
    ({"state_names": ["t", "theta"]}, "reserved"),
    ({"state_names": ["dtheta", "reward"]}, "reserved"),
    ({"state_names": ["dtheta", "\ud800"]}, "state_names"),
    ({"action_names": [""]}, "action_names"),
    ({"name": "pendubot"}, "built-in"),
    ({"name": "Pendulum"}, "name"),
])
def test_names_that_would_break_the_run_files_are_refused(tmp_path, attrs, match):
    with pytest.raises(ValueError, match=match):
        drops.run(overrides=SMALL, output=tmp_path / "o", **QUIET, **robot(**attrs))
    assert not (tmp_path / "o").exists()


def test_parameter_names_follow_the_same_grammar(tmp_path):
    r = robot()

    class Bad(pendulum.PendulumPrior):
        parameters = [drops.Parameter("m,1", 0.6, 0.2, 2.0), drops.Parameter("l", 0.7, 0.2, 2.0)]

    r["prior"] = Bad()
    with pytest.raises(ValueError, match="parameters"):
        drops.run(overrides=SMALL, output=tmp_path / "o", **QUIET, **r)

    class Twice(pendulum.PendulumPrior):
        parameters = [drops.Parameter("m", 0.6, 0.2, 2.0), drops.Parameter("m", 0.7, 0.2, 2.0)]

    r["prior"] = Twice()
    with pytest.raises(ValueError, match="twice"):
        drops.run(overrides=SMALL, output=tmp_path / "o", **QUIET, **r)
    assert not (tmp_path / "o").exists()


# 7. Numbers ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("attrs,match", [
    ({"dt": float("inf")}, "dt"),
    ({"dt": float("nan")}, "dt"),
    ({"horizon": 20.9}, "horizon.*integer"),
    ({"horizon": 10**30}, "horizon"),
    ({"horizon": True}, "horizon"),
    ({"observation_dim": 3.7}, "observation_dim.*integer"),
    ({"hidden_units": 10**6}, "hidden_units"),
    ({"hidden_units": 0}, "hidden_units"),
    ({"max_action": float("inf")}, "max_action"),
    ({"max_action": 10**400}, "max_action"),
    ({"state_units": ["rad/s", "\ud800"]}, "state_units"),
])
def test_numbers_out_of_range_or_not_integers_are_refused_before_anything_is_written(tmp_path,
                                                                                    attrs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        drops.run(overrides=SMALL, output=tmp_path / "o", **QUIET, **robot(**attrs))
    assert not (tmp_path / "o").exists()


class HugeReward(pendulum.SwingUp):
    def reward(self, x):
        return np.full(len(x), 1e308)


def test_a_reward_too_large_to_sum_is_refused_naming_the_callback(tmp_path):
    r = robot()
    r["task"] = HugeReward()
    with pytest.raises(drops.InvalidArgument, match=r"SwingUp\.reward|HugeReward\.reward"):
        drops.run(overrides=SMALL, output=tmp_path, name="h", **QUIET, **r)
    summary = json.loads((tmp_path / "h" / "summary.json").read_text())
    assert summary["status"] == "failed"


# 8. Misreports ------------------------------------------------------------------------------------

def test_read_run_of_a_directory_that_is_no_run_raises(tmp_path):
    for d in ("/", tmp_path):
        with pytest.raises(drops.Error, match="not a run directory"):
            drops.read_run(d)


def test_an_empty_policy_file_is_refused(tmp_path):
    (tmp_path / "policy.csv").write_text("")
    with pytest.raises(drops.Error, match="no value"):
        drops.read_policy(tmp_path / "policy.csv")


def test_a_refused_resume_leaves_a_complete_run_complete(tmp_path):
    drops.run(GP_MI_CONFIG, [*TINY[1:], "episodes=1"], output=tmp_path, name="r", **QUIET)
    for overrides in (["seed=3"], ["episodes=0"], ["model.type=gp"]):
        with pytest.raises(drops.ConfigError):
            drops.resume(tmp_path / "r", overrides, **QUIET)
    with pytest.raises(drops.ConfigError):  # another robot than the run's
        drops.resume(tmp_path / "r", **QUIET, **robot())
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["status"] == "complete"
    # A run of one's own robot, extended with a robot of another shape.
    drops.run(overrides=SMALL, output=tmp_path, name="p", **QUIET, **robot())
    with pytest.raises(drops.ConfigError, match="horizon"):
        drops.resume(tmp_path / "p", {"episodes": 3}, **QUIET, **robot(horizon=30))
    assert json.loads((tmp_path / "p" / "summary.json").read_text())["status"] == "complete"


# 9. Messages one can act on -----------------------------------------------------------------------

def test_a_binary_configuration_file_gives_a_readable_message(tmp_path):
    f = tmp_path / "binary.yaml"
    for content in (b"model.type: \xff\xfe\n", b"episodes: \xff\xfe\x00\x01\x80 \xc3\x28"):
        f.write_bytes(content)
        with pytest.raises(drops.ConfigError) as e:
            drops.config(f)
        assert str(e.value).strip() and "binary.yaml" in str(e.value)
    f.write_bytes(b"model.type: \xff\xfe\n")
    with pytest.raises(drops.ConfigError, match=r"model\.type.*\\xff\\xfe"):
        drops.config(f)


def test_a_file_error_says_the_operating_systems_reason(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(drops.Error, match="Not a directory"):
        drops.run(GP_MI_CONFIG, TINY, output=tmp_path / "file" / "runs", name="x", **QUIET)
    # A full disk: config.yaml is written through config.yaml.tmp, here the full device.
    run_dir = tmp_path / "full"
    run_dir.mkdir()
    (run_dir / "config.yaml.tmp").symlink_to("/dev/full")
    with pytest.raises(drops.Error, match="No space left on device"):
        drops.run(GP_MI_CONFIG, TINY, output=tmp_path, name="full", **QUIET)


def test_check_phi_is_named_when_it_refuses_the_starting_phi(tmp_path):
    r = robot()

    class Picky(pendulum.PendulumPrior):
        def check_phi(self, phi):
            raise ValueError("never")

    r["prior"] = Picky()
    with pytest.raises(ValueError, match=r"check_phi.*never|never.*check_phi") as e:
        drops.run(overrides=SMALL, output=tmp_path, name="p", **QUIET, **r)
    assert "check_phi" in str(e.value)


def test_arguments_of_the_wrong_kind_are_refused_at_the_call(tmp_path):
    with pytest.raises(TypeError, match="progress"):
        drops.run(GP_MI_CONFIG, TINY, output=tmp_path, progress=5)
    with pytest.raises(ValueError, match="NUL"):
        drops.run(GP_MI_CONFIG, TINY, output=str(tmp_path) + "\0x")
    with pytest.raises(ValueError, match="NUL"):
        drops.read_policy("a\0b")
    assert tree(tmp_path) == []


def test_a_huge_value_is_not_echoed_whole_in_an_error(tmp_path):
    with pytest.raises(drops.ConfigError) as e:
        drops.config(overrides={"model.type": "x" * 1_000_000})
    assert len(str(e.value)) < 2000 and "model.type" in str(e.value)
    r = run_cli("config", "model.type=" + "y" * 100_000)
    assert r.returncode == 2 and len(r.stderr) < 2000
