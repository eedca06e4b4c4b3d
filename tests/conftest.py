"""Test-suite wide fixtures: the virtual Uno factory (arduinoio_async.sim), and a port
registry of the suite's own."""

from collections.abc import Iterator

import pytest

from arduinoio_async._port_registry import ENV_REGISTRY_DIR

pytest_plugins = ["arduinoio_async.sim.pytest_plugin"]


@pytest.fixture(autouse=True, scope="session")
def own_port_registry(tmp_path_factory: pytest.TempPathFactory) -> Iterator[None]:
    """Virtual Unos other programs on this machine announce are not the suite's boards:
    discovery (here and in the commands tests run) reads an empty registry of its own."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(ENV_REGISTRY_DIR, str(tmp_path_factory.mktemp("port-registry")))
        yield
