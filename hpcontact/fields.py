"""The one schema of a scene's fields: every field of a contact or a slip scene, declared once.

A ``Field`` holds what the rest of the package used to keep in its own table: the value's type
and default, its allowed range with the one message an ``InputError`` shows, the scene kinds
that read it (``CONTACT``, ``SLIP``) and which shapes, quantities or body descriptions read it
(``read_by``), its unit and long name in a data set, its help text on the command line, and
whether it changes a task's kernels, grids or cost. A field whose meaning differs between the
kinds (``n``: cells along the long side of a contact, across a slip contact) keeps one
declaration with its variant per kind (``Field.variants``); ``field(name, kind)`` gives it.

The tables of ``hpcontact.scene`` (``DEFAULTS``, ``UNUSED_FIELDS``), the options of ``hpcontact
solve``, the keywords of ``hpcontact.solve``, a sweep spec's type tables, the task-neutral
tables of ``hpcontact.sweep`` and a data set's coordinate attributes are queries of it
(``defaults``, ``names``, ``of_type``, ``axis_attrs``, ``cli_help``); a field is added here.

Floor 1: this module imports nothing of hpcontact but ``hpcontact.errors``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Literal

from hpcontact.errors import InputError, finite_number, integer

#: The scene kinds (``hpcontact.problems.kinds``): a flat punch or a rigid sphere on one body,
#: and the partial slip of two bodies (``quantities = "slip"``).
CONTACT = "contact"
SLIP = "slip"
KINDS = (CONTACT, SLIP)
#: What a field may change in a sweep's task (``hpcontact.sweep.work.tasks``): the kernels (tasks
#: differing only in a kernel-neutral field may share them), the grids ``default_grids``
#: picks, the estimated cost.
Effect = Literal["kernel", "grid", "cost"]
EFFECTS: tuple[Effect, ...] = ("kernel", "grid", "cost")

#: The contact shapes (``hpcontact.geometry.SHAPES``).
SHAPES = ("circle", "ellipse", "rectangle", "polygon", "star", "rough", "mask")
#: Moduli (G, E, a crystal's constants, in the scene's stress unit) within 1e-100 … 1e100: the
#: solver's arithmetic stays finite and normal there. Kernels scale as h/G (cells h down to
#: ~1e-16 a at b/a = 1e-12), CG inner products as N h^k G^±1 over up to 2**26 cells, and the
#: Barnett–Lothe kernel forms 3 x 3 Christoffel determinants, cubes of the constants: at
#: 1e±100 these are ~1e±300 at worst, inside float64's 1e-308 … 1.8e308 (measured: G = 1e300
#: fails on a 1024 grid, a crystal at 1e±290 on any grid).
MIN_MODULUS = 1e-100
MAX_MODULUS = 1e100


def modulus_range(what: str = "modulus") -> str:
    """The allowed range of a modulus in words (``MIN_MODULUS`` … ``MAX_MODULUS``)."""
    return f"{what} in [{MIN_MODULUS:g}, {MAX_MODULUS:g}] (finite arithmetic in the solver)"


#: The Poisson ratio of an isotropic body, the one statement of its range: nu = −1 (zero bulk
#: modulus) is refused, nu = 0.5 (incompressible) allowed, its closed-form kernels hold. A
#: crystal's stiffness needs nu < 0.5 (``materials.crystal.CRYSTAL_NU_RANGE``).
NU_RANGE = "Poisson ratio in (-1, 0.5]"
#: b/a below 1e-12 is refused: the cell integrals are verified for cell aspect 1e-10 … 1e10
#: (tests/kernels) and K_a/K_b for b/a down to 1e-12 (tests/test_hard_cases.py); by 1e-160 the
#: cell integrals overflow and by 1e-200 the cell height underflows.
MIN_ASPECT = 1e-12
ASPECT_RANGE = "b/a in [1e-12, 1]"
#: Sphere radius and approach: lengths, loads (~ E* R^1/2 d^3/2) and cell areas (~ R d) stay
#: far from overflow and underflow for radius in [1e-30, 1e30] and d/R in [1e-15, 1).
MIN_RADIUS = 1e-30
MIN_DEPTH = 1e-15
RADIUS_RANGE = "sphere radius in [1e-30, 1e30]"
DEPTH_RANGE = "approach d with d/radius in [1e-15, 1)"
#: The contact size ``a`` in metres (the semi-major extent; stiffnesses K = k G a then come out
#: in N/m): from an atomic-force tip to a machine foundation, far inside float64 either way.
MIN_CONTACT_SIZE = 1e-12
MAX_CONTACT_SIZE = 1e3
CONTACT_SIZE_RANGE = "contact size a in metres, in [1e-12, 1e3]"
#: A requested accuracy: the estimated relative error every reported stiffness must reach
#: (``hpcontact.accuracy.solve_to_accuracy``).
ACCURACY_RANGE = "a relative error in [1e-9, 1)"
#: Where a contact solve runs (``hpcontact.numerics.backend``): numpy with pyFFTW on the CPU, or
#: CuPy with cuFFT on an NVIDIA GPU, or "auto": each process its own GPU where it has one, else its CPU
#: (``backend.resolved_device``). Results agree to round-off (tests/gpu), so the field is neutral to
#: kernels and grids, not to cost.
DEVICES = ("cpu", "gpu", "auto")
#: What the ``tangential`` stiffness holds fixed in the normal direction (``hpcontact.plan``,
#: ``hpcontact.quantities.load_held_stiffness``): the normal approach (u_z = 0, the default:
#: Li 2017 and the existing data sets) or the normal load (F_z = 0, Mindlin 1949 / Cattaneo's
#: experiment). The two coincide for isotropic bodies; only ``tangential`` reads it.
NORMAL_HELD = ("approach", "load")
#: What a record states when its tangential stiffness holds the normal load: the field's value
#: (``recorded``), written where the Schur complement is formed (``quantities.stiffness_record``).
LOAD_HELD_RECORD: Mapping[str, str] = {"normal_held": "load"}


@dataclass(frozen=True)
class Interval:
    """The values ``low`` … ``high`` a number may take; an open end excludes its limit."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    high_open: bool = False

    def __contains__(self, value: float) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        below = value < self.high if self.high_open else value <= self.high
        return above and below


