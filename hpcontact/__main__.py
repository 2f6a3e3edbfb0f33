"""``python -m hpcontact``: the ``hpcontact`` command."""

from hpcontact.cli import console_main

console_main()
