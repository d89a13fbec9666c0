"""The wall law for C codes: a binary table and a portable C99 sampler.

:func:`write_binary` writes the part of the wall law that the sampler needs (capture
probabilities and reservoirs) as ``wall_law.swl``, a little-endian binary file whose
layout is documented in ``c/swl.h`` (and checked there on load: magic, version,
sizes, file length, CRC-32, values). :func:`read_binary` reads it back.
:func:`write_c` writes ``c/`` into an output folder: the sampler (``swl.h``,
``swl.c``), the Ansys Fluent ``DEFINE_DPM_BC`` wrapper (``fluent_udf.c``), the
table and a README. The C sampler follows docs/wall-law.md, "The sampling rule",
as :meth:`microimpact.wall_law.WallLaw.sample_uniform` does.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from .._core.files import atomic_write
from ..errors import DataFormatError
from .checks import RESERVOIRS, dataset_problem

__all__ = ["read_binary", "write_binary", "write_c"]

#: The C sources shipped with the package (package data).
C_SOURCES = Path(__file__).with_name("c")
#: Files copied from :data:`C_SOURCES` by :func:`write_c`.
C_FILES = ("swl.h", "swl.c", "fluent_udf.c")

MAGIC = b"SWLTABL\0"
#: The format version written by default (2: the speed axis' kind in the
#: header, v_c per diameter on a reduced axis); version 1 (absolute speed axis
#: only) is still written on request and read. Version 3 is version 2 with a
#: sections word (offset 52) and optional sections after the counts; it is
#: written (by default) only for a table with a ``stay_probability``.
VERSION = 2
VERSIONS = (1, 2, 3)
NAME_WIDTH = 64
HEADER = struct.Struct("<8s8IQII8x")  # 64 bytes; see c/swl.h
#: Bits of the sections word (format version 3, offset 52).
SECTION_STAY = 1
DIMS = ("surface", "diameter_um", "speed_m_s", "angle_deg")
REDUCED_DIMS = ("surface", "diameter_um", "reduced_speed", "angle_deg")
#: Header codes of the speed axis' kind (format version 2, offset 36).
SPEED_AXIS_CODES = {"absolute": 0, "reduced": 1}


def _dataset(law):
    """The Dataset of a WallLaw (or a Dataset itself), in (surface, d, v, theta,
    sample) order."""
    ds = getattr(law, "dataset", law)
    return ds.transpose(*_dims(ds), "sample", ...)


def _dims(ds):
    return REDUCED_DIMS if "reduced_speed" in ds.dims else DIMS


def _check(names, ds):
    """Raise ValueError where the table breaks the format (what swl_load checks;
    the value ranges of :mod:`.checks`, shared with the Python reader)."""
    for name in names:
        if len(name) >= NAME_WIDTH or b"\0" in name:
            raise ValueError(
                f"surface name {name.decode()!r} must be at most {NAME_WIDTH - 1} "
                "bytes of UTF-8 without NUL for the binary table"
            )
    problem = dataset_problem(ds, _dims(ds))
    if problem:
        raise ValueError(problem)


def encode(law, version: int | None = None) -> bytes:
    """The binary table (format version `version` of ``c/swl.h``: 2, or 1 for a
    table on an absolute speed axis, or 3 with the ``stay_probability``
    section; default 3 where the table has that column, else 2) of a WallLaw or
    its Dataset."""
    ds = _dataset(law)
    stay = "stay_probability" in ds
    if version is None:
        version = 3 if stay else VERSION
    if version not in VERSIONS:
        raise ValueError(f"`version` must be one of {VERSIONS}; got {version!r}")
    if stay and version < 3:
        raise ValueError(
            "a table with stay_probability needs format version 3 (drop the "
            "variable to write version 1 or 2)"
        )
    dims = _dims(ds)
    reduced = dims is REDUCED_DIMS
    if reduced and version < 2:
        raise ValueError(
            "a table on a reduced speed axis needs format version 2 (version 1 "
            "has no critical speeds)"
        )
    names = [str(s).encode("utf-8") for s in ds["surface"].values]
    axes = [np.asarray(ds[c].values, dtype=float) for c in dims[1:]]
    p = np.asarray(ds["capture_probability"].values, dtype=float)
    count = np.asarray(ds["reservoir_count"].values)
    res = [np.asarray(ds[f"reservoir_{n}"].values, dtype=float) for n in RESERVOIRS]
    k = int(ds.sizes["sample"])
    _check(names, ds)
    critical = []
    if reduced:
        v_c = np.asarray(ds["critical_speed_m_s"].values, dtype=float)
        if not np.all(np.isfinite(v_c) & (v_c > 0)):
            raise ValueError("critical_speed_m_s must be finite and > 0")
        critical = [np.ascontiguousarray(v_c, "<f8").tobytes()]
    payload = b"".join(
        [
            b"".join(n.ljust(NAME_WIDTH, b"\0") for n in names),
            *(np.ascontiguousarray(x, "<f8").tobytes() for x in axes),
            *critical,
            np.ascontiguousarray(p, "<f8").tobytes(),
            *(np.ascontiguousarray(a, "<f8").tobytes() for a in res),
            np.ascontiguousarray(count, "<i4").tobytes(),
            *(
                [np.ascontiguousarray(ds["stay_probability"].values, "<f8").tobytes()]
                if stay
                else []
            ),
        ]
    )
    s, d, v, a = p.shape
    header = HEADER.pack(
        MAGIC,
        version,
        s,
        d,
        v,
        a,
        k,
        NAME_WIDTH,
        SPEED_AXIS_CODES["reduced" if reduced else "absolute"],
        HEADER.size + len(payload),
        zlib.crc32(payload),
        SECTION_STAY if stay else 0,
    )
    return header + payload


def write_binary(law, path, *, version: int | None = None) -> Path:
    """Write the binary table of `law` (a WallLaw or its Dataset) to `path`
    (atomically), in format `version` (default 2, or 3 for a table with
    ``stay_probability``; 1, which readers older than the reduced speed axis
    know, only for a table on an absolute speed axis); returns the path."""
    data = encode(law, version)
    return atomic_write(path, lambda tmp: Path(tmp).write_bytes(data))


def read_binary(path):
    """The binary table at `path` as an xarray Dataset (``capture_probability``,
    ``reservoir_count``, the reservoirs of e_n, mu, the lateral angle and the
    speed ratio, and ``stay_probability`` where the file has that section).

    Raises :class:`~microimpact.errors.DataFormatError` where ``swl_load`` would
    return an error (values are not re-checked).
    """
    # deferred: xarray loads only where a dataset is made (import time)
    import xarray as xr

    def bad(message):
        return DataFormatError(f"not a valid wall-law table: {message}", source=path)

    data = Path(path).read_bytes()
    if len(data) < HEADER.size:
        raise bad("file too short for the header")
    head = HEADER.unpack_from(data)
    magic, version, s, d, v, a, k, width, kind, size, crc, sections = head
    if magic != MAGIC:
        raise bad("wrong magic")
    if version not in VERSIONS:
        raise bad(f"format version {version}, this reader knows {VERSIONS}")
    if kind not in ((0,) if version == 1 else (0, 1)):
        raise bad(f"speed axis code {kind} in the header")
    if sections & ~(SECTION_STAY if version >= 3 else 0):
        raise bad(f"sections word {sections} in the header")
    reduced = kind == 1
    if width != NAME_WIDTH or size != len(data):
        raise bad(f"header says {size} bytes, the file has {len(data)}")
    if zlib.crc32(data[HEADER.size :]) != crc:
        raise bad("CRC-32 mismatch")
    at = HEADER.size
    names = [
        data[at + i * width : at + (i + 1) * width].split(b"\0", 1)[0].decode()
        for i in range(s)
    ]
    at += s * width

    def take(dtype, shape):
        nonlocal at
        n = int(np.prod(shape))
        out = np.frombuffer(data, dtype, n, at).reshape(shape).astype(dtype[1:])
        at += n * np.dtype(dtype).itemsize
        return out

    axes = [take("<f8", (n,)) for n in (d, v, a)]
    v_c = take("<f8", (d,)) if reduced else None
    nodes = (s, d, v, a)
    p = take("<f8", nodes)
    res = [take("<f8", (*nodes, k)) for _ in RESERVOIRS]
    count = take("<i4", nodes)
    dims = REDUCED_DIMS if reduced else DIMS
    variables = {"capture_probability": (dims, p), "reservoir_count": (dims, count)}
    if sections & SECTION_STAY:
        variables["stay_probability"] = (dims, take("<f8", nodes))
    for name, arr in zip(RESERVOIRS, res, strict=True):
        variables[f"reservoir_{name}"] = ((*dims, "sample"), arr)
    coords = dict(zip(dims, [np.array(names, dtype=object), *axes], strict=True))
    coords["sample"] = np.arange(k, dtype=np.int32)
    if reduced:
        variables["critical_speed_m_s"] = (("diameter_um",), v_c)
        coords["speed_m_s"] = (("diameter_um", "reduced_speed"), v_c[:, None] * axes[1])
    ds = xr.Dataset(variables, coords=coords)
    ds.attrs.update(
        speed_axis="reduced" if reduced else "absolute", format_version=version
    )
    return ds


def _readme(law) -> str:
    ds = _dataset(law)
    s = ", ".join(repr(str(n)) for n in ds["surface"].values)
    dims = _dims(ds)
    rng = {
        c: f"{float(ds[c].values[0]):g} … {float(ds[c].values[-1]):g} "
        f"({ds.sizes[c]} nodes)"
        for c in dims[1:]
    }
    if "reduced_speed" in rng:
        speeds = (
            f"v / v_c(d) {rng['reduced_speed']} (a reduced speed axis: v_c at each "
            "diameter node is in the table)"
        )
    else:
        speeds = f"{rng['speed_m_s']} m/s"
    stay = "no stay probability (built without a [resuspension] table)"
    if "stay_probability" in ds:
        stay = (
            "the probability that a captured particle stays, per node "
            f"({float(ds['stay_probability'].min()):.4g} … "
            f"{float(ds['stay_probability'].max()):.4g}): see Resuspension below"
        )
    return _README.format(
        stay=stay,
        surfaces=s,
        diameters=rng["diameter_um"],
        speeds=speeds,
        angles=rng["angle_deg"],
        k=ds.sizes["sample"],
    )


def write_c(law, out_dir) -> list[Path]:
    """Write ``out_dir/c/``: ``swl.h``, ``swl.c``, ``fluent_udf.c``, the binary
    table ``wall_law.swl`` and ``README.md``. Returns the paths written."""
    c_dir = Path(out_dir) / "c"
    written = []
    for name in C_FILES:
        text = (C_SOURCES / name).read_bytes()
        written.append(atomic_write(c_dir / name, lambda tmp, b=text: _put(tmp, b)))
    written.append(write_binary(law, c_dir / "wall_law.swl"))
    readme = _readme(law).encode("utf-8")
    written.append(atomic_write(c_dir / "README.md", lambda tmp: _put(tmp, readme)))
    return written


def _put(path, data: bytes) -> None:
    Path(path).write_bytes(data)


_README = """\
# The wall law in C