@dataclass(frozen=True)
class Field:
    """One field of a scene.

    ``type``: ``float``, ``int``, ``str``, ``bool`` or ``object`` (a list, mapping or string:
    Miller indices, elastic constants, quantities). ``default``: the engine's value when the
    field is left out (None: none, or required). ``interval`` and ``message``: the allowed
    values and the one text an ``InputError`` shows for a value outside them or not a number
    (``check``). ``kinds``: the scene kinds that read it (empty: an option of a solve, not a
    scene field, e.g. ``memory``). ``read_by``: (setting, its values whose scenes read the
    field, why the others do not or None) where only some scenes of a kind read it
    (``hpcontact.scene.UNUSED_FIELDS``). ``long_name`` and ``unit``: the data set's coordinate
    attributes (unit None: none), for the kinds in ``coordinate_of`` (default ``kinds``).
    ``help``: the command-line help, where ``{default}`` is " (default: X)", ``{value}`` the
    default, ``{range}`` the message and ``{choices}`` the choices (``cli_help``); ``option``:
    the option's name, ``group``: its group in ``hpcontact solve --help``, ``metavar``.
    ``changes``: what the field changes in a task (``EFFECTS``). ``text``: what a string value
    is, in words (a sweep spec's message); ``path``: an input file, ``flat``: a radius that may
    be infinite (a flat direction). ``recorded_by``: the quantities whose record carries the
    field's value when it is not the default (``recorded``). ``axis``: a sweep's ``[axes]`` may
    run over it (``axis_names``). ``doc``: its entry in the docstring of ``hpcontact.solve``
    (None: the command-line help, ``python_doc``); ``annotation``: the keyword's type there where
    it is not the value's type or None (``python_annotation``). ``variants``: the field's differences in a scene of another
    kind, as (kind, ((attribute, value), ...)) pairs (``field(name, kind)``; ``_in_slip``).
    """

    name: str
    type: type
    default: Any = None
    interval: Interval | None = None
    message: str | None = None
    kinds: tuple[str, ...] = (CONTACT,)
    read_by: tuple[str, tuple[str | None, ...], str | None] | None = None
    long_name: str | None = None
    unit: str | None = None
    coordinate_of: tuple[str, ...] | None = None
    help: str = ""
    option: str | None = None
    group: str | None = None
    metavar: str | None = None
    changes: frozenset[str] = frozenset(EFFECTS)
    choices: tuple[str, ...] = ()
    text: str | None = None
    path: bool = False
    flat: bool = False
    recorded_by: tuple[str, ...] = ()
    axis: bool = False
    doc: str | None = None
    annotation: str | None = None
    variants: tuple[tuple[str, tuple[tuple[str, Any], ...]], ...] = ()

    def check(self, value: Any) -> Any:
        """``value`` as this field's number (a finite float, or an integer for ``int``) inside
        ``interval``, else ``InputError(name, message, value)``."""
        message = self.message or ""
        if self.type is int:
            low = self.interval.low if self.interval else -math.inf
            high = self.interval.high if self.interval else math.inf
            return integer(self.name, value, int(low) if math.isfinite(low) else low, message, high)  # type: ignore[arg-type]
        number = finite_number(self.name, value, message)
        if self.interval is not None and number not in self.interval:
            raise InputError(self.name, message, value)
        return number

    @property
    def cli_option(self) -> str:
        """The option of ``hpcontact solve``: ``option``, else ``--`` and the name with dashes."""
        return self.option or f"--{self.name.replace('_', '-')}"


def _changes(*effects: Effect) -> frozenset[str]:
    return frozenset(effects)


def _in_slip(**changes: Any) -> tuple[tuple[str, tuple[tuple[str, Any], ...]], ...]:
    """``Field.variants`` of a field that differs in a slip scene by ``changes`` (attribute=value)."""
    return ((SLIP, tuple(changes.items())),)


_NONE: frozenset[str] = frozenset()
_SHAPE = _changes("grid", "cost")  # the outline: not the material or the grid spacing
_BOTH = (CONTACT, SLIP)

