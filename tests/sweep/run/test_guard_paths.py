"""What a run writes cannot eat what it reads (``guard.apart``): the output is not the spec, a
mask file or the journal folder and does not lie in the journal folder, and the journal folder
is not the spec or a mask file. Refused before any task, with one line naming both paths and
their keys, exit status 2, by ``hpcontact run``, its ``--dry-run`` and ``hpcontact.run_sweep``
alike; nothing is written (issue 43, items 4 and 5)."""

from __future__ import annotations

import io
import os
from pathlib import Path

import numpy as np
import pytest

import hpcontact
from hpcontact import cli
from hpcontact.sweep.driver import main, run_sweep
from hpcontact.sweep.run import guard
from hpcontact.sweep.run.guard import Refused
from hpcontact.sweep.run.schedule import SerialTeam
from hpcontact.sweep.space.parse import load_spec

SCENE = """[scene]
shape = "circle"
quantities = ["tangential"]
[numerics]
n = 16
[axes]
nu = [0.1, 0.2]
"""


def never(params):
    raise AssertionError("no task may run")


def refusals(spec: Path, capsys, *flags: str) -> str:
    """The refusal of ``hpcontact run SPEC`` and of its ``--dry-run`` (each one line on stderr,
    exit status 2) and of ``run_sweep``: the same message; no task runs and nothing appears
    beside the spec."""
    before = sorted(p.name for p in spec.parent.iterdir())
    messages = []
    for extra in ([], ["--dry-run"]):
        assert cli.main(["run", str(spec), *flags, *extra]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and ": error: " in err, err
        messages.append(err.strip().split(": error: ", 1)[1])
    output = flags[flags.index("--output") + 1] if "--output" in flags else None
    with pytest.raises(Refused) as info:
        run_sweep(spec, output=output, team=SerialTeam(), stream=io.StringIO(), task_function=never)
    messages.append(str(info.value))
    assert sorted(p.name for p in spec.parent.iterdir()) == before
    assert len(set(messages)) == 1, messages
    return messages[0]


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.setenv("HPCONTACT_MPI", "0")
    monkeypatch.chdir(tmp_path)
    return tmp_path


def test_a_spec_is_not_its_own_output(here, capsys):
    """``hpcontact run foo.nc`` on a TOML spec named foo.nc: its default output is foo.nc (was:
    exit 0, the spec replaced by the data set)."""
    spec = here / "foo.nc"
    spec.write_text(SCENE)
    assert refusals(spec, capsys) == (
        f"the output {spec} (the spec's name with .nc, beside it: set sweep.output or pass --output) is the spec {spec}: "
        f"the data set would replace it; name another output"
    )
    assert spec.read_text() == SCENE
    with pytest.raises(Refused, match=r"pass output=\) is the spec"):  # the Python face: its keyword named
        hpcontact.run_sweep(str(spec), task_function=never, stream=io.StringIO())
    assert spec.read_text() == SCENE


def test_the_output_given_as_the_spec_by_name_link_or_hard_link_is_refused(here, capsys):
    spec = here / "spec.toml"
    spec.write_text(SCENE)
    (here / "link.nc").symlink_to(spec)
    os.link(spec, here / "hard.nc")
    for output in ("link.nc", "hard.nc", str(here / "sub" / ".." / "link.nc")):
        message = refusals(spec, capsys, "--output", output)
        assert message.startswith(f"the output {output} (sweep.output or --output) is the spec {spec}: "), message
    (here / "spec.nc").write_text('[sweep]\noutput = "x.nc"\n' + SCENE)  # named by --output as it is
    assert refusals(here / "spec.nc", capsys, "--output", "spec.nc").startswith("the output spec.nc (sweep.output")
    assert spec.read_text() == SCENE and (here / "link.nc").is_symlink() and (here / "hard.nc").read_text() == SCENE
    assert not (here / "x.nc").exists()


def test_a_journal_folder_equal_to_the_output_is_refused_before_any_task(here, capsys):
    """Was: every task ran, then exit 1 'cannot write the data set … Is a directory; free space
    and run again with --resume', and --resume then refused."""
    spec = here / "s.toml"
    spec.write_text('[sweep]\noutput = "out.nc"\njournal = "out.nc"\n' + SCENE)
    assert refusals(spec, capsys) == (
        "the output out.nc (sweep.output or --output) is the journal folder out.nc (sweep.journal): name them apart"
    )
    assert not (here / "out.nc").exists()
    (here / "other").mkdir()  # the same folder by another name: a link to it
    (here / "j").symlink_to(here / "other" / "out.nc")
    spec.write_text('[sweep]\noutput = "other/out.nc"\njournal = "j"\n' + SCENE)
    assert "is the journal folder j (sweep.journal)" in refusals(spec, capsys)


def test_an_output_inside_the_journal_folder_is_refused(here, capsys):
    spec = here / "s.toml"
    spec.write_text('[sweep]\noutput = "runs/out.nc"\njournal = "runs"\n' + SCENE)
    (here / "runs").mkdir()
    assert refusals(spec, capsys) == (
        "the output runs/out.nc (sweep.output or --output) lies in the journal folder runs (sweep.journal): "
        "name an output outside it"
    )
    spec.write_text('[sweep]\noutput = "out.nc"\njournal = "."\n' + SCENE)  # deeper: the working directory
    assert "lies in the journal folder . (sweep.journal)" in refusals(spec, capsys)


def test_a_mask_file_is_neither_the_output_nor_the_journal_folder(here, capsys):
    mask = np.zeros((8, 8), dtype=bool)
    mask[2:6, 1:7] = True
    np.save(here / "contact.npy", mask)
    (here / "other.npy").symlink_to(here / "contact.npy")
    (here / "link.nc").symlink_to(here / "other.npy")  # the mask through two links
    fixed = SCENE.replace('shape = "circle"', 'shape = "mask"\nmask = "contact.npy"')
    spec = here / "s.toml"
    spec.write_text('[sweep]\noutput = "link.nc"\n' + fixed)
    assert refusals(spec, capsys) == (
        f"the output link.nc (sweep.output or --output) is the input file {here / 'contact.npy'} (scene.mask): "
        "the data set would replace it; name another output"
    )
    spec.write_text('[sweep]\noutput = "out.nc"\njournal = "contact.npy"\n' + fixed)
    assert refusals(spec, capsys) == (
        f"the journal folder contact.npy (sweep.journal) is the input file {here / 'contact.npy'} (scene.mask): "
        "name another journal folder (sweep.journal)"
    )


def test_a_mask_in_a_label_table_is_named_by_its_key(here):
    mask = np.ones((4, 4), dtype=bool)
    np.save(here / "m.npy", mask)
    (here / "out.nc").symlink_to(here / "m.npy")
    spec = here / "s.toml"
    spec.write_text(
        '[sweep]\noutput = "out.nc"\n[scene]\nquantities = ["tangential"]\n[numerics]\nn = 16\n[axes]\n'
        'shape = ["circle", { label = "m", shape = "mask", mask = "m.npy" }]\n'
    )
    with pytest.raises(Refused, match=r"is the input file .*m\.npy \(axes\.shape\[1\]\.mask\)"):
        guard.apart(load_spec(spec, check_scenes=False))


def test_outputs_apart_from_the_inputs_go_on(here, fake_solve):
    """The default journal folder (the output's name + .journal), an output beside the spec,
    a journal folder elsewhere: accepted by the check, the dry run and the run."""
    spec = here / "s.toml"
    spec.write_text(SCENE)
    guard.apart(load_spec(spec, check_scenes=False))
    spec.write_text('[sweep]\noutput = "a/out.nc"\njournal = "journals/a"\n' + SCENE)
    (here / "a").mkdir()
    (here / "journals").mkdir()
    guard.apart(load_spec(spec, check_scenes=False))
    assert main([str(spec), "--dry-run"]) == 0
    run_sweep(spec, team=SerialTeam(), stream=io.StringIO(), task_function=fake_solve)
    assert (here / "a" / "out.nc").is_file() and (here / "journals" / "a").is_dir()
