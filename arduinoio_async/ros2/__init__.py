"""ROS 2 without a ROS install: every board a ROS 2 node over rmw_zenoh (``pip install
arduinoio_async[ros2]``).

``arduinoio ros2 --config robot.yaml`` (:mod:`.cli`) runs :func:`run_bridge`: for each
configured board a node ``/<namespace>/<name>`` whose inputs publish and whose outputs
subscribe with standard message types, wire-compatible with ``rmw_zenoh_cpp`` (ROS 2
Jazzy >= 0.2.4, Kilted >= 0.6.0; ``docs/ros2.md`` writes the format down with its
sources).  The top layer: it uses the board, manager and network packages; nothing in
the library imports it.
"""

from __future__ import annotations

# The ros2 extra's own packages first: without them ``arduinoio ros2`` names that extra
# (cli._entry.EXTRAS), not the network extra of the zenoh the bridge imports next.
import rosbags  # noqa: F401
import yaml  # noqa: F401

from ._bridge import BoardNode, run_bridge
from ._clock import BoardClock
from ._config import BridgeConfig, ConfigError, load, parse

__all__ = ["BoardClock", "BoardNode", "BridgeConfig", "ConfigError", "load", "parse", "run_bridge"]