#: Every field: the contact scene's in the order of ``hpcontact.scene.DEFAULTS`` (within each
#: group of ``hpcontact solve --help``: scene, material, numerics, the order of its options),
#: then the slip scene's own.
FIELDS: tuple[Field, ...] = (
    # scene
    Field(
        "shape",
        str,
        "circle",
        choices=SHAPES,
        long_name="contact shape",
        help="{choices}{default}",
        group="scene",
        doc="``circle`` [default], ``ellipse``, ``rectangle``, ``polygon``, ``star``, ``rough`` or ``mask``.",
        axis=True,
        changes=_SHAPE,
    ),
    Field(
        "aspect",
        float,
        1.0,
        Interval(MIN_ASPECT, 1.0),
        ASPECT_RANGE,
        read_by=("shape", ("ellipse", "rectangle"), None),
        long_name="aspect ratio b/a of the contact",
        unit="1",
        help="b/a of ellipse or rectangle, in [1e-12, 1]{default}",
        group="scene",
        doc="b/a of an ellipse or rectangle, in [1e-12, 1] [1].",
        axis=True,
    ),
    Field(
        "sides",
        int,
        5,
        Interval(2),
        "an integer >= 2",
        read_by=("shape", ("polygon", "star"), None),
        long_name="polygon sides or star lobes",
        unit="1",
        help="polygon sides or star lobes{default}",
        group="scene",
        doc="Sides of a polygon, lobes of a star (≥ 2) [5].",
        changes=_SHAPE,
    ),
    Field(
        "shape_angle",
        float,
        0.0,
        None,
        "a finite angle in degrees",
        read_by=(
            "shape",
            tuple(s for s in SHAPES if s not in ("mask", "rough")),
            "a mask or a rough patch is not turned",
        ),
        long_name="rotation of the shape on the grid",
        unit="degree",
        help="turn the shape by this angle (degrees){default}",
        group="scene",
        doc="Turn of the shape (and of a crystal's lattice with it), degrees [0].",
        changes=_SHAPE,
    ),
    Field(
        "amplitude",
        float,
        0.2,
        None,
        "star modulation in [0, 1)",
        read_by=("shape", ("star",), None),
        long_name="relative lobe amplitude of the star",
        unit="1",
        help="star modulation epsilon of r = 1 + eps cos(k phi){default}",
        group="scene",
        doc="Star modulation ε of r = 1 + ε cos(k φ), in [0, 1) [0.2].",
        changes=_SHAPE,
    ),
    Field(
        "seed",
        int,
        0,
        Interval(0),
        "an integer >= 0",
        read_by=("shape", ("rough",), None),
        long_name="random seed of the rough surface",
        unit="1",
        help="seed of the rough surface{default}",
        group="scene",
        doc="The rough surface's random seed [0].",
        changes=_SHAPE,
    ),
    Field(
        "hurst",
        float,
        0.8,
        None,
        "Hurst exponent in (0, 1)",
        read_by=("shape", ("rough",), None),
        long_name="Hurst exponent of the rough surface",
        unit="1",
        help="Hurst exponent of the rough surface, in (0, 1){default}",
        group="scene",
        doc="The rough surface's Hurst exponent, in (0, 1) [0.8].",
        changes=_SHAPE,
    ),
    Field(
        "rms",
        float,
        0.02,
        None,
        "roughness rms in (0, 1]",
        read_by=("shape", ("rough",), None),
        long_name="rms height of the rough surface",
        unit="a",
        help="rms height of the rough surface (units of a){default}",
        group="scene",
        doc="The rough surface's rms height, in units of a [0.02].",
        changes=_SHAPE,
    ),
    Field(
        "mask",
        str,
        None,
        read_by=("shape", ("mask",), None),
        long_name="contact mask image (path)",
        help="contact mask file (.npy or .png) for --shape mask; a = half the long side of the contact",
        group="scene",
        doc='Contact mask file (.npy, or .png: dark pixels in contact) for ``shape="mask"``; unit a is half the long side of the contact.',
        annotation="str | os.PathLike[str] | None",
        changes=_SHAPE,
        text="a .npy or .png mask file; a relative path is relative to the spec's folder",
        path=True,
    ),
    # material
    Field(
        "nu",
        float,
        0.3,
        Interval(-1.0, 0.5, low_open=True),
        NU_RANGE,
        kinds=_BOTH,
        read_by=("body", (None,), None),
        long_name="Poisson ratio",
        unit="1",
        help="{range}; < 0.5 for a crystal (A != 1){default}",
        group="material",
        doc="Poisson ratio in (-1, 0.5], < 0.5 for a crystal (A ≠ 1) [0.3].",
        axis=True,
        changes=_changes("kernel"),
        variants=_in_slip(default=None, long_name="Poisson ratio of body 1"),
    ),
    Field(
        "G",
        float,
        1.0,
        Interval(MIN_MODULUS, MAX_MODULUS),
        modulus_range("shear modulus"),
        kinds=_BOTH,
        read_by=("body", (None,), None),
        long_name="shear modulus G: the stress unit of the scene",
        unit="1",
        help="shear modulus: the stress unit of the results{default}",
        group="material",
        doc="Shear modulus, the stress unit of the scene [1].",
        changes=_changes("kernel"),
        variants=_in_slip(default=None, long_name="shear modulus of body 1", unit="F L-2"),
    ),
    Field(
        "anisotropy",
        float,
        1.0,
        Interval(0.01, 100.0),
        "cubic anisotropy factor A in [0.01, 100]",
        kinds=_BOTH,
        read_by=("body", (None,), None),
        long_name="cubic anisotropy factor A = 2 C44 / (C11 - C12)",
        unit="1",
        help="cubic anisotropy factor A = 2 C44/(C11 - C12), 1 = isotropic{default}",
        group="material",
        doc="Cubic anisotropy factor A = 2 C44/(C11 − C12) in [0.01, 100]; 1 is isotropic [1]. ``nu``, ``G`` and ``anisotropy`` describe the body only without ``material``, ``cubic``, ``orthotropic`` or ``voigt``: beside one of them (its constants give the whole stiffness) they raise ``InputError``.",
        axis=True,
        variants=_in_slip(default=None, long_name=None),
    ),
    Field(
        "orientation",
        float,
        None,
        Interval(0.0, 90.0),
        "path angle psi in [0, 90] degrees ([110] -> [111] -> [001])",
        kinds=_BOTH,
        long_name="surface normal along [110] -> [111] -> [001]",
        unit="degree",
        help="surface normal along [110] -> [111] -> [001], psi in [0, 90] degrees (default: [001])",
        group="material",
        doc="Surface normal along [110] → [111] → [001]: ψ in [0, 90] degrees [[001]].",
        axis=True,
        changes=_changes("kernel"),
        variants=_in_slip(long_name="surface normal of the crystal along [110] -> [111] -> [001]"),
    ),
    Field(
        "miller",
        object,
        None,
        None,
        'three integers "h k l", not all zero',
        kinds=_BOTH,
        long_name="surface normal (h k l) of the crystal",
        help='surface normal as Miller indices "h k l" (default: "0 0 1")',
        group="material",
        doc='Surface normal as Miller indices, ``"1 1 0"`` or ``(1, 1, 0)`` (not with orientation).',
        annotation="str | Sequence[int] | None",
        changes=_changes("kernel"),
    ),
    Field(
        "azimuth",
        float,
        0.0,
        None,
        "a finite in-plane angle in degrees",
        kinds=_BOTH,
        long_name="in-plane turn of the crystal about the surface normal",
        unit="degree",
        help="in-plane turn of the crystal (degrees){default}",
        group="material",
        doc="In-plane turn of the crystal, degrees [0].",
        changes=_changes("kernel"),
    ),
    Field(
        "material",
        str,
        None,
        kinds=_BOTH,
        long_name="library crystal (elastic constants in GPa)",
        help="library crystal by name (Cu, Al, Fe, Ni, W, Si, ...; GPa); with --quantities slip: the isotropic "
        "body 1 (Cu, Fe/steel, Al, rigid) or a crystal as crystal:NAME",
        group="material",
        doc='Library crystal by name (``Cu``, ``Al``, ``Fe``, ``Ni``, ``W``, ``Si``, ...; constants in GPa). With ``quantities="slip"``: body 1 (``Cu``, ``Fe``/``steel``, ``Al``, ``rigid``, or ``crystal:NAME``).',
        axis=True,
        text="a library material name (crystals: Cu, Al, Fe, ...; slip bodies: Cu, Fe, Al, rigid)",
        variants=_in_slip(long_name="material of body 1 (hpcontact.problems.slip.bodies library, or crystal:NAME)"),
    ),
    Field(
        "cubic",
        object,
        None,
        kinds=_BOTH,
        help='cubic crystal "C11=... C12=... C44=..." (GPa)',
        group="material",
        doc='Cubic crystal ``"C11=... C12=... C44=..."`` (GPa), a mapping or three numbers.',
        annotation="str | Mapping[str, float] | Sequence[float] | None",
    ),
    Field(
        "orthotropic",
        object,
        None,
        kinds=_BOTH,
        help='orthotropic "E1=.. E2=.. E3=.. G12=.. G13=.. G23=.. nu12=.. nu13=.. nu23=.." (GPa)',
        group="material",
        doc='Orthotropic engineering constants ``"E1=.. E2=.. E3=.. G12=.. G13=.. G23=.. nu12=.. nu13=.. nu23=.."`` (GPa), a mapping or nine numbers.',
        annotation="str | Mapping[str, float] | Sequence[float] | None",
        variants=_in_slip(long_name="orthotropic engineering constants of body 1"),
    ),
    Field(
        "voigt",
        object,
        None,
        kinds=_BOTH,
        help="general 6 x 6 Voigt stiffness, 36 numbers row by row (GPa)",
        group="material",
        doc="General 6 × 6 Voigt stiffness (GPa): 36 numbers row by row or a nested 6 × 6 list.",
        annotation="str | Sequence[float] | Sequence[Sequence[float]] | None",
    ),
    # numerics
    Field(
        "n",
        int,
        128,
        Interval(2),
        "an integer >= 2 (cells along the long side)",
        kinds=_BOTH,
        long_name="grid cells along the long side",
        unit="1",
        help="cells along the long side (default: as --accuracy 1e-4 for shapes with an outline, any material; else {value})",
        group="numerics",
        doc="Cells along the long side. Without it (and without ``accuracy``): as ``accuracy=1e-4`` (``hpcontact.accuracy.DEFAULT_ACCURACY``) where that applies (the one exact cell of a circle or an ellipse, any material; refined grids extrapolated for other outlined shapes, any material), else 128 (a rough patch, a mask).",
        axis=True,
        variants=_in_slip(
            default=64,
            interval=Interval(8, 4096),
            message="an integer in [8, 4096] (cells across the contact)",
            long_name="grid cells across the contact's major diameter",
        ),
    ),
    Field(
        "n_across",
        int,
        None,
        Interval(1),
        "an integer >= 1 (cells across the short side)",
        long_name="grid cells across the short side",
        unit="1",
        help="cells across the short side (thin shapes; default: as along)",
        group="numerics",
        doc="Cells across the short side (thin shapes).",
    ),
    Field(
        "tol",
        float,
        1e-8,
        Interval(1e-14, 1e-2),
        "CG tolerance in [1e-14, 1e-2]",
        kinds=_BOTH,
        long_name="conjugate-gradient relative residual tolerance",
        unit="1",
        help="CG relative residual tolerance, in [1e-14, 1e-2]{default}",
        group="numerics",
        doc="Conjugate-gradient relative residual tolerance in [1e-14, 1e-2] [1e-8].",
        axis=True,
        changes=_changes("cost"),
        variants=_in_slip(interval=Interval(1e-14, 1e-4), message="a tolerance in [1e-14, 1e-4]"),
    ),
    Field(
        "accuracy",
        float,
        None,
        Interval(1e-9, 1.0, high_open=True),
        ACCURACY_RANGE,
        long_name="requested relative accuracy of every stiffness (grid extrapolation)",
        unit="1",
        help="extrapolate over grids until the estimated relative error <= REL, in [1e-9, 1) (default: off)",
        group="numerics",
        doc='Extrapolate over refined grids until the estimated relative error of every reported stiffness is ≤ this (in [1e-9, 1)), exactly as ``hpcontact solve --accuracy`` (``hpcontact.accuracy.solve_to_accuracy``, strategy "auto"); ``n`` is then ignored.',
        axis=True,
        metavar="REL",
    ),
    Field(
        "memory",
        str,
        None,
        kinds=(),
        help="memory budget of a contact solve, e.g. 2G (default: this machine's memory per core)",
        group="numerics",
        doc='Memory budget of a contact solve (``"2G"``, ``"512M"`` or bytes) [this machine\'s memory per core]: with ``accuracy`` its grids are planned within it; a one-grid solve (``n`` given, or a scene the default solves on one grid) whose estimated peak exceeds it is refused before anything is allocated (``InputError``, field ``memory``, or ``n`` without it). Not for ``quantities="slip"``.',
        annotation="str | int | None",
        metavar="SIZE",
    ),
    Field(
        "quantities",
        object,
        ("tangential",),
        kinds=_BOTH,
        long_name="quantities solved for",
        help="comma list: tangential, normal, compliance, coupled, indentation; or slip{default}",
        group="scene",
        doc="Comma string or list of ``tangential`` [default], ``normal``, ``compliance``, ``coupled``, ``indentation``; or ``slip`` (partial slip of two bodies: give its fields below as keywords, e.g. ``radius=0.01, load=100.0, mu=0.3, q_ratio=0.5``).",
        annotation="str | Sequence[str] | None",
        changes=_SHAPE,
        variants=_in_slip(default=("slip",)),
    ),
    Field(
        "radius",
        float,
        None,
        Interval(MIN_RADIUS, 1.0 / MIN_RADIUS),
        RADIUS_RANGE,
        kinds=_BOTH,
        read_by=("quantities", ("indentation",), None),
        long_name="radius R of the rigid sphere",
        unit="L",
        help="rigid sphere radius (indentation; unit L of your choice), or radius of body 1 (slip)",
        group="scene",
        doc='Rigid sphere radius (``indentation``), in a length unit L of your choice; with ``quantities="slip"``: the radius of body 1.',
        variants=_in_slip(interval=None, message=None, long_name="radius of curvature of body 1"),
    ),
    Field(
        "depth",
        float,
        None,
        None,
        DEPTH_RANGE,
        read_by=("quantities", ("indentation",), None),
        long_name="approach d of the rigid sphere",
        unit="L",
        help="rigid sphere approach (indentation), in [1e-15, 1) x radius",
        group="scene",
        doc="Rigid sphere approach (``indentation``), in the unit L of ``radius``, in [1e-15, 1) × radius.",
    ),
    Field(
        "a",
        float,
        None,
        Interval(MIN_CONTACT_SIZE, MAX_CONTACT_SIZE),
        CONTACT_SIZE_RANGE,
        read_by=(
            "quantities",
            ("tangential", "normal", "compliance", "coupled"),
            "an indentation's lengths are in the unit of its radius",
        ),
        long_name="semi-major extent a of the contact",
        unit="m",
        help="contact size: the semi-major extent a in metres; stiffnesses then in N/m (the body's modulus "
        "in Pa: --G, or a library crystal or elastic constants in GPa)",
        group="scene",
        doc="Contact size: the semi-major extent a in metres, in [1e-12, 1e3] (not for ``indentation``). Every stiffness of the record is then in N/m (K = k G a), which needs the body's modulus in physical units: ``G`` in Pa, or a library crystal or elastic constants in GPa.",
        changes=_NONE,
    ),
    Field(
        "threads",
        int,
        1,
        None,
        "an integer in [1, {}] (this machine's CPUs)",
        kinds=_BOTH,
        long_name="FFTW threads per solve",
        unit="1",
        help="FFTW threads{default}; BLAS: HPCONTACT_BLAS_THREADS (default: 1)",
        group="numerics",
        doc="FFTW threads [1]. BLAS threads: ``$HPCONTACT_BLAS_THREADS`` [1], only while solving.",
        changes=_NONE,
        variants=_in_slip(interval=Interval(1, 1024), message="an integer >= 1"),
    ),
    Field(
        "precondition",
        bool,
        True,
        kinds=_BOTH,
        help="plain CG, for comparison (default: Fourier-preconditioned CG)",
        option="--no-precondition",
        group="numerics",
        doc="Fourier-preconditioned CG [True]; False for plain CG.",
        changes=_NONE,
    ),
    Field(
        "device",
        str,
        "cpu",
        choices=DEVICES,
        kinds=_BOTH,
        long_name="device of the solves: cpu (numpy, pyFFTW), gpu (CuPy, cuFFT) or auto (the rank's own GPU, else its CPU)",
        help="where the solves run (contact and slip): {choices}{default} (gpu: CuPy and a CUDA device, ranks beyond the node's GPUs share them; auto: node-local rank r on GPU r while r < the visible GPUs, the others on the CPU)",
        group="numerics",
        doc='Where the solves run, of a contact or a slip scene: ``"cpu"`` [default] (numpy, pyFFTW), ``"gpu"`` (CuPy, cuFFT; the optional extra ``gpu``), one GPU per process (its rank on the node modulo the visible devices), or ``"auto"``: a GPU of its own where the process has one (node-local rank r on GPU r while r is below the visible devices), its CPU elsewhere, so CPU and GPU ranks run one sweep. Results agree to round-off. A GPU without CuPy or without a CUDA device raises ``InputError`` saying which ("auto" never does).',
        changes=_changes("cost"),
        text="cpu, gpu or auto: where the solves run",
    ),
    Field(
        "normal_held",
        str,
        "approach",
        choices=NORMAL_HELD,
        long_name="what the tangential stiffness holds in the normal direction: approach (u_z = 0) or load (F_z = 0)",
        help="what tangential holds normally: approach (u_z = 0) or load (F_z = 0; differs for crystals only){default}",
        group="scene",
        doc='What ``tangential`` holds in the normal direction: ``"approach"`` (u_z = 0) [default] or ``"load"`` (F_z = 0, Cattaneo–Mindlin: the Schur complement K_tt − K_tz K_zz⁻¹ K_zt of the 3 × 3 Re-H stiffness, one more solve for a crystal; the same as ``"approach"`` for an isotropic body). The record then has ``normal_held`` = "load".',
        axis=True,
        changes=_changes("cost"),
        recorded_by=("tangential",),
        text="approach or load: what the tangential stiffness holds in the normal direction",
    ),
    # partial slip
    *(
        Field(
            name,
            float,
            None,
            kinds=(SLIP,),
            long_name=long_name,
            unit="L",
            help=text,
            group="slip",
            flat=True,
            annotation="float | str | None",
        )
        for name, long_name, text in (
            (
                "radius_b",
                "second principal radius of curvature of body 1",
                "second principal radius of body 1 (ellipsoid)",
            ),
            ("radius2", "radius of curvature of body 2 (inf: flat)", "radius of body 2 (default: a flat)"),
            ("radius2_b", "second principal radius of curvature of body 2", "second principal radius of body 2"),
        )
    ),
    Field(
        "body2_angle",
        float,
        0.0,
        kinds=(SLIP,),
        long_name="angle between the principal axes of the bodies",
        unit="degree",
        help="angle between the principal axes of the bodies (degrees)",
        group="slip",
    ),
    Field(
        "material2",
        str,
        None,
        kinds=(SLIP,),
        long_name="material of body 2 (hpcontact.problems.slip.bodies library, or crystal:NAME)",
        help="body 2 by name (Cu, Fe/steel, Al, rigid)",
        group="slip",
        text="a library material name of body 2 (Cu, Fe, Al, rigid)",
    ),
    Field(
        "E",
        float,
        None,
        kinds=(SLIP,),
        long_name="Young's modulus of body 1",
        unit="F L-2",
        help="Young's modulus of body 1",
        group="slip",
    ),
    Field(
        "E2",
        float,
        None,
        kinds=(SLIP,),
        long_name="Young's modulus of body 2",
        unit="F L-2",
        help="Young's modulus of body 2",
        group="slip",
    ),
    Field(
        "G2",
        float,
        None,
        kinds=(SLIP,),
        long_name="shear modulus of body 2",
        unit="F L-2",
        help="shear modulus of body 2",
        group="slip",
    ),
    Field(
        "nu2",
        float,
        None,
        kinds=(SLIP,),
        long_name="Poisson ratio of body 2",
        unit="1",
        help="Poisson ratio of body 2",
        group="slip",
    ),
    Field(
        "load",
        float,
        None,
        Interval(0.0, low_open=True),
        "a normal load, finite and > 0",
        kinds=(SLIP,),
        long_name="normal load P",
        unit="F",
        help="normal load P (> 0)",
        group="slip",
        axis=True,
        changes=_changes("grid", "cost"),
    ),
    Field(
        "mu",
        float,
        None,
        None,
        "a friction coefficient, 0 or finite and >= 1e-6",
        kinds=(SLIP,),
        long_name="friction coefficient",
        unit="1",
        help="friction coefficient (>= 0)",
        group="slip",
        axis=True,
        changes=_changes("grid", "cost"),
    ),
    Field(
        "q_ratio",
        float,
        None,
        Interval(0.0, 1.0, high_open=True),
        "Q/(mu P) in [0, 1) (1 is gross sliding)",
        kinds=(SLIP,),
        long_name="tangential load at the end of the path Q/(mu P)",
        unit="1",
        help="tangential load Q/(mu P) in [0, 1)",
        group="slip",
        axis=True,
        changes=_changes("grid", "cost"),
    ),
    Field(
        "angle",
        float,
        0.0,
        None,
        "a finite angle in degrees",
        kinds=(SLIP,),
        long_name="direction of the tangential load from the x axis",
        unit="degree",
        coordinate_of=_BOTH,
        help="direction of the tangential load (degrees from x)",
        group="slip",
        axis=True,
        changes=_changes("grid", "cost"),
        variants=_in_slip(long_name="direction of the tangential load from x"),
    ),
    Field(
        "steps",
        int,
        10,
        Interval(1, 1000),
        "an integer in [1, 1000]",
        kinds=(SLIP,),
        long_name="tangential load steps",
        unit="1",
        help="tangential load steps",
        group="slip",
        changes=_changes("grid", "cost"),
    ),
    Field(
        "control",
        str,
        "force",
        choices=("force", "displacement"),
        kinds=(SLIP,),
        long_name="tangential load control: force or displacement",
        help="force or displacement",
        group="slip",
        changes=_changes("grid", "cost"),
        text="force or displacement",
    ),
    Field(
        "displacement",
        float,
        None,
        Interval(0.0),
        "a finite displacement >= 0",
        kinds=(SLIP,),
        long_name="final tangential displacement (displacement control)",
        unit="L",
        help="final tangential displacement (with control displacement)",
        group="slip",
        changes=_changes("grid", "cost"),
    ),
    Field(
        "path",
        str,
        "load",
        choices=("load", "loop", "proportional"),
        kinds=(SLIP,),
        long_name="tangential loading path: load, or loop (load, unload, reload)",
        help="load (monotonic), loop (load, unload, reload) or proportional (normal load with the displacement)",
        group="slip",
        changes=_changes("grid", "cost"),
        text="load or loop",
    ),
    Field(
        "coupling",
        str,
        "auto",
        choices=("auto", "both", "coupled", "decoupled"),
        kinds=(SLIP,),
        long_name="coupling of the normal and tangential problems: auto, both, coupled or decoupled",
        help="auto, both, coupled or decoupled",
        group="slip",
        changes=_changes("grid", "cost"),
        text="auto, both, coupled or decoupled",
    ),
    Field(
        "tensor",
        bool,
        False,
        kinds=(SLIP,),
        help="add the incremental 2 x 2 tangential stiffness tensor",
        group="slip",
        changes=_changes("grid", "cost"),
    ),
    Field(
        "history",
        bool,
        False,
        kinds=(SLIP,),
        help="add every load step",
        group="slip",
        changes=_changes("grid", "cost"),
    ),
    Field(
        "normal_friction",
        bool,
        False,
        kinds=(SLIP,),
        help="apply the normal load in steps with friction (Spence; coupled path)",
        group="slip",
    ),
    Field(
        "anisotropy2",
        float,
        None,
        kinds=(SLIP,),
        help="body 2: cubic anisotropy factor A (with nu2 and G2 or E2)",
        group="slip",
        axis=True,
    ),
    Field(
        "orientation2",
        float,
        None,
        kinds=(SLIP,),
        help="body 2: normal along [110] -> [111] -> [001], psi in degrees (lab frame)",
        group="slip",
        axis=True,
    ),
    Field(
        "miller2",
        object,
        None,
        kinds=(SLIP,),
        help='body 2: lattice direction "h k l" along the lab normal',
        group="slip",
        annotation="str | Sequence[int] | None",
    ),
    Field(
        "azimuth2",
        float,
        None,
        kinds=(SLIP,),
        help="body 2: in-plane turn of the crystal (degrees)",
        group="slip",
    ),
    Field(
        "cubic2",
        object,
        None,
        kinds=(SLIP,),
        help='body 2: cubic crystal "C11=... C12=... C44=..." (GPa)',
        group="slip",
        annotation="str | Mapping[str, float] | Sequence[float] | None",
    ),
    Field(
        "orthotropic2",
        object,
        None,
        kinds=(SLIP,),
        long_name="orthotropic engineering constants of body 2",
        help="body 2: orthotropic engineering constants (GPa), as orthotropic",
        group="slip",
        annotation="str | Mapping[str, float] | Sequence[float] | None",
    ),
    Field(
        "voigt2",
        object,
        None,
        kinds=(SLIP,),
        help="body 2: general 6 x 6 Voigt stiffness, 36 numbers (GPa)",
        group="slip",
        annotation="str | Sequence[float] | Sequence[Sequence[float]] | None",
    ),
)
_BY_NAME = {f.name: f for f in FIELDS}


