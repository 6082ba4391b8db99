"""Errors a Python user can act on: the command line's messages as typed exceptions; an exception
in the progress callable and Ctrl-C stop the run after its current step with every finished
episode kept, and the run resumes."""

import json
import os
import signal
import threading

import pytest

import drops
from conftest import GP_MI_CONFIG, TINY, run_cli


def cli_error(result):
    prefix = "drops: configuration error: "
    assert result.returncode == 2, result.stderr
    assert result.stderr.startswith(prefix), result.stderr
    return result.stderr[len(prefix):].rstrip("\n")


def test_a_bad_key_gives_the_command_lines_message_as_a_config_error(tmp_path, drops_program):
    for overrides in (["model.tpye=gp"], ["episodes=0"], ["model.type=gpp"]):
        with pytest.raises(drops.ConfigError) as e:
            drops.run(GP_MI_CONFIG, overrides, output=tmp_path)
        assert str(e.value) == cli_error(run_cli("run", GP_MI_CONFIG, *overrides,
                                                 "--output", tmp_path))
    assert list(tmp_path.iterdir()) == []  # nothing written
    with pytest.raises(drops.ConfigError, match="did you mean 'model.type'"):
        drops.config(overrides={"model.tpye": "gp"})


def test_resume_refuses_what_the_command_line_refuses(tmp_path, drops_program):
    drops.run(GP_MI_CONFIG, [*TINY[1:], "episodes=1"], output=tmp_path, name="r", quiet=True,
              progress=lambda line: None)
    with pytest.raises(drops.ConfigError) as e:
        drops.resume(tmp_path / "r", ["seed=3"])
    assert str(e.value) == cli_error(run_cli("run", "--resume", tmp_path / "r", "seed=3"))
    with pytest.raises(drops.Error, match="not a run directory"):
        drops.resume(tmp_path / "nothing")
    with pytest.raises(TypeError, match="key=value"):
        drops.run(GP_MI_CONFIG, "episodes=1")


class Stop(Exception):
    pass


def test_an_exception_in_the_progress_callable_stops_the_run_and_it_resumes(tmp_path):
    def progress(line):
        if line.startswith("episode  1/"):
            raise Stop("enough")

    with pytest.raises(Stop, match="enough"):
        drops.run(GP_MI_CONFIG, TINY, output=tmp_path, name="s", progress=progress)
    summary = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert summary["status"] == "interrupted" and len(summary["episodes"]) == 1
    more = drops.resume(tmp_path / "s", progress=lambda line: None)
    assert more.status == "complete" and more.episodes_done == 3


def test_ctrl_c_stops_the_run_after_its_current_step_and_raises_keyboard_interrupt(tmp_path):
    first = threading.Event()

    def interrupt():
        first.wait(120)
        os.kill(os.getpid(), signal.SIGINT)  # as Ctrl-C, while C++ runs without the lock

    lines = []

    def progress(line):
        lines.append(line)
        if line.startswith("episode  1/"):
            first.set()

    killer = threading.Thread(target=interrupt)
    killer.start()
    # A larger budget after the first episode leaves time for the signal to arrive.
    overrides = ["episodes=20", "optimizer.max_evaluations=2000", "optimizer.prior_optimizations=1"]
    try:
        with pytest.raises(KeyboardInterrupt):
            drops.run(GP_MI_CONFIG, overrides, output=tmp_path, name="c", progress=progress)
    finally:
        first.set()
        killer.join()
    summary = json.loads((tmp_path / "c" / "summary.json").read_text())
    assert summary["status"] == "interrupted"
    assert 1 <= len(summary["episodes"]) < 20
    assert (tmp_path / "c" / "checkpoint.json").exists()
    # The final lines are printed before KeyboardInterrupt is raised.
    assert lines[-2].startswith("interrupted: ") and lines[-1].startswith("continue it with: ")
