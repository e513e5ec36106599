"""Pixel size, frame interval and their units: from the options, from a TIFF's OME or
ImageJ metadata, or the defaults (1 pixel, 1 frame, units "1"); a value given both ways
must agree.

Units are written as CF / UDUNITS strings; the spellings microscopes use for micrometres
and seconds (``micron``, ``µm``, ``sec``) are normalised (:data:`UNIT_ALIASES`).
"""

from __future__ import annotations

import math
import os
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

from fcsweep.measure.readers import MeasureInputError, tiff_metadata

__all__ = ["Calibration", "tiff_calibration", "resolve", "UNIT_ALIASES", "RTOL"]

#: Relative difference above which an option and the file's metadata disagree (ImageJ stores
#: the resolution as a rational, so the round trip is inexact).
RTOL = 1e-3
#: Microscope spellings of units -> UDUNITS.
UNIT_ALIASES = {"micron": "um", "microns": "um", "µm": "um", "\u03bcm": "um", "\\u00B5m": "um", "um": "um",
                "nm": "nm", "mm": "mm", "cm": "cm", "m": "m", "sec": "s", "second": "s", "seconds": "s", "s": "s",
                "ms": "ms", "min": "min", "minute": "min", "minutes": "min", "h": "h", "hr": "h", "hour": "h"}


def _unit(u):
    if u is None:
        return None
    u = str(u).strip()
    return UNIT_ALIASES.get(u, UNIT_ALIASES.get(u.lower(), u))


@dataclass
class Calibration:
    """Pixel size ``(px, py)``, frame interval and units; None where unknown."""

    pixel_size: tuple | None = None
    length_unit: str | None = None
    frame_interval: float | None = None
    time_unit: str | None = None


def _ome(xml: str) -> Calibration:
    root = ET.fromstring(xml)
    px = next((el for el in root.iter() if el.tag.endswith("Pixels")), None)
    if px is None:
        return Calibration()
    a = px.attrib
    cal = Calibration()
    if "PhysicalSizeX" in a:
        cal.pixel_size = (float(a["PhysicalSizeX"]), float(a.get("PhysicalSizeY", a["PhysicalSizeX"])))
        cal.length_unit = _unit(a.get("PhysicalSizeXUnit", "µm"))
    if "TimeIncrement" in a:
        cal.frame_interval = float(a["TimeIncrement"])
        cal.time_unit = _unit(a.get("TimeIncrementUnit", "s"))
    return cal


def _imagej(meta: dict, resolution) -> Calibration:
    cal = Calibration()
    unit = meta.get("unit")
    if unit and unit not in ("pixel", "pixels") and resolution is not None:
        (nx, dx), (ny, dy) = resolution
        if nx and ny:
            cal.pixel_size = (dx / nx, dy / ny)
            cal.length_unit = _unit(unit)
    if meta.get("finterval"):
        cal.frame_interval = float(meta["finterval"])
        cal.time_unit = _unit(meta.get("tunit", "s"))
    return cal


def tiff_calibration(path) -> Calibration:
    """The calibration in a TIFF's OME-XML or ImageJ metadata (empty if it has none)."""
    meta = tiff_metadata(path)
    if meta["ome"]:
        try:
            return _ome(meta["ome"])
        except (ET.ParseError, ValueError) as exc:
            raise MeasureInputError(f"{path}: unreadable OME metadata ({exc})") from None
    if meta["imagej"] is not None:
        return _imagej(meta["imagej"], meta["resolution"])
    return Calibration()


def _file_calibration(labels) -> tuple[Calibration, str]:
    paths = [labels] if isinstance(labels, (str, os.PathLike)) else labels
    if isinstance(paths, (list, tuple)) and len(paths) == 1 and isinstance(paths[0], (str, os.PathLike)):
        p = Path(paths[0])
        if p.is_file() and p.name.lower().endswith((".tif", ".tiff")):
            return tiff_calibration(p), str(p)
    return Calibration(), ""


def _agree(name, given, found, where, same):
    if given is None:
        return found
    if found is not None and not same(given, found):
        raise MeasureInputError(f"{name} {given!r} conflicts with {found!r} in the metadata of {where}; "
                                f"leave the option out to use the file's")
    return given


def resolve(labels, pixel_size, frame_interval, length_unit, time_unit) -> Calibration:
    """The calibration to use: the options, checked against a single TIFF's metadata.

    Parameters
    ----------
    labels
        What :func:`fcsweep.measure.measure` was given (only a single TIFF path has metadata).
    pixel_size : (px, py) or None
    frame_interval : float or None
    length_unit, time_unit : str or None
        None: from the metadata, else 1 pixel, 1 frame interval, units "1".

    Raises
    ------
    MeasureInputError
        An option that the file's metadata contradicts.
    """
    found, where = _file_calibration(labels)
    def close(a, b):
        return all(math.isclose(x, y, rel_tol=RTOL) for x, y in zip(a, b))
    pix = _agree("pixel size", None if pixel_size is None else tuple(pixel_size), found.pixel_size, where, close)
    dt = _agree("frame interval", frame_interval, found.frame_interval, where,
                lambda a, b: math.isclose(a, b, rel_tol=RTOL))
    lu = _agree("length unit", _unit(length_unit), found.length_unit, where, str.__eq__)
    tu = _agree("time unit", _unit(time_unit), found.time_unit, where, str.__eq__)
    return Calibration(pix or (1.0, 1.0), lu or "1", 1.0 if dt is None else dt, tu or "1")