def field(name: str, kind: str = CONTACT) -> Field:
    """The field ``name`` as a scene of ``kind`` reads it (its variant for that kind, if any)."""
    f = _BY_NAME[name]
    changes = dict(f.variants).get(kind)
    return dataclasses.replace(f, **dict(changes)) if changes else f


def names(kind: str | None = None, neutral_to: Effect | None = None) -> tuple[str, ...]:
    """The scene fields (of ``kind``; None: of any kind) in declaration order; with
    ``neutral_to``, those that do not change a task's kernels, grids or cost."""
    return tuple(
        f.name
        for f in (field(g.name, kind or CONTACT) for g in FIELDS)
        if (f.kinds if kind is None else kind in f.kinds) and (neutral_to is None or neutral_to not in f.changes)
    )


def defaults(kind: str = CONTACT) -> dict[str, Any]:
    """Every field of ``kind`` with the engine's default (None: none, or required)."""
    return {name: field(name, kind).default for name in names(kind)}


def of_type(value_type: type, kind: str | None = None) -> frozenset[str]:
    """The scene fields (of ``kind``) whose value is a ``value_type`` (``float``, ``int``,
    ``str``, ``bool``, ``object``)."""
    return frozenset(name for name in names(kind) if _BY_NAME[name].type is value_type)


