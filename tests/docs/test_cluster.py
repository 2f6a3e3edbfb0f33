"""The cluster's install lines and batch template (issue 42 item 7).

- One set of module lines: every ``module load`` of the README, the cluster pages and
  ``jobs/slurm.sbatch`` is the same line, and it loads a Python of at least 3.11 (what
  ``pyproject.toml``'s ``requires-python`` asks) and an MPI.
- The batch script's exit handling, run as SLURM would run its body, with fakes for ``module``,
  ``srun``, ``scontrol`` and the ranks' ``hpcontact`` on ``PATH``: a stop (every rank exits 4,
  not at the same moment) requeues the job and the script exits 4; 0, 2 and 3 are not requeued.

The fake ``srun`` follows srun's documented rules (https://slurm.schedmd.com/srun.html):
``--kill-on-bad-exit=N`` (or ``-K``; without it the site's ``KillOnBadExit``, here 1, the
stricter setting a site may choose) ends the other tasks with SIGKILL once one exits with a
non-zero status, and srun's status is the highest of the tasks' exit codes, 128 + the signal
for a task killed by one. The script as it was (``--kill-on-bad-exit=1``) exits 137 there and
does not requeue (``test_the_former_launch_line_lost_the_requeue`` keeps that evidence).
"""

from __future__ import annotations

import re
import stat
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SBATCH = ROOT / "jobs" / "slurm.sbatch"
MODULE_PAGES = ("README.md", "docs/howto/install-cluster.md", "docs/tutorials/cluster.md", "jobs/slurm.sbatch")
MODULE_LOAD = re.compile(r"module load ([^&;#\n`]+)")


def _module_lines(path: str) -> list[str]:
    return [" ".join(match[1].split()) for match in MODULE_LOAD.finditer((ROOT / path).read_text(encoding="utf-8"))]


def test_one_set_of_module_lines_with_a_python_of_at_least_3_11() -> None:
    lines = {path: _module_lines(path) for path in MODULE_PAGES}
    for path, found in lines.items():
        assert found, f"{path} loads no modules"
    distinct = {line for found in lines.values() for line in found}
    assert len(distinct) == 1, f"the module lines differ: {lines}"
    modules = distinct.pop().split()
    versions = [tuple(map(int, m.split("/")[1].split("."))) for m in modules if m.startswith("python/")]
    required = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["requires-python"]
    minimum = tuple(map(int, re.fullmatch(r">=\s*(\d+)\.(\d+)", required).groups()))
    assert versions and versions[0] >= minimum, f"{modules}: no python/X.Y module at least {minimum}"
    assert any(m.split("/")[0] in {"openmpi", "mpich", "intel-mpi", "impi"} for m in modules), modules


# --- the batch script with fakes ------------------------------------------------------------------

FAKE_SRUN = '''#!{python}
"""srun: start SLURM_NTASKS copies of the command, each with its SLURM_PROCID; with
kill-on-bad-exit, SIGKILL the others once one exits non-zero; exit with the highest status."""
import os, subprocess, sys, time
arguments = sys.argv[1:]
kill = int(os.environ.get("FAKE_SITE_KILL_ON_BAD_EXIT", "0"))
while arguments and arguments[0].startswith("-"):
    option = arguments.pop(0)
    if option.startswith("--kill-on-bad-exit"):
        kill = int(option.partition("=")[2] or 1)
    elif option.startswith("-K"):
        kill = int(option[2:] or 1)
with open(os.environ["FAKE_LOG"], "a") as log:
    log.write("srun " + " ".join(sys.argv[1:]) + "\\n")
tasks = [subprocess.Popen(arguments, env={{**os.environ, "SLURM_PROCID": str(rank)}})
         for rank in range(int(os.environ["SLURM_NTASKS"]))]
statuses = {{}}
while len(statuses) < len(tasks):
    for rank, task in enumerate(tasks):
        if rank not in statuses and task.poll() is not None:
            statuses[rank] = task.returncode if task.returncode >= 0 else 128 - task.returncode
            if kill and statuses[rank] != 0:
                for other in tasks:
                    if other.poll() is None:
                        other.kill()
    time.sleep(0.01)
sys.exit(max(statuses.values()))
'''

# A rank of ``hpcontact run``: exits with its share of FAKE_STATUSES (one per rank) after its
# share of FAKE_DELAYS seconds, and says so in the log.
FAKE_HPCONTACT = """#!/bin/bash
rank=${SLURM_PROCID:?}
IFS=, read -ra statuses <<< "$FAKE_STATUSES"
IFS=, read -ra delays <<< "$FAKE_DELAYS"
sleep "${delays[$rank]}"
echo "rank $rank: hpcontact $* -> ${statuses[$rank]}" >> "$FAKE_LOG"
exit "${statuses[$rank]}"
"""

