"""``python -m bsrflow ...``: the command-line interface, as the ``bsrflow`` command."""
import sys

from .cli import main

sys.exit(main())
