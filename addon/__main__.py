"""Entry point for `python -m addon` (see cli.py)."""

import sys

from .cli import main

sys.exit(main())
