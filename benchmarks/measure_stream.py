"""Memory and time of `fcsweep measure` on a large label stack (docs/measure.md, "Cost and memory").

Writes a T x 2048 x 2048 uint16 TIFF (a confluent monolayer: the Voronoi cells of a jittered
triangular lattice, ~20 px per R0, about 3 300 cells per frame, drifting 1 px per frame along
the diagonal; tests/measure_render.py), then measures it as the command does
(:func:`fcsweep.measure.measure_to_file`) and prints, per frame, the resident memory and the
CPU time, and at the end the peak resident memory of the process.

    PYTHONPATH=. python benchmarks/measure_stream.py --frames 64 [--size 2048] [--r0 20] [--dir /tmp/x]
"""

import argparse
import resource
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from measure_render import drifting_frames, voronoi_base  # noqa: E402

import fcsweep.measure.dataset as dataset  # noqa: E402
from fcsweep.measure import measure_to_file  # noqa: E402


def rss_mb() -> float:
    """Resident memory of this process now (MB)."""
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize() / 1e6


def write_stack(path: Path, frames: int, size: int, r0: float) -> None:
    """The test stack, written page by page (never whole in memory)."""
    import tifffile

    base = voronoi_base(size, r0, margin=64)
    with tifffile.TiffWriter(path, bigtiff=True) as tif:
        for frame in drifting_frames(base, size, frames):
            tif.write(frame.astype(np.uint16), contiguous=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=64)
    ap.add_argument("--size", type=int, default=2048)
    ap.add_argument("--r0", type=float, default=20.0, help="pixels per R0 (cell area pi r0^2)")
    ap.add_argument("--dir", type=Path, default=Path("/tmp/fcsweep-measure-stream"))
    args = ap.parse_args()
    args.dir.mkdir(parents=True, exist_ok=True)
    stack = args.dir / f"stack_{args.frames}x{args.size}.tif"
    if not stack.exists():
        write_stack(stack, args.frames, args.size, args.r0)
    base_rss = rss_mb()
    reader = dataset.iter_frames
    t0, c0 = time.time(), time.process_time()

    def logged(labels, **options):
        for k, item in enumerate(reader(labels, **options)):
            if k % 8 == 0:
                print(f"frame {k:5d}  rss {rss_mb():7.0f} MB  cpu {time.process_time() - c0:8.1f} s", flush=True)
            yield item

    dataset.iter_frames = logged
    out = measure_to_file(stack, args.dir / f"out_{args.frames}")
    cpu, wall = time.process_time() - c0, time.time() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3
    import xarray as xr

    with xr.open_dataset(out) as ds:
        cells = float(ds.n_cells.mean())
        print(f"frames {args.frames} of {args.size}^2, {cells:.0f} cells per frame, {ds.sizes['cell']} tracks; "
              f"cpu {cpu:.0f} s ({cpu / args.frames:.2f} s per frame), wall {wall:.0f} s; rss before measuring "
              f"{base_rss:.0f} MB, peak rss {peak:.0f} MB; measure.nc {out.stat().st_size / 1e6:.0f} MB")


if __name__ == "__main__":
    main()