def string_texts() -> dict[str, str]:
    """Fields whose value is a string, each with what it is in words (a sweep spec's message)."""
    return {f.name: f.text for f in FIELDS if f.text is not None}


def path_fields() -> frozenset[str]:
    """Fields naming an input file (a sweep spec's relative path is relative to its folder)."""
    return frozenset(f.name for f in FIELDS if f.path)


def flat_fields() -> frozenset[str]:
    """Radii that may be infinite: inf, or the strings "inf" / "flat" (a flat direction)."""
    return frozenset(f.name for f in FIELDS if f.flat)


def read_by(setting: str | None = None) -> dict[str, tuple[str, tuple[str | None, ...], str | None]]:
    """Fields that only some contact scenes read (field -> ``Field.read_by``), those decided
    by ``setting`` (``shape``, ``quantities``, ``body``) when given."""
    return {f.name: f.read_by for f in FIELDS if f.read_by is not None and setting in (None, f.read_by[0])}


def recorded(quantities: tuple[str, ...], values: Mapping[str, Any]) -> dict[str, Any]:
    """The fields a contact record of ``quantities`` states, from a scene's ``values``: each
    whose value is not its default where a quantity that reads it is asked (``recorded_by``:
    ``normal_held = "load"`` beside ``tangential``)."""
    return {
        f.name: values[f.name]
        for f in FIELDS
        if any(q in f.recorded_by for q in quantities) and values[f.name] != f.default
    }


