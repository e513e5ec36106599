"""Label images in: TIFF stacks, PNG sequences or directories, Cellpose ``_seg.npy``,
integer arrays and iterators of frames, each checked as it is read.

A label image is a 2-D integer array, 0 = background and 1 ... n = cells.  Frames are
yielded one at a time, so a long stack is never held in memory whole.  Broken input
raises :class:`MeasureInputError` with one line that says what is wrong and where: a file
that its reader cannot read (truncated, corrupt, empty, another format under the suffix),
a structured or object array, a colour image (a TIFF with a sample or channel axis, a
Y x X x 3 or 4 array, an RGB PNG), a binary mask (one label value in several separate
pieces: label it first, or ``label_binary=True``), a frame too large for the memory
(:data:`BYTES_PER_PIXEL`).  Label values far above the number of cells are renumbered
(:func:`relabel`), so memory and time follow the cells, not the largest label.

Cellpose's ``_seg.npy`` is a pickled dict; it is read with a restricted unpickler that
builds only numpy arrays, dtypes and scalars and plain containers, so a crafted file
cannot run code.  Only its ``masks`` entry is used.
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import pickle
from pathlib import Path

import numpy as np

__all__ = ["MeasureInputError", "iter_frames", "read_seg_npy", "check_frame", "available_memory", "tiff_metadata",
           "relabel", "readable", "BYTES_PER_PIXEL", "IMAGE_SUFFIXES", "RELABEL_ABOVE"]

#: Bytes of work memory per pixel the measurement of one frame needs: the peak resident memory
#: above the libraries, measured 37.5 per pixel on 4096^2 frames (the int64 frame and the previous
#: one, the tracking's pixel-pair keys and their sort, the contact pairs), rounded up.
BYTES_PER_PIXEL = 40
#: Frames whose largest label exceeds this are renumbered 1..n before they are measured.
RELABEL_ABOVE = 1 << 16
#: File suffixes read from a directory, in the order they are tried.
IMAGE_SUFFIXES = (".tif", ".tiff", ".png", ".npy")


class MeasureInputError(ValueError):
    """Input that is not a usable label image (the CLI exits 2 with its message)."""


def _need(module: str):
    try:
        return __import__(module)
    except ImportError as exc:
        raise ImportError(f"fcsweep measure needs {module} to read this input: "
                          "pip install 'fcsweep[measure]'") from exc


def available_memory() -> int:
    """Bytes of memory available now (``MemAvailable`` of /proc/meminfo, else physical pages)."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return 1 << 62


def _check_size(shape, where: str) -> None:
    need = int(np.prod(shape, dtype=np.float64)) * BYTES_PER_PIXEL
    have = available_memory()
    if need > have:
        raise MeasureInputError(f"{where}: a frame of {shape[0]} x {shape[1]} pixels needs about "
                                f"{need / 2**30:.1f} GiB to measure, only {have / 2**30:.1f} GiB is available")


def relabel(frame: np.ndarray):
    """``(frame, originals)``: labels renumbered 1..n in order of value and the original label of
    each new one (index new - 1); ``originals`` is None when the largest label is at most
    :data:`RELABEL_ABOVE` (the frame is returned as it is)."""
    if frame.size == 0 or int(frame.max()) <= RELABEL_ABOVE:
        return frame, None
    values, inverse = np.unique(frame, return_inverse=True)
    inverse = inverse.reshape(frame.shape).astype(np.int64, copy=False)
    if values[0] == 0:
        return inverse, values[1:].astype(np.int64)
    return inverse + 1, values.astype(np.int64)


def _is_binary(arr: np.ndarray) -> bool:
    """One nonzero value in several 8-connected pieces: a binary mask, not labels."""
    from scipy import ndimage

    top = arr.max()
    if np.any((arr != 0) & (arr != top)):
        return False
    return ndimage.label(arr != 0, structure=np.ones((3, 3), dtype=bool))[1] > 1


