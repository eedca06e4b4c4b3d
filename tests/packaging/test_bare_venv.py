"""The wheel without its extras: pytest still runs, and a missing extra is named in one line.

The venv is the session's (``conftest.py``): the wheel and its dependencies only.  Installing
the package registers its pytest plugin (``pytest11``) for every pytest run in the venv,
so that plugin must load with nothing optional installed, and say what to install only
when a test uses the fixture that needs it.  The CLI commands that need an extra (the
monitor's web stack, Zenoh for ``serve`` and ``--remote``) print one line naming it.
"""

from __future__ import annotations

import pytest

from .conftest import Installed, checked

pytestmark = [pytest.mark.timeout(300)]

PLAIN_TEST = "def test_arithmetic():\n    assert 1 + 1 == 2\n"
FIXTURE_TEST = "async def test_a_board(virtual_uno_factory):\n    await virtual_uno_factory()\n"


@pytest.fixture(scope="module")
def with_pytest(installed: Installed) -> Installed:
    """The session's bare venv plus pytest (no pytest-asyncio, no pytest-timeout)."""
    checked(installed.run(installed.exe("pip"), "install", "-q", "pytest", timeout=300))
    missing = installed.run(installed.exe("python"), "-c", "import pytest_asyncio")
    assert missing.returncode != 0, "the bare venv must not have pytest-asyncio"
    return installed


def test_pytest_runs_a_plain_test_with_the_package_installed(with_pytest: Installed) -> None:
    (with_pytest.workdir / "test_plain.py").write_text(PLAIN_TEST)
    result = with_pytest.run(with_pytest.exe("python"), "-m", "pytest", "-q", "test_plain.py")
    assert result.returncode == 0, result.stdout + result.stderr
    assert "1 passed" in result.stdout
    plugins = with_pytest.run(
        with_pytest.exe("python"), "-m", "pytest", "-q", "--trace-config", "test_plain.py"
    )
    assert "arduinoio_async.sim.pytest_plugin" in plugins.stdout  # it loaded, it did not vanish


def test_the_virtual_uno_fixture_says_what_to_install(with_pytest: Installed) -> None:
    (with_pytest.workdir / "test_fixture.py").write_text(FIXTURE_TEST)
    result = with_pytest.run(with_pytest.exe("python"), "-m", "pytest", "-q", "test_fixture.py")
    assert result.returncode == 1, result.stdout + result.stderr  # an error, not a skip
    assert "1 error" in result.stdout
    assert "pip install pytest-asyncio" in result.stdout


@pytest.mark.parametrize(
    ("argv", "extra"),
    [
        (["monitor"], "monitor"),
        (["monitor", "--remote", "--id", "1"], "monitor"),
        (["serve"], "network"),
        (["ros2", "--config", "robot.yaml"], "ros2"),
        (["info", "--remote", "--id", "1"], "network"),
        (["status", "--remote", "--id", "1"], "network"),
    ],
)
def test_a_command_whose_extra_is_missing_says_so_in_one_line(
    installed: Installed, argv: list[str], extra: str
) -> None:
    result = installed.run(installed.exe("arduinoio"), *argv, timeout=60)
    assert result.returncode == 2, result.stdout + result.stderr
    lines = result.stderr.splitlines()
    assert len(lines) == 1, result.stderr
    assert f"pip install 'arduinoio_async[{extra}]'" in lines[0]