LOGGER = '#!/bin/bash\necho "{name} $*" >> "$FAKE_LOG"\n'


def _executable(path: Path, text: str) -> None:
    path.write_text(text, encoding="utf-8")
    path.chmod(path.stat().st_mode | stat.S_IXUSR)


@pytest.fixture()
def site(tmp_path: Path) -> Path:
    """A submit directory with a venv whose bin/ holds the fake hpcontact, and a bin/ of fake
    site commands (srun, scontrol, module)."""
    bin_dir = tmp_path / "site-bin"
    venv_bin = tmp_path / "submit" / ".venv" / "bin"
    bin_dir.mkdir()
    venv_bin.mkdir(parents=True)
    _executable(bin_dir / "srun", FAKE_SRUN.format(python=sys.executable))
    for name in ("scontrol", "module"):
        _executable(bin_dir / name, LOGGER.format(name=name))
    _executable(venv_bin / "hpcontact", FAKE_HPCONTACT)
    (venv_bin / "activate").write_text(f'PATH="{venv_bin}:$PATH"\n', encoding="utf-8")
    return tmp_path


def _submit(site: Path, script: str, statuses: list[int], delays: list[float]) -> tuple[int, list[str]]:
    """Run the batch script's body as SLURM would on 4 ranks; its status and the fakes' log."""
    submit = site / "submit"
    log = site / "log"
    log.write_text("", encoding="utf-8")
    job = site / "job.sbatch"
    job.write_text(script, encoding="utf-8")
    env = {
        "PATH": f"{site / 'site-bin'}:/usr/bin:/bin",
        "HOME": str(site),
        "SLURM_SUBMIT_DIR": str(submit),
        "SLURM_JOB_ID": "4242",
        "SLURM_NTASKS": str(len(statuses)),
        "FAKE_SITE_KILL_ON_BAD_EXIT": "1",
        "FAKE_STATUSES": ",".join(map(str, statuses)),
        "FAKE_DELAYS": ",".join(map(str, delays)),
        "FAKE_LOG": str(log),
    }
    done = subprocess.run(
        ["bash", str(job), "jobs/x.toml", "--grace", "30"],
        cwd=submit,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    return done.returncode, log.read_text(encoding="utf-8").splitlines()


# After a stop request every rank exits 4, rank 0 first, the others within their grace.
STOPPED = ([4, 4, 4, 4], [0.0, 0.4, 0.5, 0.6])


def test_a_stop_on_every_rank_requeues_the_job(site: Path) -> None:
    status, log = _submit(site, SBATCH.read_text(encoding="utf-8"), *STOPPED)
    assert status == 4
    assert "scontrol requeue 4242" in log
    ranks = [line for line in log if line.startswith("rank ")]
    assert len(ranks) == 4 and all(line.endswith("run jobs/x.toml --resume --grace 30 -> 4") for line in ranks), log
    assert "module purge" in log and any(line.startswith("module load ") for line in log)


@pytest.mark.parametrize(
    ("statuses", "expected"),
    [
        ([0, 0, 0, 0], 0),  # done
        ([3, 0, 0, 0], 3),  # data set written by rank 0, some tasks failed
        ([2, 2, 2, 2], 2),  # refused (bad spec, foreign journals, a second job on the output)
    ],
)
def test_other_statuses_are_not_requeued(site: Path, statuses: list[int], expected: int) -> None:
    status, log = _submit(site, SBATCH.read_text(encoding="utf-8"), statuses, [0.3, 0.0, 0.1, 0.2])
    assert status == expected
    assert not any(line.startswith("scontrol") for line in log), log


def test_the_former_launch_line_lost_the_requeue(site: Path) -> None:
    """The evidence for the fix: with --kill-on-bad-exit=1, rank 0's exit 4 gets the others
    killed in their grace, srun says 137 and the job is not requeued."""
    script = SBATCH.read_text(encoding="utf-8")
    former = re.sub(r"--kill-on-bad-exit=\d", "--kill-on-bad-exit=1", script)
    assert former != script
    status, log = _submit(site, former, *STOPPED)
    assert status == 128 + 9
    assert not any(line.startswith("scontrol") for line in log), log
    assert sum(line.startswith("rank ") for line in log) == 1, log


def test_the_launch_line_overrides_the_sites_kill_on_bad_exit() -> None:
    launch = [line for line in SBATCH.read_text(encoding="utf-8").splitlines() if line.startswith("srun ")]
    assert len(launch) == 1 and "--kill-on-bad-exit=0" in launch[0].split(), launch