def check_frame(frame, where: str, shape=None, label_binary: bool = False) -> np.ndarray:
    """One frame as a 2-D int64 label array, or :class:`MeasureInputError`.

    Parameters
    ----------
    frame : array_like
    where : str
        Names the frame in messages (file and index).
    shape : tuple, optional
        The shape of the first frame; a different shape is an error.
    label_binary : bool
        Label a binary mask's connected pieces (8-connected) as cells instead of refusing it.
    """
    arr = np.asarray(frame)
    if arr.dtype.fields is not None or arr.dtype.hasobject:
        raise MeasureInputError(f"{where}: a structured or object array (dtype {arr.dtype}) is not a label image")
    if arr.ndim != 2:
        raise MeasureInputError(f"{where}: a label frame must be 2-D, got shape {arr.shape}")
    if shape is not None and arr.shape != tuple(shape):
        raise MeasureInputError(f"{where}: frame of shape {arr.shape} differs from the first frame's {tuple(shape)}")
    if arr.dtype == bool:
        raise MeasureInputError(f"{where}: a binary mask is not a label image (0 = background, 1..n = cells); "
                                "label its connected cells first")
    if arr.dtype.kind == "f":
        raise MeasureInputError(f"{where}: labels must be integers, got a {arr.dtype} image; an intensity image "
                                "must be segmented first (Cellpose, StarDist)")
    if arr.dtype.kind not in "iu":
        raise MeasureInputError(f"{where}: labels must be integers, got dtype {arr.dtype}")
    if arr.size and arr.min() < 0:
        raise MeasureInputError(f"{where}: negative label {int(arr.min())} (0 = background, 1..n = cells)")
    if not arr.any():
        raise MeasureInputError(f"{where}: empty mask, no cell in the frame")
    if arr.dtype == np.uint64 and arr.max() > np.iinfo(np.int64).max:
        arr = relabel(arr)[0]
    if _is_binary(arr):
        from scipy import ndimage

        if not label_binary:
            raise MeasureInputError(f"{where}: a binary mask (values 0 and {int(arr.max())}), not a label image: "
                                    "label its connected cells first (Cellpose, StarDist, scipy.ndimage.label), or "
                                    "pass label_binary=True (fcsweep measure --label-binary) to label them here")
        arr = ndimage.label(arr != 0, structure=np.ones((3, 3), dtype=bool))[0]
    return arr.astype(np.int64, copy=False)


class _SegUnpickler(pickle.Unpickler):
    """Builds numpy arrays, dtypes and scalars and plain containers, nothing else."""

    ALLOWED = {
        ("numpy.core.multiarray", "_reconstruct"), ("numpy._core.multiarray", "_reconstruct"),
        ("numpy.core.multiarray", "scalar"), ("numpy._core.multiarray", "scalar"),
        ("numpy.core.numeric", "_frombuffer"), ("numpy._core.numeric", "_frombuffer"),
        ("numpy", "ndarray"), ("numpy", "dtype"),
    }

    def find_class(self, module, name):
        if (module, name) in self.ALLOWED:
            return super().find_class(module, name)
        raise pickle.UnpicklingError(f"refused to load {module}.{name}")


def read_seg_npy(path) -> np.ndarray:
    """The ``masks`` array of a Cellpose ``_seg.npy`` file, read without unpickling code
    (a ``.npy`` file of a plain array is returned memory-mapped).

    Raises
    ------
    MeasureInputError
        Not a ``.npy`` file, a pickle that needs anything but numpy arrays and plain
        containers, or no ``masks`` entry.
    """
    path = Path(path)
    with open(path, "rb") as fh:
        try:
            version = np.lib.format.read_magic(fh)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
            else:
                shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
        except ValueError as exc:
            raise MeasureInputError(f"{path}: not a .npy file ({exc})") from None
        if dtype.fields is not None or (dtype.hasobject and dtype.kind != "O"):
            raise MeasureInputError(f"{path}: holds a structured array (dtype {dtype}), not label masks")
        if dtype.kind != "O":  # a plain array: memory-mapped, read frame by frame
            return np.load(path, allow_pickle=False, mmap_mode="r")
        try:
            obj = _SegUnpickler(io.BufferedReader(fh)).load()
        except (pickle.UnpicklingError, EOFError, AttributeError, TypeError, ValueError) as exc:
            raise MeasureInputError(f"{path}: not a Cellpose _seg.npy file that can be read safely ({exc})") from None
    if isinstance(obj, np.ndarray) and obj.dtype == object and obj.size == 1:
        obj = obj.reshape(()).item()
    if not isinstance(obj, dict) or "masks" not in obj:
        raise MeasureInputError(f"{path}: no 'masks' entry (is it a Cellpose _seg.npy file?)")
    return np.asarray(obj["masks"])


