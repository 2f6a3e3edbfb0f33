"""Grids and contact shapes: which cells of a uniform grid belong to the contact area.

A grid is nx × ny rectangular cells of size dx × dy (independent: a rectangle of aspect 1e-8 is
meshed with cells of aspect ~1e-7, docs/design.md §2.2), centred on the origin. Shapes are scaled so that
their semi-major extent is 1 (docs/design.md §4.1): circle radius 1, ellipse semi-axes 1 and b/a,
rectangle half-sides 1 and b/a, polygon and star circumradius 1. A cell belongs to the contact
when its centre lies inside the shape (centre-in-shape rasterization). Lengths are dimensionless
(in units of the semi-major extent).
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import stat
import struct
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hpcontact.errors import InputError
from hpcontact.fields import field

SHAPES = ("circle", "ellipse", "rectangle", "polygon", "star", "rough", "mask")
#: The most cells a scene's grid may have (``hpcontact.scene``: n · n_across); a mask file's
#: pixels count against it, read from its header before anything is decoded (``mask_pixels``).
MAX_GRID_CELLS = 2**26
MASK_SUFFIXES = (".npy", ".png")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: .npy element kinds a mask may hold (bool, integers, floats, complex): non-zero is contact.
MASK_DTYPE_KINDS = "biufc"


@dataclass(frozen=True)
class Grid:
    """nx × ny cells of size dx × dy, cell centres at ((i − (nx−1)/2) dx, (j − (ny−1)/2) dy)."""

    nx: int
    ny: int
    dx: float
    dy: float

    @property
    def x(self) -> np.ndarray:
        """Cell-centre x coordinates, shape (nx,)."""
        return (np.arange(self.nx) - 0.5 * (self.nx - 1)) * self.dx

    @property
    def y(self) -> np.ndarray:
        """Cell-centre y coordinates, shape (ny,)."""
        return (np.arange(self.ny) - 0.5 * (self.ny - 1)) * self.dy

    @property
    def cell_area(self) -> float:
        return self.dx * self.dy

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates as two (nx, ny) arrays (index order [i, j] = [x, y])."""
        return np.meshgrid(self.x, self.y, indexing="ij")


