"""Per-cell time series read in pieces: a frame at a time, or every frame of a block of cells.

The unwrapped centroids of every frame after the transient, ``(T, N, 2)`` in float64,
take 0.8 GB at N = 10^5 and 501 frames, and the MSD would copy them several times.  A
:class:`FrameSource` gives the same values in pieces, so that the MSD and D_eff (:mod:`fcsweep.analysis.stream`), the
cage measure (:func:`fcsweep.analysis.cage.cage_breaking`, which reads single frames) and
the structure and shape steps hold a bounded number of frames, or all frames of a block of
cells sized by :data:`BLOCK_BYTES` (computed on in pieces of :data:`WORK_BYTES`).

:class:`ArrayFrames` serves an array held in memory (tests, callers with arrays);
:class:`fcsweep.results.analyze.TrajectoryFrames` reads a trajectory file (the analysis
layer opens no file).
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

#: Bytes of one block of cells over all its frames (float64) read at once by the streamed
#: MSD and D_eff (:meth:`FrameSource.cell_blocks`): each read of a block decompresses the
#: whole series of the file, so fewer, larger blocks cost less time.
BLOCK_BYTES = 256 << 20
#: Bytes of the pieces those steps compute on at once (:func:`work_blocks`; freud's window
#: MSD needs about 9 times its input), and of a block of frames (:meth:`FrameSource.frame_blocks`).
WORK_BYTES = 16 << 20
#: Bytes of single frames a source keeps for repeated reads (the cage measure reads each
#: time origin at many lags).
CACHE_BYTES = 64 << 20


class FrameSource:
    """A ``(T, N, ...)`` float64 per-cell series, read in pieces.

    Subclasses implement :meth:`_read` (frames ``rows``, cells ``lo:hi``).  Indexing with
    an integer gives one frame ``(N, ...)``; :meth:`cells` every frame of a block of
    cells; :meth:`window` a view of consecutive frames.  Values are those of the series
    held whole, bit for bit.
    """

    def __init__(self, shape, rows=None):
        self._div = 1.0
        self.shape = tuple(int(s) for s in shape)
        self._rows = np.arange(self.shape[0]) if rows is None else np.asarray(rows, dtype=np.int64)
        self.shape = (int(self._rows.size), *self.shape[1:])
        width = int(np.prod(self.shape[1:])) * 8
        self._cache: OrderedDict = OrderedDict()
        self._cache_frames = max(2, CACHE_BYTES // max(width, 1))

    ndim = property(lambda self: len(self.shape))

    def __len__(self) -> int:
        return self.shape[0]

    def _read(self, rows: np.ndarray, lo: int, hi: int) -> np.ndarray:
        raise NotImplementedError

    def _get(self, rows, lo, hi):
        out = self._read(rows, lo, hi)
        return out if self._div == 1.0 else out / self._div

    def scaled(self, length: float) -> "FrameSource":
        """The same series in units of ``length`` (each read divided by it)."""
        view = self.window(0, self.shape[0])
        view._div = self._div * float(length)
        view._cache = OrderedDict()
        return view

    def __getitem__(self, k) -> np.ndarray:
        k = int(k)
        if k < 0:
            k += self.shape[0]
        if not 0 <= k < self.shape[0]:
            raise IndexError(f"frame {k} out of range for {self.shape[0]} frames")
        row = int(self._rows[k])
        if row in self._cache:
            self._cache.move_to_end(row)
            return self._cache[row]
        out = np.array(self._get(self._rows[k:k + 1], 0, self.shape[1])[0])
        out.setflags(write=False)  # shared by every later read of this frame
        self._cache[row] = out
        if len(self._cache) > self._cache_frames:
            self._cache.popitem(last=False)
        return out

    def frames(self, start: int, stop: int) -> np.ndarray:
        """Frames ``start:stop``, every cell."""
        return self._get(self._rows[start:stop], 0, self.shape[1])

    def cells(self, lo: int, hi: int) -> np.ndarray:
        """Every frame of cells ``lo:hi``, shape ``(T, hi - lo, ...)``."""
        return self._get(self._rows, int(lo), int(hi))

    def window(self, start: int, stop: int) -> "FrameSource":
        """The frames ``start:stop`` as a source of their own (nothing is read)."""
        view = object.__new__(type(self))
        view.__dict__.update(self.__dict__)
        view._rows = self._rows[start:stop]
        view.shape = (int(view._rows.size), *self.shape[1:])
        view._cache = self._cache  # keyed by the row of the underlying series
        return view

    def select(self, indices) -> "FrameSource":
        """The frames ``indices`` (of this source) as a source of their own."""
        view = self.window(0, self.shape[0])
        view._rows = self._rows[np.asarray(indices, dtype=np.int64)]
        view.shape = (int(view._rows.size), *self.shape[1:])
        return view

    def cell_blocks(self, block_bytes: int | None = None):
        """``(lo, hi)`` blocks of cells whose frames take about ``block_bytes`` each."""
        per_cell = max(1, self.shape[0] * int(np.prod(self.shape[2:])) * 8)
        size = max(1, int(BLOCK_BYTES if block_bytes is None else block_bytes) // per_cell)
        N = self.shape[1]
        return [(lo, min(lo + size, N)) for lo in range(0, N, size)]

    def frame_blocks(self, block_bytes: int | None = None):
        """``(start, stop)`` blocks of frames of about ``block_bytes`` (default :data:`WORK_BYTES`) each."""
        per_frame = max(1, int(np.prod(self.shape[1:])) * 8)
        size = max(1, int(WORK_BYTES if block_bytes is None else block_bytes) // per_frame)
        T = self.shape[0]
        return [(s, min(s + size, T)) for s in range(0, T, size)]


def work_blocks(block: np.ndarray, work_bytes: int | None = None):
    """Views ``block[:, a:b]`` of a block of cells ``(T, n, ...)`` of about ``work_bytes``
    (default :data:`WORK_BYTES`) each."""
    per_cell = max(1, block.shape[0] * int(np.prod(block.shape[2:])) * 8)
    size = max(1, int(WORK_BYTES if work_bytes is None else work_bytes) // per_cell)
    return [(a, block[:, a:a + size]) for a in range(0, block.shape[1], size)]


class ArrayFrames(FrameSource):
    """A :class:`FrameSource` over an array held in memory (converted to float64)."""

    def __init__(self, array):
        self._array = np.asarray(array, dtype=float)
        super().__init__(self._array.shape)

    def _read(self, rows, lo, hi):
        return self._array[rows, lo:hi]


def as_source(x) -> FrameSource:
    """``x`` itself if it is a :class:`FrameSource`, else an :class:`ArrayFrames` of it."""
    return x if isinstance(x, FrameSource) else ArrayFrames(x)
