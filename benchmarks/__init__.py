"""Comparisons and investigations: run each as ``python -m benchmarks.NAME`` from the
repository root (see ``benchmarks/README.md`` for what belongs here and what in the
shipped ``arduinoio bench``)."""
