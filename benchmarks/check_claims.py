"""Every row of docs/claims.md checked, one PASS or FAIL line per row (issue 39 item 2).

    python benchmarks/check_claims.py [--check NAME ...] [--static] [--keep DIR]

All checks: ~40 min at load ~11 on 2 cores (2026-11-29; the four jobs most of it), roughly a third of that idle.

For every row: what ``tests/test_claims.py`` checks without running anything (each named path,
module and test exists; the page, section and every excerpt quoted in “…” stand; the status is
one of the page's words, a one-off names its date, machine and commit). For the rows whose
status is ``regenerated``, it also runs the command the row names through its check
(``--check NAME`` in the row) and compares the number each page quotes with what the command
prints, at the quoted precision. The cheap regenerated figures (dry-run counts, printed
records, the triangle and square at 1e-3, the interpolation miss) are tests in
tests/test_claims.py and run with the suite; the checks here take minutes:

- ``dense_map``: ``hpcontact run jobs/demo_map.toml`` on one rank (~15 s idle), then
  ``hpcontact show`` of its data set: the dense map's solves and worst map error
  (docs/tutorials/sweep.md, docs/howto/adaptive.md, docs/reference/cli.md);
- ``main_job``: ``mpiexec -n 2 hpcontact run jobs/demo.toml`` (~2 min on 2 idle cores), then
  ``hpcontact show --json``: the worst estimated errors the README quotes;
- ``thin_rectangle_512``: ``hpcontact solve`` of the b/a = 1e-8 rectangle on 512 × 64 cells
  (docs/explanation/verification.md's K_a/K_b, ~10 s);
- ``tembleque``: ``mpiexec -n 2 hpcontact run jobs/tembleque2011_friction.toml`` and its figure
  script, which prints the figures docs/explanation/results.md quotes for Rodríguez-Tembleque
  et al. 2011 (9 min at load ~12 on 2 cores, 2026-11-29; about a third of that idle);
- ``crystal_friction_map``: ``mpiexec -n 2 hpcontact run jobs/crystal_friction_map.toml`` and
  its figure script: the friction map's ratios under load and the stick zone's offset
  (docs/explanation/results.md; 8 min at load ~11 on 2 cores, 2026-11-29);
- ``sphere_pairs``: ``mpiexec -n 2 hpcontact run jobs/sphere_pairs.toml`` and
  ``postprocess/slip_stiffness.py``: k_t's deviation from Mindlin–Deresiewicz over every pair,
  load, mu and Q (docs/explanation/results.md; 15 min at load ~11 on 2 cores, 2026-11-29).

Every row's line says PASS or FAIL and why; the exit status is 1 if any row failed. ``--static``
runs no command (the regenerated rows' comparisons are then reported NOT RUN); ``--check``
runs only the named checks (the other rows still get their static check). A dry run or a run
reads this machine's cost-model calibration as ``hpcontact run`` does (it calibrates first,
~12-30 s, where there is none).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from types import ModuleType

ROOT = Path(__file__).resolve().parents[1]


@cache
def claims_test() -> ModuleType:
    """tests/test_claims.py as a module: the row parser and its static checks (plain functions
    that raise AssertionError)."""
    spec = importlib.util.spec_from_file_location("claims_rows", ROOT / "tests" / "test_claims.py")
    assert spec and spec.loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # as an import would: dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@dataclass
class Runner:
    """Runs ``hpcontact ARGUMENTS`` (or ``python SCRIPT.py ARGUMENTS``) once each from the
    repository root, keeping what they print; their data sets go to ``folder``."""

    folder: Path
    printed: dict[tuple[str, ...], str] = field(default_factory=dict)

    def __call__(self, *arguments: str, ranks: int = 1) -> str:
        if arguments not in self.printed:
            script = arguments[0].endswith(".py")
            hpcontact = [sys.executable, *([] if script else ["-m", "hpcontact"]), *arguments]
            mpiexec = shutil.which("mpiexec", path=str(Path(sys.executable).parent)) or "mpiexec"
            command = [mpiexec, "-n", str(ranks), *hpcontact] if ranks > 1 else hpcontact
            env = {name: value for name, value in os.environ.items() if name != "HPCONTACT_MPI"}
            if ranks == 1:
                env["HPCONTACT_MPI"] = "0"  # one process on purpose (docs/reference/environment.md)
            done = subprocess.run(command, cwd=ROOT, env=env, capture_output=True, text=True, check=False)
            if done.returncode != 0:
                raise AssertionError(f"{' '.join(command)} exited {done.returncode}: {done.stderr.strip()[-400:]}")
            self.printed[arguments] = done.stdout + done.stderr
        return self.printed[arguments]


def quoted(page: str, pattern: str) -> list[re.Match[str]]:
    """Every match of ``pattern`` on ``page`` (whitespace collapsed); the page must quote it."""
    return [match for _, match in claims_test()._quoted(pattern, (page,))]


#: What a check found wrong: (the page that quotes the figure, one line saying what and both values).
Failure = tuple[str, str]


def compare(page: str, what: str, quoted_text: str, value: float | int | str) -> list[Failure]:
    """``[]`` if ``value`` is what ``page`` quotes (at its precision, for a float), else one
    failure saying both."""
    ok = (
        claims_test().at_quoted_precision(quoted_text, value) if isinstance(value, float) else str(value) == quoted_text
    )
    return [] if ok else [(page, f"{what}: the page says {quoted_text}, the command printed {value}")]


def show_summary(text: str) -> list[str]:
    """The lines of an ``hpcontact show`` text summary from its ``run`` section to the end of its
    map errors (the file, axes, quantities and provenance left out: they name this run)."""
    lines = [line.rstrip() for line in text.splitlines()]
    start = lines.index("run")
    end = next((i for i, line in enumerate(lines) if line == "provenance"), len(lines))
    return lines[start:end]


def dense_map(run: Runner) -> list[Failure]:
    """The dense map of the README's main job on one rank: its last line (solves, points, worst
    map error and where), and ``hpcontact show``'s summary of its data set against the console
    block of docs/reference/cli.md, from ``run`` to the map errors."""
    output = run.folder / "demo_map.nc"
    printed = run("run", "jobs/demo_map.toml", "--output", str(output))
    last = re.search(r"worst map error (\S+) \(.+?\); (\d+) solves for (\d+) points", printed)
    assert last, f"hpcontact run jobs/demo_map.toml printed no map line: {printed[-400:]}"
    failures, sweep, adaptive, cli_page = (
        [],
        "docs/tutorials/sweep.md",
        "docs/howto/adaptive.md",
        "docs/reference/cli.md",
    )
    for match in quoted(sweep, r"in (\d+) solves of the (\d[\d ]*\d) points"):
        failures += compare(sweep, "solves", match[1], last[2])
        failures += compare(sweep, "points", str(claims_test()._count(match[2])), last[3])
    for match in quoted(sweep, r"its worst map error (\d\.\d+e-\d+)"):
        failures += compare(sweep, "worst map error", match[1], float(last[1]))
    for match in quoted(adaptive, r"worst map error \S+ \(.+?\); \d+ solves for \d+ points"):
        failures += compare(adaptive, "the last line", match[0], last[0])
    cli = (ROOT / cli_page).read_text(encoding="utf-8")
    block = re.search(r"```\w+\n\$ hpcontact show results/demo_map.nc\n(.*?)```", cli, re.S)
    assert block, "docs/reference/cli.md shows no hpcontact show of results/demo_map.nc"
    shown = show_summary(run("show", str(output)))
    for quoted_line, shown_line in zip(show_summary(block[1]), shown, strict=False):
        failures += compare(cli_page, "hpcontact show", quoted_line.strip(), shown_line.strip())
    failures += compare(cli_page, "hpcontact show's lines", str(len(show_summary(block[1]))), len(shown))
    return failures


def worst_estimated_error(path: Path, shape: str | None = None) -> float:
    """The largest ``estimated_error`` (a record's worst over its own quantities) of a data set,
    or of its points of one ``shape``."""
    import xarray as xr

    with xr.open_dataset(path) as dataset:
        errors = dataset["estimated_error"]
        return float((errors if shape is None else errors.sel(shape=shape)).max())


#: Pages that quote the exact cell's largest estimate: (page, pattern whose group is the bound).
EXACT_CELL_BOUNDS = (
    ("README.md", r"Ellipses and circles are one exact cell each .*?estimates ≤ (\S+)\);"),
    (
        "docs/performance.md",
        r"The estimate is a bound on the contour integral's truncation and rounding, 1e-14 … (\S+) \(",
    ),
    ("docs/performance.md", r"every ellipse on its one exact cell \(errors estimated ≤ (\S+) in"),
    ("docs/design.md", r"\(series tail and rounding\) is a bound at 1e-14 … (\S+)\."),
    ("docs/explanation/accuracy.md", r"rounding of the sum \(1e-14 … (\S+)\)"),
)


def main_job(run: Runner) -> list[Failure]:
    """The README's main job on 2 ranks and ``hpcontact show --json`` of its data set: its
    points (with the load angle), the largest ``estimated_error`` over them, the worst estimated
    errors of K_nn and of ``normalized_nn``, and the ellipses' largest ``estimated_error`` (one
    exact cell each) against the bound each page gives the exact cell."""
    output = run.folder / "demo.nc"
    run("run", "jobs/demo.toml", "--output", str(output), ranks=2)
    shown = json.loads(run("show", "--json", str(output)))
    worst = {name: entry["error"] for name, entry in shown["errors"]["worst"].items()}
    points = 1
    for axis in shown["axes"]:
        points *= axis["size"]
    failures, readme = [], "README.md"
    pattern = r"the worst estimated error over the (\d[\d ]*\d) points is (\S+) \(`estimated_error`; K_nn (\S+);"
    for match in quoted(readme, pattern):
        failures += compare(readme, "points", str(claims_test()._count(match[1])), str(points))
        failures += compare(readme, "worst estimated_error", match[2], worst_estimated_error(output))
        failures += compare(readme, "K_nn", match[3], worst["K_nn"])
    for match in quoted(readme, r"`normalized_nn`, K_nn's plus K_zz's, (\S+)\)"):
        failures += compare(readme, "normalized_nn", match[1], worst["normalized_nn"])
    exact_cells = worst_estimated_error(output, "ellipse")  # the job's ellipses: one exact cell each
    for page, pattern in EXACT_CELL_BOUNDS:
        failures += [
            (
                page,
                f"the exact cell's estimates: the page says ≤ {match[1]}, the main job's ellipses reach {exact_cells:.2e}",
            )
            for match in quoted(page, pattern)
            if exact_cells > float(match[1])
        ]
    return failures


def thin_rectangle_512(run: Runner) -> list[Failure]:
    """K_a/K_b of the rectangle b/a = 1e-8, nu = 0.5 on 512 × 64 cells."""
    arguments = "--shape rectangle --aspect 1e-8 --nu 0.5 --n 512 --n-across 64 --quantities tangential --json"
    record = json.loads(run("solve", *arguments.split()))
    page = "docs/explanation/verification.md"
    return [
        failure
        for match in quoted(page, r"(\d\.\d+) \(512×64")
        for failure in compare(page, "K_a/K_b at 512×64", match[1], record["K_a_over_K_b"])
    ]


def tembleque(run: Runner) -> list[Failure]:
    """Rodríguez-Tembleque et al. 2011: ``jobs/tembleque2011_friction.toml`` on 2 ranks and its
    figure script, whose printed lines hold the figures docs/explanation/results.md quotes
    (Figs. 3 and 5–7: the line contact's errors, the load and force ratios, the coupling sizes,
    the stick zones and their centroids)."""
    page, output = "docs/explanation/results.md", run.folder / "tembleque2011_friction.nc"
    run("run", "jobs/tembleque2011_friction.toml", "--output", str(output), ranks=2)
    printed = run("postprocess/tembleque2011_friction.py", str(output), str(run.folder / "tembleque2011"))
    text = " ".join(printed.split())

    def line(pattern: str) -> re.Match[str]:
        found = re.search(pattern, text)
        assert found, f"the figure script printed no /{pattern}/"
        return found

    def percent(ratio: str, sign: float = 1.0) -> float:
        """``1.0109`` → 1.09 (% above 1; below 1 with ``sign`` = −1)."""
        return sign * 100.0 * (float(ratio) - 1.0)

    def series(label: str) -> dict[str, str]:
        """``Q / Q(ratio 1): 1: 1.0000, 2: 0.9954, …`` → {"1": "1.0000", "2": "0.9954", …}."""
        body = line(re.escape(label) + r":? ((?:[\d.]+: (?:[\d.]+|nan)(?:, )?)+)")[1]
        return dict(re.findall(r"([\d.]+): ([\d.]+|nan)", body))

    failures = []

    def check(pattern: str, values: list[float | str]) -> None:
        for match in quoted(page, pattern):
            for index, (quoted_text, value) in enumerate(zip(match.groups(), values, strict=True)):
                failures.extend(compare(page, f"/{pattern}/ item {index + 1}", quoted_text, value))

    plane = line(r"plane strain [\d.]+: ([\d.]+), [\d.]+: ([\d.]+), 1000: ([\d.]+), rigid in x1: ([\d.]+)")
    check(
        r"the rise is (\S+) % at 2, (\S+) % at 32, (\S+) % at 1000 and (\S+) % for a punch",
        list(map(percent, plane.groups())),
    )
    paper = line(r"paper eq\. 24 [\d.]+: ([\d.]+), [\d.]+: ([\d.]+), 1000: [\d.]+, rigid in x1: ([\d.]+)")
    check(r"as we read the garbled text\) gives (\S+) %, (\S+) % and (\S+) %", list(map(percent, paper.groups())))
    bem = series("3-D BEM")
    check(r"cylinder \(n = 16\) gives (\S+) % and (\S+) % at 2 and 32", [percent(bem["2"]), percent(bem["32"])])
    q, decoupled, fixed = (
        series("Q / Q(ratio 1)"),
        series("decoupled Q / Q(ratio 1)"),
        series("P at a fixed approach / ratio 1"),
    )
    check(
        r"falls with the ratio by (\S+) % at 2, (\S+) % at 4, (\S+) % at 8, (\S+) % at 16 and (\S+) % at 32",
        [percent(q[r], -1.0) for r in ("2", "4", "8", "16", "32")],
    )
    check(r"Q rises by (\S+) % at 2", [percent(decoupled["2"])])
    check(
        r"d\^1\.5, d the frictionless approach at 0\.37 MN\) rises (\S+) % at 2 and (\S+) % at 32",
        [percent(fixed["2"]), percent(fixed["32"])],
    )
    import xarray as xr

    with xr.open_dataset(output) as dataset:
        coupling = dict(zip(map(str, dataset["pair"].values), map(float, dataset["coupling_size"].values), strict=True))
    check(
        r"coupling_size (\S+) at ratio 2, (\S+) at 32\)", [coupling["ortho E1 ratio 2"], coupling["ortho E1 ratio 32"]]
    )
    contact = line(
        r"semi-axes ([\d.]+) mm across x1, ([\d.]+) mm along; p0 = ([\d.]+) MPa \(plane strain at a = 50 mm: ([\d.]+) MPa\)"
    )
    check(
        r"semi-axes (\S+) × (\S+) mm and p0 = (\S+) MPa for the similar pair at n = 64, printed by the figure script; plane strain at a = 50 mm gives (\S+) MPa",
        list(map(float, contact.groups())),
    )
    similar = line(r"tractions, ortho E1 ratio 1: stick cells on the centre line from x/50mm = (-?[\d.]+) to ([\d.]+)")
    check(r"on the centre line it spans x = −(\S+) a … (\S+) a", [-float(similar[1]), float(similar[2])])
    band = line(
        r"tractions, ortho E1 ratio 2: stick cells on the centre line from x/50mm = \S+ to \S+ \(centre (-?[\d.]+)\)"
    )
    check(r"The 3-D ellipse's band is centred at (\S+) a", [abs(float(band[1]))])
    estimate = line(r"\|e\| = ([\d.]+) a = ([\d.]+) mm")
    check(r"\|e\| = (\S+) a = (\S+) mm", list(map(float, estimate.groups())))
    shift = line(
        r"stick centroid x, ortho E1 ratio 2: " + ", ".join([r"n = \d+ \(cell [\d.]+ mm\): ([-+][\d.]+) mm"] * 4)
    )
    check(
        r"centroid is at (\S+), (\S+), (\S+) and (\S+) mm at n = 32, 48, 64 and 96",
        [f"{float(x):.2f}".replace("-", "−") for x in shift.groups()],
    )
    iso = line(r"stick centroid x, isotropic: .*?n = 96 \(cell [\d.]+ mm\): ([-+][\d.]+) mm")  # the finest grid
    check(r"has its stick zone on the other side, at \+(\S+) mm", [float(iso[1])])
    pairs = re.findall(r"\(32, ([-+][\d.e-]+), ([-+][\d.e-]+)\)", text)  # (n, peak error, width error)
    errors = [abs(float(error)) for pair in pairs for error in pair]
    assert len(errors) == 4, "the figure script printed no n = 32 errors of the two line contacts"
    check(r"falling to ≤ (\S+) at n = 32", [max(errors)])
    return failures


def compare_printed(page: str, what: str, quoted_text: str, printed_text: str) -> list[Failure]:
    """``[]`` if a value printed to fewer digits than it has (``printed_text``, ± half its last
    digit) can round to ``quoted_text`` (± half its last digit): the two intervals meet."""

    def half_unit(text: str) -> float:
        mantissa, _, exponent = text.partition("e")
        return 0.5 * 10.0 ** (-len(mantissa.partition(".")[2]) + int(exponent or 0))

    gap = abs(float(printed_text) - float(quoted_text)) - half_unit(printed_text) - half_unit(quoted_text)
    return [] if gap <= 0.0 else [(page, f"{what}: the page says {quoted_text}, the command printed {printed_text}")]


def crystal_friction_map(run: Runner) -> list[Failure]:
    """The crystal-sphere friction map: ``jobs/crystal_friction_map.toml`` on 2 ranks and its
    figure script, whose k_min/k_max table (Q/(μP) = 0, 0.5, 0.8, 0.9 per row) and stick-centroid
    offset hold the figures docs/explanation/results.md quotes under load."""
    page, output = "docs/explanation/results.md", run.folder / "crystal_friction_map.nc"
    run("run", "jobs/crystal_friction_map.toml", "--output", str(output), ranks=2)
    printed = run("postprocess/crystal_friction_map.py", str(output), str(run.folder / "crystal_friction"))
    text = " ".join(printed.split())

    def row(pattern: str) -> list[str]:
        found = re.search(pattern + r"((?: [\d.]+){4})", text)
        assert found, f"the figure script printed no /{pattern}/"
        return found[1].split()

    isotropic = row(r"isotropic reference k_min/k_max:")
    cu_110 = row(r"crystal:Cu: k_min/k_max psi = 0\.00:")
    cu_50 = row(r"crystal:Cu: k_min/k_max (?:psi = [\d.]+:(?: [\d.]+){4} )*psi = 50\.00:")
    offset = re.search(r"largest stick-centroid offset along the load: (\S+) m", text)
    assert offset, "the figure script printed no stick-centroid offset"
    failures = []
    for match in quoted(page, r"the isotropic body, (\S+), (\S+), (\S+) at Q/\(μP\) = 0\.5, 0\.8, 0\.9\)"):
        for quoted_text, printed_text in zip(match.groups(), isotropic[1:], strict=True):
            failures += compare_printed(page, "isotropic k_min/k_max", quoted_text, printed_text)
    for match in quoted(page, r"\(Cu (\S+) at 0\.9\) and up near ψ = 50° \((\S+)\)"):
        failures += compare_printed(page, "Cu on [110] at 0.9", match[1], cu_110[3])
        failures += compare_printed(page, "Cu at ψ = 50° and 0.9", match[2], cu_50[3])
    for match in quoted(page, r"off centre by up to (\S+) µm"):
        failures += compare(page, "stick-centroid offset (µm)", match[1], float(offset[1]) * 1e6)
    return failures


def sphere_pairs(run: Runner) -> list[Failure]:
    """The sphere-pair job: ``jobs/sphere_pairs.toml`` on 2 ranks and ``postprocess/slip_stiffness.py``,
    whose table gives each pair's deviation of k_t from Mindlin–Deresiewicz over every load, mu
    and Q; docs/explanation/results.md quotes the range over all pairs."""
    page, output = "docs/explanation/results.md", run.folder / "sphere_pairs.nc"
    run("run", "jobs/sphere_pairs.toml", "--output", str(output), ranks=2)
    printed = run("postprocess/slip_stiffness.py", str(output), str(run.folder / "sphere_pairs"))
    ranges = re.findall(r"^\s+\S+\s+[\d.]+\s+\S+\s+(\S+) … (\S+)\s", printed, re.M)
    assert ranges, "postprocess/slip_stiffness.py printed no k_t/MD-1 ranges"
    low = min(ranges, key=lambda pair: float(pair[0]))[0]
    high = max(ranges, key=lambda pair: float(pair[1]))[1]

    def percent(printed_text: str) -> str:
        """``-1.40e-03`` → ``-0.140`` (in %, at the printed precision)."""
        mantissa, _, exponent = printed_text.partition("e")
        digits = len(mantissa.partition(".")[2]) - int(exponent) - 2
        return f"{100.0 * float(printed_text):.{max(digits, 0)}f}"

    failures = []
    for match in quoted(page, r"within (\S+) % … \+(\S+) % over every pair, load, mu and Q"):
        failures += compare_printed(page, "k_t/MD − 1, lowest (%)", match[1].replace("−", "-"), percent(low))
        failures += compare_printed(page, "k_t/MD − 1, highest (%)", match[2], percent(high))
    return failures


#: The checks a regenerated row names (``benchmarks/check_claims.py --check NAME``).
CHECKS: dict[str, Callable[[Runner], list[Failure]]] = {
    "dense_map": dense_map,
    "main_job": main_job,
    "thin_rectangle_512": thin_rectangle_512,
    "tembleque": tembleque,
    "crystal_friction_map": crystal_friction_map,
    "sphere_pairs": sphere_pairs,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--check", nargs="+", choices=sorted(CHECKS), help="run only these checks")
    parser.add_argument("--static", action="store_true", help="run no command")
    parser.add_argument("--keep", type=Path, help="keep the data sets the checks write in this folder")
    args = parser.parse_args(argv)
    claims = claims_test()
    folder = args.keep or Path(tempfile.mkdtemp(prefix="check_claims-"))
    folder.mkdir(parents=True, exist_ok=True)
    run, results = Runner(folder), {}
    selected = [] if args.static else (args.check or list(CHECKS))
    for name in selected:
        try:
            results[name] = CHECKS[name](run)
        except AssertionError as error:  # the command failed, or a page no longer quotes the figure
            results[name] = [("", str(error))]
    failed = 0
    for row in claims.ROWS:
        problems = []
        checks = [claims.test_every_named_path_and_test_exists]
        if row in claims.CLAIM_ROWS:
            checks.append(claims.test_every_claim_names_its_page_section_excerpts_and_status)
        for check in checks:
            try:
                check(row)
            except AssertionError as error:
                problems.append(str(error))
        names = claims.CHECK.findall(" ".join(row.cells.values()))
        ran = [name for name in names if name in results]
        page = claims.PATH.findall(row.cells.get("where", ""))
        problems += [
            problem for name in ran for where, problem in results[name] if where in ("", *page)
        ]  # a failure of this row's page, or of the command
        verdict = "FAIL" if problems else "PASS"
        failed += bool(problems)
        not_run = [name for name in names if name not in results]
        how = "static" + "".join(f"; regenerated: {name}" for name in ran)
        how += f"; NOT RUN: {', '.join(not_run)} (only the static checks)" if not_run else ""
        print(f"{verdict} {row} [{how}]" + "".join(f"\n    {problem}" for problem in problems))
    print(
        f"{len(claims.ROWS) - failed} of {len(claims.ROWS)} rows pass"
        + (f"; data sets in {folder}" if args.keep else "")
    )
    if not args.keep:
        shutil.rmtree(folder, ignore_errors=True)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