def _check_stack(shape, where: str, axes: str | None = None) -> None:
    """Refuse colour and multi-channel layouts: a TIFF axis C or S, or a Y x X x 3 / 4 array."""
    if axes is not None and ("C" in axes or "S" in axes):
        kind = "colour (RGB) samples" if "S" in axes else "a channel axis"
        raise MeasureInputError(f"{where}: the image has {kind} (axes {axes}, shape {tuple(shape)}), not a label "
                                "image: save the label channel alone (one integer per pixel)")
    if len(shape) == 3 and shape[-1] in (3, 4) and shape[1] > 4 * shape[-1]:
        raise MeasureInputError(f"{where}: shape {tuple(shape)} looks like a Y x X x {shape[-1]} colour image, not "
                                "a T x Y x X label stack: save the label channel alone")


def _frames_of_array(arr: np.ndarray, where: str):
    _check_stack(arr.shape, where)
    if arr.ndim == 2:
        yield where, arr
    elif arr.ndim == 3:
        for k in range(arr.shape[0]):
            yield f"{where} frame {k}", arr[k]
    else:
        raise MeasureInputError(f"{where}: expected a 2-D frame or a T x Y x X stack, got shape {arr.shape}")


def _frames_of_raw(path: Path, offset: int, dtype: np.dtype, shape):
    """Frames of a contiguous C-ordered T x Y x X array at ``offset`` in a file, each read by
    itself.  Not memory-mapped: the pages of a mapped stack stay resident in the process
    (8 MB per 2048 x 2048 uint16 frame) until the whole map is closed."""
    count = int(shape[1]) * int(shape[2])
    with open(path, "rb") as fh:
        for k in range(shape[0]):
            fh.seek(offset + k * count * dtype.itemsize)
            frame = np.fromfile(fh, dtype=dtype, count=count)
            if frame.size != count:
                raise MeasureInputError(f"{path} frame {k}: the file ends inside the frame")
            yield f"{path} frame {k}", frame.reshape(shape[1], shape[2])


def _npy_stack(path: Path):
    """(offset, dtype, shape) of a plain C-ordered 3-D ``.npy`` array, else None."""
    with open(path, "rb") as fh:
        try:
            version = np.lib.format.read_magic(fh)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
            shape, fortran, dtype = read(fh)
        except ValueError:
            return None
        if dtype.kind == "O" or fortran or len(shape) != 3:
            return None
        return fh.tell(), dtype, shape


def _frames_of_tiff(path: Path):
    """Frames of a TIFF's first series, one at a time: read straight from the file when the series is stored
    contiguous and uncompressed, else page by page."""
    tifffile = _need("tifffile")
    with tifffile.TiffFile(path) as tif:
        series = tif.series[0]
        shape = tuple(series.shape)
        _check_stack(shape, str(path), str(series.axes))
        if len(shape) not in (2, 3):
            raise MeasureInputError(f"{path}: expected a 2-D frame or a T x Y x X stack, got shape {shape}")
        _check_size(shape[-2:], str(path))
        if len(shape) == 2:
            yield str(path), series.asarray()
            return
        if series.dataoffset is not None:
            dtype = np.dtype(series.dtype).newbyteorder(tif.byteorder)
            yield from _frames_of_raw(path, series.dataoffset, dtype, shape)
        elif len(series.pages) == shape[0]:
            for k, page in enumerate(series.pages):
                yield f"{path} frame {k}", page.asarray()
        else:
            _check_size((shape[0] * shape[1], shape[2]), str(path))
            stack = series.asarray()
            for k in range(shape[0]):
                yield f"{path} frame {k}", stack[k]


def tiff_metadata(path) -> dict:
    """The calibration metadata of a TIFF, unparsed: ``ome`` (the OME-XML string or None),
    ``imagej`` (the ImageJ metadata dict or None) and ``resolution`` (the first page's
    ``XResolution``, ``YResolution`` rationals, or None)."""
    tifffile = _need("tifffile")
    with readable(path), tifffile.TiffFile(path) as tif:
        tags = tif.pages[0].tags
        res = None
        if "XResolution" in tags:
            res = (tags["XResolution"].value, tags.get("YResolution", tags["XResolution"]).value)
        return {"ome": tif.ome_metadata if tif.is_ome else None,
                "imagej": (tif.imagej_metadata or {}) if tif.is_imagej else None, "resolution": res}


