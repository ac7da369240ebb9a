"""Instrument files cut short, and files with two channels of one name, through the real
SurfaceTopography readers (roughflow.scan, `roughflow import`). The repository holds no
instrument scan, so the tests write small ones in the layouts of the example files
di-1.di and opd-1.opd of SurfaceTopography's test data (test/file_format_examples, the
measured scans tests/data/README.md names): :func:`write_nanoscope` and :func:`write_opd`
below say what each holds."""

from __future__ import annotations

import io
import logging
import struct
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from roughflow import log_progress
from roughflow.cli import main
from roughflow.errors import InputError
from roughflow.scan import read_scan

ST = pytest.importorskip("SurfaceTopography")

#: Nanoscope scale of the measured example: 2.910461 V over the int16 range, 20.82646 nm/V.
NM_PER_LSB = 2.910461 / 65536 * 20.82646


def write_nanoscope(path: Path, channels: dict[tuple[str, str], tuple[str, np.ndarray]]
                    ) -> int:
    """A Bruker/Veeco Nanoscope file (.di, version 0x07200000, the layout of the measured
    example: a text header of CRLF lines, the "\\*File list end" mark, 0x1a and zeros up to
    the header length, then one int16 block per channel). ``channels`` maps a line
    direction and name to (image kind, int16 counts); "Height" channels are heights in nm
    (NM_PER_LSB), "Phase" ones degrees. Returns the length of the header's text."""
    blocks = list(channels.values())
    nx, ny = blocks[0][1].shape
    header_length = 8192
    lines = ["\\*File list", "\\Version: 0x07200000", "\\Date: 09:57:48 AM Tue Jan 12 2016",
             "\\Start context: OL2BIG", f"\\Data length: {header_length}",
             "\\*Equipment list", "\\Description: Dimension V", "\\Microscope: Dimension V",
             "\\*Ciao scan list", "\\Scan Size: 500 nm", f"\\Samps/line: {nx}",
             f"\\Lines: {ny}", "\\Aspect Ratio: 1:1", "\\@Sens. Zsens: V 20.82646 nm/V",
             "\\@Sens. Phase: V 1.000000 "]
    for k, ((direction, name), (kind, _)) in enumerate(channels.items()):
        sens, scale = ("Zsens", "2.910461 V") if kind == "Height" else ("Phase", "359.9945 deg")
        lines += ["\\*Ciao image list", f"\\Data offset: {header_length + k * 2 * nx * ny}",
                  f"\\Data length: {2 * nx * ny}", "\\Bytes/pixel: 2", f"\\Samps/line: {nx}",
                  f"\\Number of lines: {ny}", "\\Aspect Ratio: 1:1", "\\Scan Size: 500 500 nm",
                  f"\\Line Direction: {direction}",
                  f'\\@2:Image Data: S [{kind}] "{name}"',
                  f"\\@2:Z scale: V [Sens. {sens}] (0.005035400 V/LSB) {scale}",
                  f"\\@2:Z offset: V [Sens. {sens}] (0.005035400 V/LSB) 0 V"]
    text = ("\r\n".join(lines) + "\r\n").encode("latin-1")
    end = b"\\*File list end\r\n\x1a"
    data = b"".join(np.ascontiguousarray(c, dtype="<i2").tobytes() for _, c in blocks)
    path.write_bytes(text + end + bytes(header_length - len(text) - len(end)) + data)
    return len(text)


def write_opd(path: Path, waves: np.ndarray) -> None:
    """A Wyko OPD file (the layout of the measured example: a 2-byte prelude, a directory of
    24-byte block headers, then the blocks in its order): the wavelength (nm), aspect and
    pixel size (mm) of the example, a "Raw" float32 raster of ``waves`` (heights in
    wavelengths: nm = waves * 577.29), then the example's time, date and magnification."""
    nx, ny = waves.shape
    blocks = [(b"Wavelength", 7, struct.pack("<f", 577.2949829)),
              (b"Aspect", 7, struct.pack("<f", 1.0)),
              (b"Pixel_size", 7, struct.pack("<f", 0.000196733)),
              (b"Raw", 3, struct.pack("<HHH", nx, ny, 4) + waves.astype("<f4").tobytes()),
              (b"Time", 5, b"16:19:48"), (b"Date", 5, b"7/7/2015"),
              (b"Magnification", 7, struct.pack("<f", 50.322))]
    directory = struct.pack("<16shlH", b"Directory", 1, 24 * (len(blocks) + 1), 0xFFFF)
    for name, kind, payload in blocks:
        directory += struct.pack("<16shlH", name, kind, len(payload), 8)
    path.write_bytes(b"\x01\x00" + directory + b"".join(p for *_, p in blocks))


