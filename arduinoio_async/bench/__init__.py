"""Latency benchmark: the paper's Table IV, explained by a model, and beaten.

``arduinoio bench`` runs the ten commands of Table IV under four scenarios (paper
conditions through a 16U2 bridge model, pipelined, fast link, host overhead) against a
virtual Uno it starts itself, or a real board given by ``--port``/``--id``.  The model
behind the predictions is documented in ``docs/performance.md``.
"""

from .commands import COMMANDS, PAPER_MS, BenchCommand
from .model import LinkModel, predict_ms

__all__ = ["COMMANDS", "PAPER_MS", "BenchCommand", "LinkModel", "predict_ms"]