def _frames_of_png(path: Path):
    from PIL import Image

    with Image.open(path) as im:
        _check_size((im.height, im.width), str(path))
        if im.mode not in ("L", "I", "I;16", "I;16B", "I;16L", "P"):
            raise MeasureInputError(f"{path}: a {im.mode} PNG is not a label image (need 8- or 16-bit grey)")
        arr = np.asarray(im)
    yield str(path), arr


_KIND = {".tif": "TIFF", ".tiff": "TIFF", ".png": "PNG", ".npy": ".npy"}


@contextlib.contextmanager
def readable(path):
    """Turn whatever a reader raises on ``path`` into one :class:`MeasureInputError` line naming
    the file (an empty file is named as such); the readers' own log messages are silenced."""
    path = Path(path)
    kind = _KIND.get(path.suffix.lower(), "label image")
    quiet = [logging.getLogger(name) for name in ("tifffile", "PIL")]
    levels = [lg.level for lg in quiet]
    for lg in quiet:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        if path.is_file() and path.stat().st_size == 0:
            raise MeasureInputError(f"{path}: empty file")
        yield
    except (MeasureInputError, ImportError):
        raise
    except MemoryError:
        raise MeasureInputError(f"{path}: out of memory while reading it") from None
    except Exception as exc:  # noqa: BLE001 - every reader's own error becomes one line
        text = str(exc).strip().splitlines()
        raise MeasureInputError(f"{path}: not a readable {kind} file ({type(exc).__name__}"
                                f"{': ' + text[0] if text else ''})") from None
    finally:
        for lg, level in zip(quiet, levels):
            lg.setLevel(level)


def _frames_of_file(path: Path):
    """The frames of one file; whatever its reader raises becomes one line naming the file."""
    with readable(path):
        yield from _read_file(path)


def _read_file(path: Path):
    name = path.name.lower()
    if name.endswith((".tif", ".tiff")):
        yield from _frames_of_tiff(path)
    elif name.endswith(".png"):
        yield from _frames_of_png(path)
    elif name.endswith(".npy"):
        raw = _npy_stack(path)
        if raw is not None:
            _check_stack(raw[2], str(path))
            _check_size(raw[2][-2:], str(path))
            yield from _frames_of_raw(path, *raw)
            return
        arr = read_seg_npy(path)
        if arr.ndim >= 2:
            _check_size(arr.shape[-2:], str(path))
        yield from _frames_of_array(arr, str(path))
    else:
        raise MeasureInputError(f"{path}: unknown label image format (TIFF, PNG or Cellpose _seg.npy)")


def _expand(paths) -> list[Path]:
    out = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            files = sorted(f for f in p.iterdir() if f.is_file() and f.name.lower().endswith(IMAGE_SUFFIXES))
            if not files:
                raise MeasureInputError(f"{p}: no TIFF, PNG or _seg.npy file in the directory")
            out.extend(files)
        elif p.is_file():
            out.append(p)
        else:
            raise MeasureInputError(f"{p}: no such file or directory")
    return out


def iter_frames(labels, label_binary: bool = False):
    """Yield the checked label frames of ``labels`` one at a time.

    Parameters
    ----------
    labels : ndarray, path, list of paths, or iterable of 2-D arrays
        A 2-D frame or T x Y x X stack; a TIFF file, a PNG file, a Cellpose ``_seg.npy``
        or a directory of them (sorted by name: one frame per PNG / ``_seg.npy``); or an
        iterator of frames.

    Yields
    ------
    where : str
        The frame's file and index, for messages.
    frame : ndarray of int64, shape (Y, X)
    """
    if isinstance(labels, (str, os.PathLike)):
        labels = [labels]
    if isinstance(labels, np.ndarray):
        source = _frames_of_array(labels, "labels")
    elif isinstance(labels, (list, tuple)) and labels and all(isinstance(p, (str, os.PathLike)) for p in labels):
        files = _expand(labels)
        source = (item for f in files for item in _frames_of_file(f))
    else:
        source = ((f"frame {k}", fr) for k, fr in enumerate(labels))
    shape = None
    count = 0
    for where, frame in source:
        frame = check_frame(frame, where, shape, label_binary)
        shape = frame.shape
        count += 1
        yield where, frame
    if count == 0:
        raise MeasureInputError("no frame in the input")
