"""Test-suite wide fixtures: the virtual Uno factory (arduinoio_async.sim)."""

pytest_plugins = ["arduinoio_async.sim.pytest_plugin"]
