"""The stated maxima of gshade's inputs, in one place.

Scene files arrive from pull requests and overnight batches; every size a file can ask for
is bounded here, so that a hostile or mistaken file is refused with one line before it
costs minutes of time or gigabytes of memory.  The docs list the same values
(docs/how_to/untrusted.rst).

The render's memory is estimated from its sizes (:func:`render_memory`) and refused above
:func:`memory_limit`: ``GSHADE_MEMORY_LIMIT`` (e.g. ``8G``) or 3/4 of this machine's memory,
and never more than the process's address-space limit (``ulimit -v``) leaves, whichever is
given (:func:`memory_budget` says which one set it).
"""

from __future__ import annotations

import os
import re

from .errors import GshadeError

__all__ = [
    "CAD_READ_MEMORY_BASE",
    "CAD_READ_MEMORY_PER_BYTE",
    "CAD_SECONDS",
    "MAX_COMB_SECTIONS",
    "MAX_CONTINUITY_SAMPLES",
    "MAX_DATA_FILE_BYTES",
    "MAX_DEGREE",
    "MAX_HOLES",
    "MAX_HOLE_MESH_FACES",
    "MAX_IMAGE_FILE_BYTES",
    "MAX_IMAGE_SIDE",
    "MAX_MAGNITUDE",
    "MAX_NESTING",
    "MAX_PATCHES",
    "MAX_SAMPLES",
    "MAX_SCENE_FILE_BYTES",
    "MAX_SEED",
    "MAX_SPP",
    "MAX_STRING",
    "MAX_SUBDIVISION_LEVELS",
    "MAX_TESSELLATION",
    "MAX_TEXTURE_RESOLUTION",
    "MIN_CHORD_TOLERANCE",
    "MIN_DIRECTION",
    "cad_read_memory",
    "gigabytes",
    "memory_budget",
    "memory_limit",
    "render_memory",
]

#: Largest magnitude of any number in a scene or surface data file.  Positions, lengths,
#: knots and weights up to 1e15 keep their curvatures (which square and cube them) within
#: double precision; numbers beyond it are mistakes or attacks.
MAX_MAGNITUDE = 1e15
#: Deepest nesting of arrays and tables in a scene file (control nets need 3 inside 2).
MAX_NESTING = 8
#: Longest string value in a scene file (characters).
MAX_STRING = 4096

#: File sizes: a scene file, a surface data file (Newell, OBJ), an image read by compare.
MAX_SCENE_FILE_BYTES = 16 * 2**20
MAX_DATA_FILE_BYTES = 256 * 2**20
MAX_IMAGE_FILE_BYTES = 4 * 2**30

#: Render settings.
MAX_IMAGE_SIDE = 16384
MAX_SPP = 4096
#: Most samples of one render (width x height x spp, after rounding spp up to a power of 4).
MAX_SAMPLES = 2**30
MAX_SEED = 2**32 - 1
MAX_TESSELLATION = 1024
MAX_TEXTURE_RESOLUTION = 512
MIN_CHORD_TOLERANCE = 1e-9
#: Most planes of ``render.comb_sections`` (each cut traced on every patch).
MAX_COMB_SECTIONS = 256
#: Shortest direction accepted (a shape function's light or axis, the camera's up):
#: normalising it stays exact.
MIN_DIRECTION = 1e-12

#: Samples per junction of ``gshade continuity`` (patch junctions and CAD B-rep edges): a
#: junction's measures need a few dozen; the edges' arrays grow with edges x samples.
MAX_CONTINUITY_SAMPLES = 4096

#: Surfaces: the highest polynomial degree in u or v, the most patches of a scene, and the
#: most refinement steps of a subdivision surface (each multiplies the patches by 4).
MAX_DEGREE = 20
MAX_PATCHES = 100_000
MAX_SUBDIVISION_LEVELS = 4
#: A ``hole`` surface: most extraordinary vertices (holes filled, ~0.01-0.1 s each) and most
#: faces (the mesh may be refined twice, x 16, before its holes are cut).
MAX_HOLES = 1000
MAX_HOLE_MESH_FACES = MAX_PATCHES // 16

#: Peak bytes per pixel, per mesh vertex and per texel of a render, and its fixed part
#: (Python, Mitsuba, LLVM), each an upper bound with a margin (the calibration renders are
#: in benchmarks/RESULTS.md, *Memory estimate*).  Samples per pixel cost time, not memory:
#: Mitsuba renders them in passes.
_BYTES_PER_PIXEL = 600
_BYTES_PER_VERTEX = 450
_BYTES_PER_TEXEL = 350
_BYTES_FIXED = 300 * 2**20
#: Address space that Python, Mitsuba and LLVM reserve without using it (with a margin).
_RESERVED_ADDRESS_SPACE = 512 * 2**20


