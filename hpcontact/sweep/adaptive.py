"""The old path of the adaptive map's rounds (``hpcontact.sweep.maps.rounds``), for the driver's
imports until they name ``hpcontact.sweep.maps``."""

from hpcontact.sweep.maps.rounds import dry_run_text, run_rounds

__all__ = ["dry_run_text", "run_rounds"]
