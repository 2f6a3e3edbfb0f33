"""The accuracy-versus-cost sweep (``hpcontact.sweep.accuracy_study``)."""

from __future__ import annotations

from hpcontact.sweep.accuracy_study import run_study


def test_the_study_runner_is_hpcontact_run_with_cold_solves(tmp_path, capsys):
    """``python -m hpcontact.sweep.accuracy_study`` takes ``hpcontact run``'s options and exit statuses."""
    spec = tmp_path / "study.toml"
    spec.write_text(
        '[scene]\nquantities = ["tangential"]\nshape = "circle"\n[numerics]\ntol = 1e-8\n[axes]\nn = [8, 16]\n'
    )
    output = tmp_path / "study.nc"
    assert run_study([str(spec), "--output", str(output)]) == 0 and output.exists()
    assert run_study([str(spec), "--output", str(output)]) == 2  # journals exist: --resume or --restart
    assert "--resume" in capsys.readouterr().err
    assert run_study([str(spec), "--output", str(output), "--resume"]) == 0
