"""``python -m hpcontact.sweep SPEC [options]``: ``hpcontact run`` without the full CLI."""

import sys

from .driver import main

sys.exit(main())
