"""`fcsweep measure` on unreadable or ambiguous input: one line naming the file and the problem,
exit 2, no traceback, nothing left behind (CLI); :class:`MeasureInputError` (Python API).
Legitimate but unusual input (large label values, a binary mask with ``label_binary``) is
measured correctly."""

from __future__ import annotations

import re
import zlib

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from fcsweep.cli import cli
from fcsweep.measure import MeasureInputError, measure
from fcsweep.measure import readers as measure_readers

tifffile = pytest.importorskip("tifffile")


def _discs(n=3, size=64, r=7, dtype=np.uint16):
    """A label frame of ``n`` separate discs labelled 1..n."""
    yy, xx = np.mgrid[0:size, 0:size]
    frame = np.zeros((size, size), dtype=dtype)
    for k in range(n):
        cx, cy = 12 + 19 * k, 20 + 10 * (k % 2)
        frame[(xx - cx) ** 2 + (yy - cy) ** 2 < r * r] = k + 1
    return frame


def _files(tmp):
    """name -> words the message must hold."""
    good = _discs()
    stack = np.stack([good, good])
    tifffile.imwrite(tmp / "plain.tif", stack)
    data = (tmp / "plain.tif").read_bytes()
    (tmp / "trunc_plain.tif").write_bytes(data[: len(data) // 2])
    tifffile.imwrite(tmp / "z.tif", stack, compression="zlib")
    data = (tmp / "z.tif").read_bytes()
    (tmp / "trunc_zlib.tif").write_bytes(data[: len(data) * 2 // 3])
    (tmp / "header6.tif").write_bytes(data[:6])
    Image.fromarray(good.astype(np.uint8)).save(tmp / "good.png")
    data = (tmp / "good.png").read_bytes()
    (tmp / "trunc.png").write_bytes(data[: len(data) // 2])
    (tmp / "text.tif").write_text("not an image\n")
    Image.fromarray(np.zeros((16, 16, 3), np.uint8)).save(tmp / "photo.jpg", format="JPEG")
    (tmp / "jpeg.tif").write_bytes((tmp / "photo.jpg").read_bytes())
    (tmp / "empty.tif").write_bytes(b"")
    (tmp / "text.png").write_text("not a png\n")
    rec = np.zeros(4, dtype=[("a", "i4"), ("b", "f8")])
    np.save(tmp / "struct_seg.npy", rec)
    obj = np.zeros(3, dtype=[("a", "O"), ("b", "i4")])
    np.save(tmp / "objstruct_seg.npy", obj, allow_pickle=True)
    rgb = np.zeros((64, 64, 3), np.uint8)
    rgb[..., 0] = good
    tifffile.imwrite(tmp / "rgb.tif", rgb, photometric="rgb")
    Image.fromarray(rgb).save(tmp / "rgb.png")
    Image.fromarray(np.dstack([rgb, np.full((64, 64), 255, np.uint8)])).save(tmp / "rgba.png")
    tifffile.imwrite(tmp / "cyx.tif", stack, metadata={"axes": "CYX"})
    np.save(tmp / "yxc.npy", rgb)
    Image.fromarray(np.where(good > 0, 255, 0).astype(np.uint8)).save(tmp / "binary255.png")
    tifffile.imwrite(tmp / "binary01.tif", (good > 0).astype(np.uint8))
    return {"trunc_plain.tif": "ends inside the frame", "trunc_zlib.tif": "not a readable TIFF",
            "header6.tif": "not a readable TIFF", "trunc.png": "not a readable PNG", "text.tif": "not a readable TIFF",
            "jpeg.tif": "not a readable TIFF", "empty.tif": "empty file", "text.png": "not a readable PNG",
            "struct_seg.npy": "structured", "objstruct_seg.npy": "structured", "rgb.tif": "colour (RGB)",
            "rgb.png": "not a label image", "rgba.png": "not a label image", "cyx.tif": "channel axis",
            "yxc.npy": "colour image", "binary255.png": "binary mask", "binary01.tif": "binary mask"}


def test_every_broken_file_is_one_line_exit_2_nothing_left(tmp_path):
    src = tmp_path / "in"
    src.mkdir()
    for name, words in _files(src).items():
        out = tmp_path / f"out_{name}"
        r = CliRunner().invoke(cli, ["measure", str(src / name), "-o", str(out)])
        text = r.output.strip()
        assert r.exit_code == 2, (name, r.output, r.exception)
        assert "Traceback" not in r.output and len(text.splitlines()) == 1, (name, r.output)
        assert name in text and words in text, (name, text)
        assert not out.exists(), name  # no measure.nc, no .fcsweep-measure-* spool, no empty directory
        with pytest.raises(MeasureInputError, match=re.escape(words)):
            measure(src / name)


def test_output_directory_kept_clean_on_error(tmp_path):
    """An existing output directory keeps only what it had: no spool and no partial file."""
    src = tmp_path / "in"
    src.mkdir()
    _files(src)
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    r = CliRunner().invoke(cli, ["measure", str(src / "trunc_zlib.tif"), "-o", str(out)])
    assert r.exit_code == 2
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt"]


def test_binary_mask_labelled_on_request():
    """A 0/255 mask of three discs: refused by default, three cells with ``label_binary=True``."""
    binary = np.where(_discs() > 0, 255, 0).astype(np.uint8)
    with pytest.raises(MeasureInputError, match="label_binary=True"):
        measure(binary)
    ds = measure(binary, label_binary=True, track=False)
    assert int(ds.n_cells[0]) == 3
    # a single cell labelled 1 (or 255) is a legitimate label image
    one = (_discs(1) > 0).astype(np.uint8) * 255
    assert int(measure(one, track=False).n_cells[0]) == 1


@pytest.mark.parametrize("big", [10 ** 8, 2 ** 31 - 1, 2 ** 62])
def test_large_label_values_are_renumbered(big, tmp_path):
    """Two cells, one labelled ``big``: measured as two cells in a fraction of a second (the frame is
    renumbered first, so memory follows the cells), the original labels kept, from an int64 .npy too."""
    frame = _discs(2, dtype=np.int64)
    frame[frame == 2] = big
    ref = measure(_discs(2, dtype=np.int64), track=False)
    np.save(tmp_path / "big.npy", frame[None])
    for src in (frame, tmp_path / "big.npy"):
        ds = measure(src, track=False)
        assert sorted(ds.label.values[0].tolist()) == [1, big]
        np.testing.assert_allclose(np.sort(ds.q.values[0]), np.sort(ref.q.values[0]))
    out = tmp_path / "o"
    r = CliRunner().invoke(cli, ["measure", str(tmp_path / "big.npy"), "-o", str(out)])
    assert r.exit_code == 0, r.output
    assert [p.name for p in out.iterdir()] == ["measure.nc"]


def test_uint64_labels_above_int64():
    frame = _discs(2).astype(np.uint64)
    frame[frame == 2] = np.uint64(2 ** 63 + 5)
    ds = measure(frame, track=False)
    assert int(ds.n_cells[0]) == 2


def test_memory_guard_uses_the_measured_bytes_per_pixel(tmp_path, monkeypatch):
    """The guard asks BYTES_PER_PIXEL (40, measured 37.5 at 4096^2) per pixel of a frame."""
    tifffile.imwrite(tmp_path / "f.tif", _discs())
    need = 64 * 64 * measure_readers.BYTES_PER_PIXEL
    monkeypatch.setattr(measure_readers, "available_memory", lambda: need - 1)
    with pytest.raises(MeasureInputError, match="GiB"):
        measure(tmp_path / "f.tif")
    monkeypatch.setattr(measure_readers, "available_memory", lambda: need + 1)
    assert int(measure(tmp_path / "f.tif").n_cells[0]) == 3


@pytest.mark.parametrize("times, words", [("0,2,1", "must increase from frame to frame, got 0,2,1: frame 2 is at 1"),
                                          ("0,1,2", "3 time stamps given for 2 frames"),
                                          ("0,a", "comma-separated numbers")])
def test_times_wording(times, words, tmp_path):
    np.save(tmp_path / "s.npy", np.stack([_discs(), _discs()]))
    r = CliRunner().invoke(cli, ["measure", str(tmp_path / "s.npy"), "-o", str(tmp_path / "o"), "--times", times])
    assert r.exit_code == 2 and words in r.output and "Traceback" not in r.output, r.output
    assert not (tmp_path / "o").exists()


def test_contact_graph_warns_when_most_cells_are_alone(tmp_path):
    """Separate nuclei: --neighbours contact leaves every cell without a neighbour; one warning line
    says so (rho_d would read 1 without a word)."""
    frame = np.zeros((120, 120), np.uint16)
    yy, xx = np.mgrid[0:120, 0:120]
    k = 0
    for cx in range(15, 120, 22):
        for cy in range(15, 120, 22):
            k += 1
            frame[(xx - cx) ** 2 + (yy - cy) ** 2 < 36] = k
    np.save(tmp_path / "nuclei.npy", frame)
    with pytest.warns(UserWarning, match="without a touching neighbour"):
        measure(frame, neighbours="contact", track=False)
    r = CliRunner().invoke(cli, ["measure", str(tmp_path / "nuclei.npy"), "-o", str(tmp_path / "o"),
                                 "--neighbours", "contact"])
    assert r.exit_code == 0 and r.output.count("warning:") == 1 and "without a touching neighbour" in r.output


def test_reader_error_is_a_measure_input_error_not_a_raw_one(tmp_path):
    """Whatever the underlying reader raises (zlib.error, struct.error, OSError...), the API raises
    MeasureInputError naming the file."""
    payload = zlib.compress(b"x" * 100)[:5]
    (tmp_path / "bad.tif").write_bytes(b"II*\x00\x08\x00\x00\x00" + payload)
    with pytest.raises(MeasureInputError, match="bad.tif"):
        measure(tmp_path / "bad.tif")


def test_binary_mask_from_the_command_line(tmp_path):
    """The CLI refuses a binary PNG in one line naming --label-binary, and measures it with it."""
    from PIL import Image

    png = tmp_path / "binary.png"
    Image.fromarray(np.where(_discs() > 0, 255, 0).astype(np.uint8)).save(png)
    r = CliRunner().invoke(cli, ["measure", str(png), "-o", str(tmp_path / "a")])
    assert r.exit_code == 2 and "--label-binary" in r.output and len(r.output.strip().splitlines()) == 1
    assert not (tmp_path / "a" / "measure.nc").exists()
    r = CliRunner().invoke(cli, ["measure", str(png), "-o", str(tmp_path / "b"), "--label-binary"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "b" / "measure.nc").exists()