def axis_names() -> tuple[str, ...]:
    """The fields a sweep's ``[axes]`` may run over (``Field.axis``), in declaration order."""
    return tuple(f.name for f in FIELDS if f.axis)


def recorded_names() -> tuple[str, ...]:
    """The fields a contact record may state (``recorded``), in declaration order."""
    return tuple(f.name for f in FIELDS if f.recorded_by)


def axis_attrs(kind: str = CONTACT) -> dict[str, dict[str, str]]:
    """A data set's attributes of each field as a coordinate of ``kind``'s sweeps: long_name
    and, where it has one, units."""
    table: dict[str, dict[str, str]] = {}
    for g in FIELDS:
        f = field(g.name, kind)
        if kind in (f.coordinate_of or f.kinds) and f.long_name is not None:
            table[f.name] = {"long_name": f.long_name, **({"units": f.unit} if f.unit else {})}
    return table


def default_text(name: str) -> str:
    """ " (default: X)": the engine's default of the contact field ``name``, a list joined by commas."""
    value = field(name).default
    shown = ",".join(value) if isinstance(value, (list, tuple)) else value
    return f" (default: {shown})"


def cli_help(name: str) -> str:
    """The help text of the field's ``hpcontact solve`` option."""
    f = _BY_NAME[name]
    return (
        f.help.replace("{default}", default_text(name))
        .replace("{value}", str(f.default))
        .replace("{range}", f.message or "")
        .replace("{choices}", ", ".join(f.choices))
    )


def python_annotation(name: str) -> str:
    """The type of the field's keyword of ``hpcontact.solve``, as an annotation's text:
    ``Field.annotation``, else its value's type or None (``Any`` for an ``object``)."""
    f = _BY_NAME[name]
    if f.annotation is not None:
        return f.annotation
    return "Any" if f.type is object else f"{f.type.__name__} | None"


def python_doc(name: str) -> str:
    """The field's entry in the docstring of ``hpcontact.solve``: ``Field.doc``, else (a slip
    scene's own field) its command-line help."""
    f = _BY_NAME[name]
    return f.doc if f.doc is not None else f'Partial slip (``quantities="slip"`` only): {cli_help(name)}.'


def cli_fields(group: str | None = None) -> tuple[Field, ...]:
    """The fields that are options of ``hpcontact solve`` (in ``group`` when given), in order."""
    return tuple(f for f in FIELDS if f.group is not None and group in (None, f.group))
