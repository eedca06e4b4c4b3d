"""The board's behaviour stated once: request -> reply vectors in ``*.vec`` files.

They run against the firmware's host tests (as the generated ``firmware/tests/vectors.h``),
the real firmware on a virtual Uno, and :class:`~arduinoio_async.testing.FakeBoard`
(``test_vectors.py``), so the three can never drift apart.
"""