@dataclass(frozen=True)
class Shape:
    """A contact shape in its own frame, turned by ``angle_deg`` (counter-clockwise) on the grid.

    ``aspect`` is b/a for ellipse and rectangle; ``sides`` the number of polygon sides or star
    lobes; ``amplitude`` the star modulation ε of r(φ) ∝ 1 + ε cos(kφ); ``seed``, ``hurst`` and
    ``rms`` define the rough patch; ``mask_path`` a .npy or .png file for ``mask``.
    """

    name: str
    aspect: float = 1.0
    sides: int = 5
    angle_deg: float = 0.0
    amplitude: float = 0.2
    seed: int = 0
    hurst: float = 0.8
    rms: float = 0.02
    mask_path: str | None = None

    def __post_init__(self) -> None:
        if self.name not in SHAPES:
            raise InputError("shape", f"one of {', '.join(SHAPES)}", self.name)
        if not (0.0 < self.aspect <= 1.0) or not math.isfinite(self.aspect):
            raise InputError("aspect", "b/a in (0, 1]", self.aspect)
        if not math.isfinite(self.angle_deg):
            raise InputError("shape_angle", field("shape_angle").message, self.angle_deg)
        if self.name == "polygon" and not (3 <= self.sides <= 1000):
            raise InputError("sides", "an integer in [3, 1000] for a polygon", self.sides)
        if self.name == "star":
            if not (2 <= self.sides <= 1000):
                raise InputError("sides", "an integer in [2, 1000] lobes for a star", self.sides)
            if not (0.0 <= self.amplitude < 1.0):
                raise InputError("amplitude", field("amplitude").message, self.amplitude)
        if self.name == "rough":
            if not (0.0 < self.hurst < 1.0):
                raise InputError("hurst", field("hurst").message, self.hurst)
            if not (0.0 < self.rms <= 1.0):
                raise InputError("rms", "roughness rms in (0, 1] (units of the contact radius)", self.rms)
        if self.name == "mask" and not self.mask_path:
            raise InputError("mask", "a path to a .npy or .png file", self.mask_path)

    # -- the shape in its own frame ------------------------------------------------------------
    def _inside(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Points (x, y) of the shape's own frame that lie inside (closed set)."""
        if self.name == "circle":
            return x * x + y * y <= 1.0
        if self.name == "ellipse":
            return x * x + (y / self.aspect) ** 2 <= 1.0
        if self.name == "rectangle":
            return (np.abs(x) <= 1.0) & (np.abs(y) <= self.aspect)
        r = np.hypot(x, y)
        phi = np.arctan2(y, x)
        return r <= self._radius(phi)

    def _radius(self, phi: np.ndarray) -> np.ndarray:
        """Boundary radius r(φ) of polygon and star (circumradius 1)."""
        k = self.sides
        if self.name == "polygon":
            # distance to the side facing φ; a vertex lies on the +x axis
            sector = 2.0 * math.pi / k
            local = np.mod(phi + 0.5 * sector, sector) - 0.5 * sector  # angle from nearest vertex
            return math.cos(math.pi / k) / np.cos(np.abs(local) - math.pi / k)
        if self.name == "star":
            return (1.0 + self.amplitude * np.cos(k * phi)) / (1.0 + self.amplitude)
        raise AssertionError(self.name)

    def half_extents(self) -> tuple[float, float]:
        """Half-widths (X, Y) of the axis-aligned bounding box of the turned shape."""
        c, s = math.cos(math.radians(self.angle_deg)), math.sin(math.radians(self.angle_deg))
        if self.name in ("circle", "rough"):
            return 1.0, 1.0
        if self.name == "ellipse":
            b = self.aspect
            return math.sqrt(c * c + (b * s) ** 2), math.sqrt(s * s + (b * c) ** 2)
        if self.name == "rectangle":
            b = self.aspect
            return abs(c) + b * abs(s), abs(s) + b * abs(c)
        if self.name == "polygon":  # the extremes lie on vertices (angles 2πk/sides, radius 1)
            phi = 2.0 * math.pi * np.arange(self.sides) / self.sides
        else:  # star: smooth boundary, dense sampling (relative error ~ (2π/20000)² k²)
            phi = np.linspace(0.0, 2.0 * math.pi, 20001)
        r = self._radius(phi)
        turned = phi + math.radians(self.angle_deg)
        return float(np.max(np.abs(r * np.cos(turned)))), float(np.max(np.abs(r * np.sin(turned))))

    def smallest_bend_radius(self) -> float:
        """The smallest radius of curvature of the outline (units of a; turning changes nothing):
        circle 1, ellipse (b/a)² (its tips), rectangle and polygon ∞ (straight sides; a corner is
        a singular point, not a bend), star the least over φ of the polar-curve radius

            ρ(φ) = (r² + r′²)^(3/2) / |r² + 2 r′² − r r″|,   r = (1 + ε cos kφ)/(1 + ε),

        at 1001 points of one half-period, which include the lobe's tip (φ = 0) and the bend
        between two lobes (φ = π/k). Rough patches and masks have no outline to bend: 0."""
        if self.name == "circle":
            return 1.0
        if self.name == "ellipse":
            return self.aspect**2
        if self.name in ("rectangle", "polygon"):
            return math.inf
        if self.name != "star":
            return 0.0
        k, eps = self.sides, self.amplitude
        phi = np.linspace(0.0, math.pi / k, 1001)
        r = self._radius(phi)
        dr = -eps * k * np.sin(k * phi) / (1.0 + eps)
        d2r = -eps * k * k * np.cos(k * phi) / (1.0 + eps)
        denominator = np.abs(r * r + 2.0 * dr * dr - r * d2r)
        with np.errstate(divide="ignore"):
            return float(np.min((r * r + dr * dr) ** 1.5 / denominator))

    def contains(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Lab-frame points inside the shape turned by ``angle_deg``."""
        t = math.radians(self.angle_deg)
        c, s = math.cos(t), math.sin(t)
        return self._inside(c * x + s * y, -s * x + c * y)


def grid_for(shape: Shape, n: int, n_across: int | None = None) -> Grid:
    """The grid that hugs the turned shape's bounding box: ``n`` cells along x, ``n_across`` along y.

    Without ``n_across`` the cells are as square as the box allows, but never fewer than
    min(n, 16) across, so a thin shape is still resolved across its width.
    """
    if n < 2:
        raise InputError("n", field("n").message, n)
    if n_across is not None and n_across < 1:
        raise InputError("n_across", field("n_across").message, n_across)
    X, Y = shape.half_extents()
    if n_across is None:
        n_across = max(min(n, 16), int(round(n * Y / X)))
    return Grid(nx=n, ny=n_across, dx=2.0 * X / n, dy=2.0 * Y / n_across)


def rasterize(shape: Shape, grid: Grid) -> np.ndarray:
    """Boolean (nx, ny) mask of the cells whose centres lie inside the shape."""
    x, y = grid.centres()
    return shape.contains(x, y)


def mask_pixels(path: str | Path) -> tuple[int, int]:
    """Cells (nx, ny) in [x, y] order of the mask file ``path``, from its header alone.

    A .png's IHDR chunk (signature and first chunk, 33 bytes) gives width × height; a .npy's
    header (``numpy.lib.format``: version 1.0 or 2.0) its shape and dtype. Nothing is decoded, so
    an image that would not fit in memory costs a few bytes to refuse: an ``InputError`` (field
    ``mask``, one line with the file's size in bytes) for a missing file, another suffix, a file
    that is not a PNG or .npy, a .npy of objects (pickles are never loaded), of a non-numeric
    dtype, not 2-D, empty or truncated, and a mask of more than ``MAX_GRID_CELLS`` cells (the
    grid limit of a scene). Cached per (resolved path, inode, size, mtime_ns): a sweep validates
    its mask scenes at the cost of one ``stat`` each.
    """
    return _mask_header(str(path), *_file_identity(path, "mask"))


def file_sha256(path: str | Path, field: str = "mask") -> str:
    """SHA-256 (hex) of the bytes of the input file ``path`` (``field`` names it in errors),
    read in blocks; cached per (resolved path, inode, size, mtime_ns), so that a sweep reads a
    file once for all its tasks and again only when the file changed."""
    return _sha256(*_file_identity(path, field))


def _file_identity(path: str | Path, field: str) -> tuple[str, int, int, int]:
    """(resolved path, inode, size, mtime_ns) of the regular file ``path``; ``InputError``
    (``field``) when there is none."""
    try:
        st = os.stat(path)
    except (OSError, ValueError):
        st = None
    if st is None or not stat.S_ISREG(st.st_mode):
        raise InputError(field, "an existing .npy or .png file", str(path))
    return str(Path(path).resolve()), st.st_ino, st.st_size, st.st_mtime_ns


@functools.lru_cache(maxsize=1024)
def _sha256(resolved: str, inode: int, size: int, mtime_ns: int) -> str:
    with open(resolved, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


@functools.lru_cache(maxsize=1024)
def _mask_header(shown: str, resolved: str, inode: int, size: int, mtime_ns: int) -> tuple[int, int]:
    """``mask_pixels`` of the file ``shown`` (as given: errors name it) at ``resolved``."""
    suffix = Path(shown).suffix.lower()
    if suffix not in MASK_SUFFIXES:
        raise InputError("mask", "a .npy or .png file", shown)
    where = f"{shown} ({size} bytes)"
    try:
        with open(resolved, "rb") as f:
            return _png_header(f, where) if suffix == ".png" else _npy_header(f, size, where)
    except OSError as exc:
        raise InputError("mask", f"a readable .npy or .png file ({exc.strerror or exc})", shown) from None


def _png_header(f, where: str) -> tuple[int, int]:
    """(width, height) from a PNG's signature and IHDR chunk (PNG spec §5.2, §11.2.2)."""
    head = f.read(33)
    if head[:8] != PNG_SIGNATURE:
        raise InputError("mask", "a PNG image (this file does not start with the PNG signature)", where)
    if len(head) < 33 or head[12:16] != b"IHDR" or struct.unpack(">I", head[8:12])[0] != 13:
        raise InputError("mask", "a PNG image whose first chunk is its 13-byte IHDR header", where)
    width, height = struct.unpack(">II", head[16:24])
    if width == 0 or height == 0:
        raise InputError("mask", "a PNG image of at least 1 x 1 pixels", where)
    _within_grid_limit(width, height, where)
    return width, height  # columns run along x, rows along y


def _npy_header(f, size: int, where: str) -> tuple[int, int]:
    """(nx, ny) from a .npy header: a complete, numeric, non-empty 2-D array."""
    from numpy.lib import format as npy

    try:
        version = npy.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = npy.read_array_header_1_0(f)
        elif version == (2, 0):
            shape, _, dtype = npy.read_array_header_2_0(f)
        else:
            raise ValueError(f"format version {version[0]}.{version[1]}")
    except (ValueError, SyntaxError, TypeError, KeyError, OverflowError, EOFError) as exc:
        reason = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise InputError(
            "mask", f"a .npy array file written by numpy.save (unreadable header: {reason})", where
        ) from None
    if dtype.hasobject:
        raise InputError("mask", "a numeric .npy array, not Python objects (pickled data is never loaded)", where)
    if dtype.kind not in MASK_DTYPE_KINDS or dtype.names is not None or dtype.subdtype is not None:
        raise InputError("mask", f"a numeric .npy array (bool, integer or float), not dtype {dtype}", where)
    if len(shape) != 2:
        raise InputError("mask", f"a 2-D array (this one has shape {shape})", where)
    nx, ny = (int(s) for s in shape)
    if nx == 0 or ny == 0:
        raise InputError("mask", f"a non-empty 2-D array (this one has shape {shape})", where)
    _within_grid_limit(nx, ny, where)
    needed = f.tell() + nx * ny * dtype.itemsize
    if size < needed:
        raise InputError(
            "mask", f"a complete .npy file ({needed} bytes for its {nx} x {ny} {dtype}; this one is truncated)", where
        )
    return nx, ny


def _within_grid_limit(nx: int, ny: int, where: str) -> None:
    if nx * ny > MAX_GRID_CELLS:
        raise InputError(
            "mask",
            f"a mask of at most 2**26 = {MAX_GRID_CELLS} cells, the grid limit of a scene "
            f"(this one has {nx} x {ny} = {nx * ny} cells)",
            where,
        )


def load_mask(path: str | Path) -> np.ndarray:
    """A contact mask from a .npy array (non-zero = contact) or a .png image.

    The file's header is checked first (``mask_pixels``: type, shape, the grid limit), so only
    a mask within the limit is decoded; a .npy is read through a memory map (only the boolean
    mask is held). In a PNG, contact cells are the opaque dark pixels (luminance < 0.5 and
    alpha > 0.5). Image rows run top to bottom, so the array is flipped to put +y up and
    transposed to [x, y] order.
    """
    nx, ny = mask_pixels(path)
    path = Path(path)
    where = f"{path} ({path.stat().st_size} bytes)"
    if path.suffix.lower() == ".npy":
        try:
            data = np.load(path, mmap_mode="r", allow_pickle=False)
        except (OSError, ValueError) as exc:  # changed since its header was read
            raise InputError("mask", f"a readable .npy array file ({exc})", where) from None
        mask = np.asarray(data) != 0
        del data
    else:
        import matplotlib.image as mpimg

        try:
            img = np.asarray(mpimg.imread(path, format="png"))  # float32 in [0, 1]
        except (OSError, ValueError, SyntaxError, EOFError, struct.error, zlib.error) as exc:
            reason = (str(exc).splitlines() or [type(exc).__name__])[0]
            raise InputError("mask", f"a PNG image that decodes ({type(exc).__name__}: {reason})", where) from None
        if img.shape[:2] != (ny, nx):
            raise InputError("mask", f"a PNG image of its header's {nx} x {ny} pixels", where)
        if img.ndim == 2:
            mask = img < 0.5
        else:
            lum = img[..., :3].mean(axis=-1)
            alpha = img[..., 3] if img.shape[-1] == 4 else np.ones_like(lum)
            mask = (lum < 0.5) & (alpha > 0.5)
        mask = mask[::-1, :].T
    if not mask.any():
        raise InputError("mask", "at least one contact cell", str(path))
    return mask


def mask_grid(mask: np.ndarray) -> Grid:
    """Square cells; the length unit a is half the longer side of the contact's bounding box
    (not of the image array: empty margins do not change the answer)."""
    if not mask.any():
        raise InputError("mask", "at least one contact cell", "an empty mask")
    nx, ny = mask.shape
    extent = max(np.ptp(np.flatnonzero(mask.any(axis=1))), np.ptp(np.flatnonzero(mask.any(axis=0)))) + 1
    h = 2.0 / extent
    return Grid(nx=nx, ny=ny, dx=h, dy=h)


def crop_to_support(mask: np.ndarray, grid: Grid) -> tuple[np.ndarray, Grid]:
    """The smallest sub-grid holding every contact cell (the solution does not depend on the rest).

    Non-periodic convolution couples contact cells only, so cropping changes no result and makes
    the FFTs smaller.
    """
    if not mask.any():
        raise InputError("mask", "at least one contact cell", "an empty mask")
    ii = np.flatnonzero(mask.any(axis=1))
    jj = np.flatnonzero(mask.any(axis=0))
    sub = mask[ii[0] : ii[-1] + 1, jj[0] : jj[-1] + 1]
    return sub, Grid(nx=sub.shape[0], ny=sub.shape[1], dx=grid.dx, dy=grid.dy)


def self_affine_surface(nx: int, ny: int, dx: float, dy: float, hurst: float, rms: float, seed: int) -> np.ndarray:
    """A seeded, self-affine random rough height field (units of length) with given rms.

    Power spectral density C(q) ∝ q^(−2(1+H)) between the grid's lowest non-zero wavenumber and
    the Nyquist wavenumber, random phases (Persson et al. 2005, J. Phys.: Condens. Matter 17 R1).
    """
    rng = np.random.default_rng(seed)
    qx = 2.0 * np.pi * np.fft.fftfreq(nx, dx)
    qy = 2.0 * np.pi * np.fft.rfftfreq(ny, dy)
    q = np.hypot(qx[:, None], qy[None, :])
    q0 = 2.0 * np.pi / max(nx * dx, ny * dy)
    amplitude = np.where(q >= q0, np.maximum(q, q0) ** (-(1.0 + hurst)), 0.0)
    phase = np.exp(2j * np.pi * rng.random(q.shape))
    h = np.fft.irfft2(amplitude * phase, s=(nx, ny))
    h -= h.mean()
    return h * (rms / np.sqrt(np.mean(h * h)))
