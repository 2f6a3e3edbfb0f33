"""The units convention of the data set (hpcontact.sweep.data.units): a value in units of a scene scale
is stored as the dimensionless ratio (units "1", the scale in ``scale``), and ``dimensional``
multiplies the scale back in. Expected factors and unit strings are worked out by hand."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from hpcontact.sweep.data.units import cf_attributes, comment, convention, dimensional, scale_symbols


@pytest.mark.parametrize(
    ("unit", "symbols"),
    [
        ("G a", {"G", "a"}),
        ("G L2", {"G", "L"}),
        ("F L-1", {"F", "L"}),
        ("a2", {"a"}),
        ("Pa", set()),
        ("N m-1", set()),
        ("degree", set()),
        ("1", set()),
    ],
)
def test_the_scale_symbols_of_a_unit_are_read_from_its_factors(unit, symbols):
    assert scale_symbols(unit) == symbols


def test_a_scaled_unit_becomes_a_ratio_with_its_scale_named_three_ways():
    attrs = {"long_name": "stiffness K_xx", "units": "G a", "kind": "stiffness"}
    out = cf_attributes(attrs)
    assert out["units"] == "1" and out["scale"] == "G a"
    assert out["long_name"] == "stiffness K_xx (in units of G a)"
    assert out["comment"].startswith("dimensionless: the quantity divided by G a (G: the shear modulus")
    assert out["comment"].endswith("; multiply by G a for the quantity")
    assert out["kind"] == "stiffness"
    assert attrs == {"long_name": "stiffness K_xx", "units": "G a", "kind": "stiffness"}  # not changed in place


@pytest.mark.parametrize("unit", ["Pa", "N m-1", "degree", "1", "s"])
def test_a_udunits_unit_is_kept_as_it_is(unit):
    attrs = {"long_name": "something", "units": unit}
    assert cf_attributes(attrs) == attrs


def test_a_comment_names_each_scale_once_in_the_order_g_a_l_f():
    text = comment("F L-1 G a")
    where = [text.index(f"{symbol}: ") for symbol in ("G", "a", "L", "F")]
    assert where == sorted(where)
    assert text.count("G: ") == 1


def test_the_global_note_lists_the_scales_used_or_says_none_is():
    used = convention(["L", "G", "G", "Pa"])
    assert "(G, L)" in used and "G: the shear modulus" in used and "L: the length unit" in used
    assert "F: the force unit" not in used
    none = convention([])
    assert "(none in this data set)" in none and "No value is scaled" in none


def _stored(values, unit: str) -> xr.DataArray:
    return xr.DataArray(np.asarray(values, dtype=np.float64), dims=("x",), name="v").assign_attrs(
        cf_attributes({"long_name": "a value", "units": unit})
    )


@pytest.mark.parametrize(
    ("unit", "scales", "factor", "si"),
    [
        ("G a", {"G": 80e9, "a": 1e-3}, 8e7, "Pa m"),  # a stiffness in N/m
        ("G L2", {"G": 2.0, "L": 3.0}, 18.0, "Pa m2"),  # a force
        ("F L-1", {"F": 10.0, "L": 4.0}, 2.5, "N m-1"),  # a tangential stiffness
        ("L", {"L": 1e-6}, 1e-6, "m"),
    ],
)
def test_dimensional_multiplies_by_the_scale_and_names_the_si_unit(unit, scales, factor, si):
    ratio = _stored([1.0, 2.5, -4.0], unit)
    quantity = dimensional(ratio, **scales)
    np.testing.assert_allclose(quantity.values, np.array([1.0, 2.5, -4.0]) * factor, rtol=1e-15)
    assert quantity.attrs == {"long_name": "a value", "units": si}
    assert ratio.attrs["units"] == "1" and ratio.attrs["scale"] == unit  # the stored variable is kept


def test_dimensional_takes_the_unit_of_the_result_when_given():
    quantity = dimensional(_stored([2.0], "G a"), units="kN mm-1", G=1.0, a=1.0)
    assert quantity.attrs["units"] == "kN mm-1" and float(quantity[0]) == 2.0


def test_dimensional_names_every_missing_scale():
    with pytest.raises(ValueError, match=r"v: in units of G L2: give G, L \(e\.g\. G=1\.0\)"):
        dimensional(_stored([1.0], "G L2"))


def test_a_variable_without_a_scale_is_returned_as_it_is():
    plain = xr.DataArray([1.0], dims=("x",), attrs={"units": "Pa"})
    assert dimensional(plain, G=2.0) is plain


def _contact_area_attrs(scene: str) -> dict:
    """The data set attributes of ``contact_area`` for a one-point contact spec of ``scene``."""
    from hpcontact.sweep.data.attributes import attribute_table
    from hpcontact.sweep.space.parse import parse_spec

    spec = parse_spec(f'[sweep]\ntitle = "t"\noutput = "t.nc"\n[scene]\n{scene}\n[axes]\nnu = [0.2, 0.3]\n')
    return attribute_table(spec)["contact_area"]


def test_contact_area_is_named_for_what_it_is_the_punch_or_the_sphere():
    """A bonded punch's contact area is its outline's, in units of a²; an indentation's is under
    the sphere, in L²: the long_name says which (it said "under the sphere" for a punch)."""
    punch = _contact_area_attrs('shape = "ellipse"\naspect = 0.5\nquantities = ["tangential"]')
    sphere = _contact_area_attrs('quantities = ["indentation"]\nradius = 1.0\ndepth = 1e-4')
    assert "punch" in punch["long_name"] and "sphere" not in punch["long_name"], punch
    assert punch["scale"] == "a2" and "a2" in punch["long_name"], punch
    assert "under the sphere" in sphere["long_name"] and "punch" not in sphere["long_name"], sphere
