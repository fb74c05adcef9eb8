"""``python -m pfrepro``: the command line (:mod:`pfrepro.cli`)."""
import sys

from .cli import main

sys.exit(main())