def counts(seed: int, shape=(16, 12)) -> np.ndarray:
    return np.random.default_rng(seed).integers(-3000, 3000, shape).astype(np.int16)


def nanoscope(tmp_path: Path) -> tuple[Path, int, dict]:
    """A 16 x 12 Nanoscope file with trace and retrace "Height" and a phase channel, as
    the measured example holds them."""
    channels = {("Trace", "Height"): ("Height", counts(0)),
                ("Retrace", "Height"): ("Height", counts(1)),
                ("Trace", "Phase"): ("Phase", counts(2))}
    path = tmp_path / "afm.di"
    return path, write_nanoscope(path, channels), channels


def test_the_small_files_are_read_as_their_instruments_files(tmp_path):
    # the written layouts are what the readers take (a test of truncation needs a whole file)
    path, _, channels = nanoscope(tmp_path)
    s = read_scan(path, channel=0, detrend_mode="none")
    assert s.scan.reader == "Bruker/Veeco/DI Nanoscope" and s.shape == (16, 12)
    assert s.scan.channel == "Height (channel 0)"
    h = s.heights * s.scan.length_scale
    want = channels["Trace", "Height"][1] * NM_PER_LSB * 1e-9
    # the reader's orientation of the lines aside, the heights are the counts, scaled
    assert np.sort(h.ravel()) == pytest.approx(np.sort(want.ravel()), rel=1e-6)
    waves = np.random.default_rng(3).normal(0.0, 0.01, (32, 24))
    write_opd(tmp_path / "wli.opd", waves)
    s = read_scan(tmp_path / "wli.opd", detrend_mode="none")
    assert s.scan.reader == "Wyko OPD" and s.shape == (32, 24)
    assert np.sort(s.heights.ravel() * s.scan.length_scale) == pytest.approx(
        np.sort(waves.ravel() * 577.2949829e-9), rel=1e-5)


