"""The distance accuracy a STEP file declares: its global uncertainty
(``UNCERTAINTY_MEASURE_WITH_UNIT``, ISO 10303-41), converted to millimetres, the unit gshade
reads STEP coordinates in.  Faces closer than it count as meeting (see
:mod:`gshade.analysis.edge_continuity`)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from ..errors import GshadeError
from ..io.files import read_bytes
from ..limits import MAX_DATA_FILE_BYTES

__all__ = ["step_uncertainty"]

#: Millimetres per STEP length unit: SI prefixes of the metre, and conversion-based units.
_SI_PREFIX_MM = {"$": 1000.0, ".KILO.": 1e6, ".DECI.": 100.0, ".CENTI.": 10.0}
_SI_PREFIX_MM |= {".MILLI.": 1.0, ".MICRO.": 1e-3, ".NANO.": 1e-6}
_NAMED_UNIT_MM = {"INCH": 25.4, "FOOT": 304.8, "MILLIMETRE": 1.0, "METRE": 1000.0}
_UNCERTAINTY = re.compile(
    rb"UNCERTAINTY_MEASURE_WITH_UNIT\s*\(\s*LENGTH_MEASURE\s*\(\s*([-+0-9.Ee]+)\s*\)\s*,"
    rb"\s*#(\d+)"
)


def step_uncertainty(path: Path) -> float:
    """The distance accuracy a STEP file declares (its global uncertainty, in mm; 0 when it
    declares none or in a unit not understood): faces closer than it count as meeting."""
    try:
        text = read_bytes(path, "a STEP file", limit=MAX_DATA_FILE_BYTES)
    except GshadeError:
        return 0.0
    worst = 0.0
    for value, unit in _UNCERTAINTY.findall(text):
        entity = re.search(rb"#" + unit + rb"\s*=\s*(.*?);", text, re.S)
        if entity is None:
            continue
        body = entity.group(1).decode("ascii", "replace")
        si = re.search(r"SI_UNIT\s*\(\s*([.$A-Z]+)\s*,\s*\.METRE\.", body)
        named = re.search(r"CONVERSION_BASED_UNIT\s*\(\s*'([A-Z]+)'", body.upper())
        scale = (
            _SI_PREFIX_MM.get(si.group(1))
            if si
            else _NAMED_UNIT_MM.get(named.group(1))
            if named
            else None
        )
        try:
            distance = float(value) * scale if scale is not None else 0.0
        except ValueError:
            continue
        if np.isfinite(distance):
            worst = max(worst, distance)
    return worst
