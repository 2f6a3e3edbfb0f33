"""The ``hpcontact run`` command by role: records, shares, resume policy, rounds, assembly, summary, dry run."""
