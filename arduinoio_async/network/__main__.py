"""``python -m arduinoio_async.network`` = ``arduinoio serve``."""

import sys

from .cli import main

sys.exit(main())
