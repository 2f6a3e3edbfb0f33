"""``python -m hpcontact.sweep SPEC [--resume] [--output PATH]``: the sweep without the full CLI."""

import sys

from .driver import main

sys.exit(main())