def _cuts(path: Path, text_length: int) -> list[int]:
    """Sizes to cut ``path`` to: inside its header text, at its end, in the padding, and in
    the data."""
    n = path.stat().st_size
    return sorted({16, 100, 300, 500, text_length // 2, text_length - 300, text_length - 1,
                   text_length + 40, (text_length + 8192) // 2, 8192 + 100, n - 1})


def test_a_nanoscope_file_cut_inside_its_header_is_refused_naming_it(tmp_path, capsys):
    """A .di file cut inside its text header (the first 2000 bytes of the measured one)
    opened without a channel and crashed with an IndexError (exit 1)."""
    path, text_length, _ = nanoscope(tmp_path)
    data = path.read_bytes()
    first_image = data.index(b"\\*Ciao image list")
    for cut in _cuts(path, text_length):
        part = tmp_path / f"cut{cut}.di"
        part.write_bytes(data[:cut])
        with pytest.raises(InputError, match=f"cut{cut}.di' cannot be read: DIReader: ") as exc:
            read_scan(part)
        if cut <= first_image:  # every image section of the header is cut off
            assert f"no data channel in its {cut} bytes; is the file truncated?" in \
                str(exc.value)
    with pytest.raises(SystemExit) as exc:
        main(["import", str(tmp_path / "cut300.di"), "-o", str(tmp_path / "s.nc")])
    assert exc.value.code == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        f"roughflow import: error: {str(tmp_path / 'cut300.di')!r} cannot be read: DIReader: "
        "no data channel in its 300 bytes; is the file truncated?"]
    assert not (tmp_path / "s.nc").exists()


def test_a_reader_that_finds_no_channel_gives_way_to_the_reader_of_the_file_ending(tmp_path):
    """The first 128 bytes of the measured FRT file (frt-1.frt): the MATLAB reader, tried
    before the FRT one, opened them without a channel, and the import said the file "holds
    several arrays () and none named as heights"; the FRT reader says what is wrong."""
    head = bytes.fromhex(
        "4652544d5f474c4944455256312e30303a006500010000000077000100000000"
        "66000c000000f4010000f40100001000000067002c000000fa7e6abc7493883f"
        "fa7e6abc7493883f98512cb7b41a62bf2829b000a60c1cbf000000000000f03f"
        "010000006c000c00000005000000365ea27adff8443e0b0020a1070001000100")
    (tmp_path / "cut.frt").write_bytes(head)
    with pytest.raises(InputError, match=r"cannot read the heights of .*cut.frt' "
                                         r"\(CorruptFile: The file ended after"):
        read_scan(tmp_path / "cut.frt", fill="harmonic")


def test_two_channels_of_one_name_are_refused_listing_their_indices(tmp_path, capsys):
    """`--channel Height` took the first of the trace and retrace "Height" without a word."""
    path, _, channels = nanoscope(tmp_path)
    with pytest.raises(InputError, match=r"channel 'Height' names 2 channels of .*afm.di' "
                                         r"\(0: Height, 1: Height\): choose one by its index, "
                                         r"e.g. channel=0 \(CLI --channel 0\)"):
        read_scan(path, channel="Height")
    out = tmp_path / "s.nc"
    with pytest.raises(SystemExit) as exc:
        main(["import", str(path), "--channel", "Height", "-o", str(out)])
    assert exc.value.code == 2 and "names 2 channels" in capsys.readouterr().err
    assert not out.exists()
    # the index picks either; a unique name still picks its channel
    trace, retrace = (read_scan(path, channel=c, detrend_mode="none") for c in (0, "1"))
    assert (trace.scan.channel, retrace.scan.channel) == ("Height (channel 0)",
                                                          "Height (channel 1)")
    scale = NM_PER_LSB * 1e-9 / retrace.scan.length_scale
    assert np.sort(retrace.heights.ravel()) == pytest.approx(
        np.sort(channels["Retrace", "Height"][1].ravel() * scale), rel=1e-6)
    assert not np.allclose(trace.heights, retrace.heights)
    with pytest.raises(InputError, match="channel 'Phase' is not a height map"):
        read_scan(path, channel="Phase")
    assert main(["import", str(path), "--channel", "1", "-o", str(out)]) == 0
    assert "channel Height (channel 1)" in capsys.readouterr().out


def test_the_default_of_two_channels_of_one_name_is_read_with_a_warning(tmp_path, capsys,
                                                                         caplog):
    """Without --channel the file's default, channel 0 of the trace and retrace "Height",
    was read without a word while `--channel Height` was refused as ambiguous. It is still
    read (the documented imports of such files give no channel), with a warning naming both
    and how to pick one; the surface file keeps it, so `roughflow leak` repeats it."""
    path, _, _ = nanoscope(tmp_path)
    with caplog.at_level(logging.WARNING, logger="roughflow.scan"):
        s = read_scan(path, detrend_mode="none")
    said = ("2 channels are named 'Height' (0: Height, 1: Height; an AFM's trace and "
            "retrace?): read channel 0, the file's default; choose one by its index with "
            "channel= (CLI --channel 0 / --channel 1)")
    assert said in caplog.text and said in s.scan.warnings
    assert s.scan.channel == "Height (channel 0)"
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="roughflow.scan"):
        chosen = read_scan(path, channel=1, detrend_mode="none")
    assert "channels are named" not in caplog.text + chosen.scan.warnings
    assert main(["import", str(path), "-o", str(tmp_path / "s.nc")]) == 0
    assert "--channel 0 / --channel 1" in capsys.readouterr().err


