"""The module imports from the build tree and lists what the command line lists."""

import drops
from conftest import run_cli


def test_the_module_imports_and_registers_the_command_lines_tasks_and_algorithms():
    assert drops.tasks()[0] == "pendubot"
    assert "black_drops" in drops.algorithms()
    assert issubclass(drops.ConfigError, drops.Error)
    assert issubclass(drops.ConfigError, ValueError)
    assert issubclass(drops.Error, RuntimeError)


def test_the_schema_lists_every_key_with_type_unit_range_and_doc(drops_program):
    keys = {k["key"]: k for k in drops.schema()}
    assert keys["model.type"]["type"] == "enum"
    assert "gp_mi" in keys["model.type"]["allowed"]
    episodes = keys["episodes"]
    assert episodes["type"] == "int" and episodes["min"] is not None and episodes["doc"]
    assert any(k.startswith("pendubot.") or k.startswith("prior.") for k in keys)
    # The Markdown schema is the command line's, byte for byte.
    cli = run_cli("config", "--markdown")
    assert cli.returncode == 0, cli.stderr
    assert drops.schema_markdown() == cli.stdout


def test_an_unknown_task_is_a_config_error():
    try:
        drops.schema("no_such_task")
    except drops.ConfigError as e:
        assert "no_such_task" in str(e)
    else:
        raise AssertionError("schema('no_such_task') did not raise ConfigError")


def test_the_version_is_the_cmake_projects_and_the_command_lines(drops_program):
    import re
    from conftest import SOURCE_DIR
    cmake = (SOURCE_DIR / "CMakeLists.txt").read_text()
    version = re.search(r"project\(drops VERSION (\S+)", cmake).group(1)
    assert drops.__version__ == version
    assert run_cli("--version").stdout.strip() == f"drops {version}"
    assert f"## {version}" in (SOURCE_DIR / "CHANGELOG.md").read_text()