def render_memory(pixels: int, vertices: int, texels: int) -> int:
    """An upper estimate of a render's peak memory in bytes, from its sizes."""
    return (
        _BYTES_FIXED
        + _BYTES_PER_PIXEL * pixels
        + _BYTES_PER_VERTEX * vertices
        + _BYTES_PER_TEXEL * texels
    )


def _physical_memory() -> int:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # not POSIX: assume a small machine
        return 8 * 2**30


def _cgroup_memory() -> int | None:
    """The memory limit of this process's control group (a container), if any."""
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit() and int(text) < 2**60:  # "max" or a huge number: no limit
            return int(text)
    return None


def _address_space() -> int | None:
    """What ``ulimit -v`` leaves for the render's data: the limit less the address space
    Python, Mitsuba and LLVM reserve without using it (``_RESERVED_ADDRESS_SPACE``)."""
    try:
        import resource

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
    except (ImportError, OSError, ValueError):
        return None
    if soft == resource.RLIM_INFINITY:
        return None
    return max(soft - _RESERVED_ADDRESS_SPACE, 0)


_ULIMIT = "what the address-space limit, ulimit -v, leaves"


def memory_budget() -> tuple[int, str]:
    """Bytes a render may use, and what set that limit (for messages).

    ``GSHADE_MEMORY_LIMIT`` (bytes, or with a suffix K, M, G, T) if set, else the smallest
    of three quarters of the machine's physical memory and the control group's limit; in
    both cases at most what the address-space limit (``ulimit -v``) leaves: an allocation
    beyond that fails inside the renderer (a crash, not a message), so the smaller wins.

    Returns
    -------
    limit : int
        Bytes.
    source : str
        What set it, for a message: ``"GSHADE_MEMORY_LIMIT"``, 3/4 of the machine's
        memory, the container's (cgroup) limit or the address-space limit (naming
        ``GSHADE_MEMORY_LIMIT`` where that was set higher).

    Raises
    ------
    GshadeError
        ``GSHADE_MEMORY_LIMIT: expected a size such as 8G or 512M, got ...``.
    """
    text = os.environ.get("GSHADE_MEMORY_LIMIT", "").strip()
    if text:
        match = re.fullmatch(r"(\d+(?:\.\d+)?)\s*([KMGT]?)i?B?", text, re.IGNORECASE)
        if match is None:
            raise GshadeError(
                f"GSHADE_MEMORY_LIMIT: expected a size such as 8G or 512M, got {text[:40]!r}"
            )
        scale = 1024 ** " KMGT".index(match.group(2).upper() or " ")
        given = int(float(match.group(1)) * scale)
        candidates = [(given, "GSHADE_MEMORY_LIMIT")]
        above = f"{_ULIMIT}; GSHADE_MEMORY_LIMIT={text[:40]} is above it and the smaller wins"
    else:
        machine = "3/4 of this machine's memory; GSHADE_MEMORY_LIMIT sets another"
        candidates = [(_physical_memory() * 3 // 4, machine)]
        cgroup = _cgroup_memory()
        if cgroup is not None:
            candidates.append((cgroup, "the container's (cgroup) memory limit"))
        above = _ULIMIT
    space = _address_space()
    if space is not None:
        candidates.append((space, above))
    return min(candidates, key=lambda c: c[0])


def memory_limit() -> int:
    """Bytes a render may use (:func:`memory_budget`'s limit)."""
    return memory_budget()[0]


#: CAD files (:mod:`gshade.cad.process`): the wall-clock seconds one kernel call (reading
#: a file, meshing it) may take by default (``GSHADE_CAD_TIMEOUT``), and the address space a
#: file's reading may take beyond the kernel's own: the base, plus so much per byte of the
#: file (measured: the kernel holds 20-150 bytes per byte of a STEP or IGES file it read).
CAD_SECONDS = 120
CAD_READ_MEMORY_BASE = 2**30
CAD_READ_MEMORY_PER_BYTE = 256


def cad_read_memory(file_bytes: int) -> int:
    """The address space (bytes) the CAD kernel may take to read a file of ``file_bytes``:
    :data:`CAD_READ_MEMORY_BASE` + :data:`CAD_READ_MEMORY_PER_BYTE` x its size, at most
    :func:`memory_limit`.

    Examples
    --------
    >>> cad_read_memory(0) == min(CAD_READ_MEMORY_BASE, memory_limit())
    True
    """
    return min(CAD_READ_MEMORY_BASE + CAD_READ_MEMORY_PER_BYTE * max(file_bytes, 0), memory_limit())


def gigabytes(n: int) -> str:
    """A byte count for messages: ``12.3 GB``."""
    return f"{n / 2**30:.1f} GB"
