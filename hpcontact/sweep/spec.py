"""The sweep spec, split by role into ``hpcontact.sweep.space``: ``parse`` (the spec's format,
``load_spec``, ``parse_spec``), ``axes`` (field type tables, axis values), ``spec`` (the checked
``Spec``, ``canonical_json``) and ``enumeration`` (``scene_runs``, its checks)."""

# moved: importers outside this helper are updated by the coordinator
from hpcontact.sweep.space.axes import LABEL_AXES, MAX_POINTS, PATH_FIELDS
from hpcontact.sweep.space.enumeration import Run, run_field, scene_runs, scene_texts, text_template
from hpcontact.sweep.space.parse import MAX_SPEC_BYTES, load_spec, parse_spec
from hpcontact.sweep.space.spec import Spec, Validator, canonical_json

__all__ = [
    "LABEL_AXES",
    "MAX_POINTS",
    "MAX_SPEC_BYTES",
    "PATH_FIELDS",
    "Run",
    "Spec",
    "Validator",
    "canonical_json",
    "load_spec",
    "parse_spec",
    "run_field",
    "scene_runs",
    "scene_texts",
    "text_template",
]
