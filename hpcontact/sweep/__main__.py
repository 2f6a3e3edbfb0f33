"""``python -m hpcontact.sweep SPEC [options]``: ``hpcontact run`` without the full CLI."""

import sys

from hpcontact.sweep.driver import main

sys.exit(main())