def _cut_opd(tmp_path: Path) -> Path:
    """A Wyko OPD file cut inside its raster: the OPD reader refuses it (the blocks after
    the raster are missing), and igor2, trying it as an Igor wave (its first two bytes read
    as version 1), logs the rest of the file ("could not reshape data from ... b'...")."""
    write_opd(tmp_path / "wli.opd", np.random.default_rng(3).normal(0.0, 0.01, (64, 48)))
    data = (tmp_path / "wli.opd").read_bytes()
    (tmp_path / "cut.opd").write_bytes(data[:len(data) // 2])
    return tmp_path / "cut.opd"


@pytest.fixture
def debug_log():
    """roughflow's log at DEBUG, as `roughflow -vv` shows it (a stream to read), and a
    handler on the root logger, as logging.basicConfig installs one (its records)."""
    class Kept(logging.Handler):
        def __init__(self):
            super().__init__()
            self.records = []

        def emit(self, record):
            self.records.append(record)

    shown, user = io.StringIO(), Kept()
    logging.getLogger().addHandler(user)
    log_progress("DEBUG", stream=shown)
    try:
        yield shown, user.records
    finally:
        log_progress(None)
        logging.getLogger().removeHandler(user)


def test_what_reader_libraries_log_stays_out_of_the_users_log(tmp_path, debug_log):
    """igor2 logged a truncated .opd file's raw bytes (6.5 MB from the measured one) to
    whatever handles the root logger; roughflow's log has it at DEBUG, one short line."""
    shown, user = debug_log
    with pytest.raises(InputError, match=r"cut.opd' cannot be read: OPDReader: .*truncated"):
        read_scan(_cut_opd(tmp_path))
    assert [r.name for r in user if not r.name.startswith("roughflow")] == []
    said = [line for line in shown.getvalue().splitlines() if "igor2" in line]
    assert said and all(len(line) < 400 and line.isprintable() for line in said)


def test_what_reader_libraries_warn_stays_out_of_the_users_stderr(tmp_path, monkeypatch,
                                                                    debug_log):
    # no reader of the installed SurfaceTopography warns on these files; one that does is
    # simulated around the real detection
    real = ST.open_topography

    def warning_open(path, *args, **kwargs):
        warnings.warn("could not decode b'\\x00\\x01...'", UserWarning, stacklevel=1)
        return real(path, *args, **kwargs)

    monkeypatch.setattr(ST, "open_topography", warning_open)
    path = _cut_opd(tmp_path)
    with warnings.catch_warnings(record=True) as escaped:
        warnings.simplefilter("always")
        with pytest.raises(InputError, match="cannot be read: OPDReader"):
            read_scan(path)
    assert escaped == []
    assert "a reader warned: UserWarning: could not decode" in debug_log[0].getvalue()


def test_a_tiff_image_is_refused_without_what_tifffile_logs(tmp_path, debug_log):
    """A TIFF image of no instrument: the JPK reader opened it without a channel (an
    IndexError, exit 1); cut to its 8-byte header, tifffile also logged three warnings."""
    tifffile = pytest.importorskip("tifffile")
    tifffile.imwrite(tmp_path / "image.tiff", counts(4).astype(np.float32))
    (tmp_path / "head.tiff").write_bytes((tmp_path / "image.tiff").read_bytes()[:8])
    shown, user = debug_log
    for name in ("image.tiff", "head.tiff"):
        with pytest.raises(InputError, match=rf"{name}' is not a topography that Surface"
                                             r"Topography can read \(\w+ found no data channel"):
            read_scan(tmp_path / name, size="1um", unit="um")
    assert [r.name for r in user if not r.name.startswith("roughflow")] == []
    assert "tifffile logged: " in shown.getvalue()


def test_cli_refusal_of_a_truncated_opd_file_is_one_line(tmp_path):
    """As the user runs it (no logging configured: a library's records reach logging's
    last resort, standard error): `roughflow -q import` printed igor2's dump, then the
    error."""
    path = _cut_opd(tmp_path)
    run = subprocess.run([sys.executable, "-m", "roughflow", "-q", "import", str(path),
                          "-o", str(tmp_path / "s.nc")], capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 2, run.stderr[-2000:]
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and len(run.stderr) < 400, run.stderr[:2000]
    assert lines[0].startswith(f"roughflow import: error: {str(path)!r} cannot be read: "
                               "OPDReader: The file ended after")