`swl.h` and `swl.c` read and sample this wall law in portable C99 (libc and libm
only); `fluent_udf.c` is an Ansys Fluent `DEFINE_DPM_BC` wrapper around them.
`wall_law.swl` is the table:

* surfaces {surfaces};
* diameter {diameters} µm;
* speed {speeds};
* angle {angles} degrees from the wall plane;
* K = {k} rebound samples per node;
* {stay}.

The frame and the sampling rule are in microimpact's docs/wall-law.md; the binary
format is documented at the top of `swl.h`.

## Compile

    cc -std=c99 -O2 -c swl.c            # then link swl.o and -lm into your code

Compiled with `-ffp-contract=off` (no fused multiply-add), the sampler gives the
results of microimpact's Python sampler `WallLaw.sample_uniform` for the same
uniform numbers, bit for bit except where the C library's `log` or `tan` differs
from NumPy's in the last place: then the velocity differs by about 1e-16 of the
speed, or, very rarely, a uniform number within 1e-16 of a cell fraction picks the
other corner.

## API

    swl_law *law;
    int rc = swl_load("wall_law.swl", &law);        /* 0, or a negative SWL_E_* */
    int s = swl_surface_index(law, "my surface");   /* or 0 for the first */
    double u[5] = {{...}};                            /* five uniforms in [0, 1) */
    double vel[3]; int flags;
    rc = swl_sample(law, s, d_um, speed, theta_deg, u, vel, &flags);
    /* rc: SWL_REBOUND (vel = rebound, wall frame), SWL_CAPTURED (vel = 0),
       SWL_NO_DATA (the node had no impact; vel = NaN) or a negative error;
       flags: SWL_FLAG_CLAMPED_* (query outside the table), SWL_FLAG_REIMPACT */
    rc = swl_rebound_velocity(law, s, d_um, v_in, normal, u, v_out, &flags);
    /* the same in your own frame: normal is the wall's outward normal (into the
       fluid), v_in must move into the wall; v_out is the rebound velocity */
    swl_free(law);

