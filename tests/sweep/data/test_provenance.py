"""Where a result came from (hpcontact.sweep.data.provenance): the revision, the numerics fingerprint,
the resolved scene, and the check that names the first journal entry computed by other code."""

from __future__ import annotations

import hashlib
import json
import platform
import re

import numpy
import pytest
import scipy

import hpcontact
from hpcontact.scene import DEFAULTS
from hpcontact.sweep.data.journal import OK, Entry
from hpcontact.sweep.data.provenance import (
    REVISION_VARIABLE,
    contributors,
    current,
    describe,
    fingerprint,
    first_mismatch,
    git_revision,
    numerics,
    resolved_scene,
)


def test_the_revision_variable_overrides_the_checkout(monkeypatch):
    monkeypatch.setenv(REVISION_VARIABLE, "abc123-dirty")
    assert git_revision() == "abc123-dirty"
    assert current()["git_revision"] == "abc123-dirty"


def test_the_revision_of_this_checkout_is_a_commit_dirty_or_not(monkeypatch):
    monkeypatch.delenv(REVISION_VARIABLE, raising=False)
    assert re.fullmatch(r"[0-9a-f]{40}(-dirty)?", git_revision() or "")


def test_numerics_names_the_libraries_and_machine_that_make_the_numbers():
    found = numerics()
    assert found["numpy"] == numpy.__version__ and found["scipy"] == scipy.__version__
    assert found["machine"] == platform.machine() and found["pyfftw"]


def test_a_fingerprint_is_12_hex_digits_of_sha1_of_the_sorted_json():
    settings = {"b": [1, 2], "a": "x"}
    expected = hashlib.sha1(b'{"a": "x", "b": [1, 2]}').hexdigest()[:12]
    assert fingerprint(settings) == expected == fingerprint({"a": "x", "b": [1, 2]})  # key order aside
    assert fingerprint({"a": "x", "b": [1, 3]}) != expected


def test_the_current_provenance_is_version_revision_and_numerics(monkeypatch):
    monkeypatch.setenv(REVISION_VARIABLE, "r1")
    assert current() == {
        "hpcontact_version": hpcontact.__version__,
        "git_revision": "r1",
        "numerics": fingerprint(numerics()),
    }


def test_a_contact_scene_resolves_to_every_default_with_the_given_fields_kept():
    resolved = resolved_scene({"shape": "ellipse", "aspect": 0.5})
    assert set(resolved) >= set(DEFAULTS)
    assert resolved["shape"] == "ellipse" and resolved["aspect"] == 0.5
    for name in ("nu", "G", "n", "tol", "seed"):
        assert resolved[name] == DEFAULTS[name], name


def test_a_slip_scene_resolves_to_its_validated_fields():
    resolved = resolved_scene(
        {"quantities": "slip", "radius": 1.0, "load": 1.0, "mu": 0.3, "q_ratio": 0.5, "E": 2.0, "nu": 0.0}
    )
    assert resolved["steps"] == 10 and resolved["n"] == 64 and resolved["control"] == "force"
    assert resolved["pair"]["body1"]["material"] == {"G": 1.0, "nu": 0.0}  # G = E / 2(1 + nu)
    assert resolved["pair"]["body2"]["material"] is None  # rigid flat by default


def test_describe_says_unknown_for_a_missing_revision():
    assert describe({"hpcontact_version": "0.1", "git_revision": None, "numerics": "0123456789ab"}) == (
        "hpcontact 0.1 (git unknown, numerics 0123456789ab)"
    )


def _entry(key: str, rank: int = 0, host: str = "node1", **provenance) -> Entry:
    base = {"hpcontact_version": "0.1", "git_revision": "a", "numerics": "n1"}
    return Entry(key, {}, OK, "", {}, 0.0, 0.0, rank, host, {}, {**base, **provenance})


NOW = {"hpcontact_version": "0.1", "git_revision": "a", "numerics": "n1"}


def test_entries_of_this_code_have_no_mismatch():
    assert first_mismatch([_entry("k1"), _entry("k2")], NOW) is None
    assert first_mismatch([], NOW) is None


@pytest.mark.parametrize(
    ("changed", "difference"),
    [
        ({"hpcontact_version": "0.2"}, "package version"),
        ({"git_revision": "b"}, "git revision"),
        ({"numerics": "n2"}, "numerics fingerprint"),
    ],
)
def test_the_first_entry_of_other_code_is_named_with_its_first_difference(changed, difference):
    entries = [_entry("0" * 16), _entry("f" * 16, rank=3, host="node7", **changed), _entry("e" * 16, git_revision="c")]
    line = first_mismatch(entries, NOW)
    assert line is not None and line.startswith(f"task {'f' * 12} was computed by ")
    assert "on node7, rank 3; this is hpcontact 0.1 (git a, numerics n1)" in line
    assert line.endswith(f"(first difference: {difference})")


def test_contributors_count_the_tasks_of_each_provenance():
    entries = [_entry("1"), _entry("2", git_revision="b"), _entry("3"), _entry("4", numerics="n2")]
    listed = json.loads(contributors(entries))
    counts = {(c["git_revision"], c["numerics"]): c["tasks"] for c in listed}
    assert counts == {("a", "n1"): 2, ("b", "n1"): 1, ("a", "n2"): 1}
    assert all(set(c) == {"hpcontact_version", "git_revision", "numerics", "tasks"} for c in listed)