`swl_sample_n` samples many queries at once and `swl_strerror(rc)` explains a
code. The wall frame: z the wall's outward normal, x the incoming particle's
tangential direction of travel, y = z × x; theta is measured from the wall plane
(90 = normal incidence) and must lie in (0, 90].

## The uniform numbers

Every sample takes five uniform numbers in [0, 1), in this order:

| u | use |
|---|---|
| u[0] | picks the diameter node of the cell corner (upper node where u[0] < t_d) |
| u[1] | picks the speed node (upper where u[1] < t_v) |
| u[2] | picks the angle node (upper where u[2] < t_theta) |
| u[3] | captured where u[3] < the corner's capture probability |
| u[4] | reservoir sample floor(u[4] * count) of the corner |

All five are used on every call, whatever the outcome. t is the query's fraction of
its cell in log d, log v and theta (on a reduced speed axis log(v / v_c(d)), v_c
interpolated in log-log between the diameter nodes); a query outside an axis is
clamped to the end node, and flagged if it lies outside by more than 1e-9
relative.

## Resuspension

A table built from a scenario with a `[resuspension]` table (format version 3)
carries, per node, the probability q that a captured particle stays on the wall
after the stated exposure at the stated friction velocity (microimpact's
docs/resuspension.md; quasi-steady flow, independent particles). No extra
uniform is drawn: a captured particle (u[3] < p) stays where u[3] < p * q, and
otherwise `swl_sample` sets `SWL_FLAG_RESUSPENDED` in flags (it still returns
`SWL_CAPTURED`). `swl_stay_probability(law, s, d_um, speed, theta_deg, &q)` gives
the probability that a particle captured at that query stays (the trilinear
corners weighted by their capture probabilities). `swl_has_stay(law)` says
whether the table carries it.

## Fluent

Compile `fluent_udf.c` with `swl.c` as a compiled UDF (Source Files: both `.c`;
Header Files: `swl.h`), copy `wall_law.swl` into the case folder (or set
`MICROIMPACT_SWL_TABLE` to its path, and `MICROIMPACT_SWL_SURFACE` to a surface
name), and hook `microimpact_wall` as the DPM boundary condition (Discrete Phase
BC Type: user-defined) of the walls. A captured particle ends with PATH_ABORT,
which Fluent's DPM summary counts as *aborted*, not *trapped*; the on-demand
function `microimpact_wall_report` prints the captures of each process. See the
comments at the top of `fluent_udf.c`.
"""
