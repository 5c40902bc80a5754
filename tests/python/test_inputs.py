"""The Python packages' input discipline (python/inchworm_inputs), the one implementation
inchworm_optics, inchworm_segments and inchworm_dask share: `Range`'s text and its
messages (closed, open, integer and unitless ranges; NaN and infinities told a finite
number; a bool is not a number), and the bounded reading of a file (a regular file past
its bound refused unread, a stream such as /dev/zero or a FIFO refused within its bound,
lines past their length)."""
import io
import math
import os
import re
import sys
import threading

import numpy as np
import pytest

from conftest import ROOT

sys.path.insert(0, str(ROOT / "python" / "inchworm_inputs"))  # this tree's package, whatever the venv holds
from inchworm_inputs import InputError, Range, _g, bounded_lines, open_bounded, read_bounded  # noqa: E402


def refused(rng, value, message, **kw):
    with pytest.raises(InputError) as e:
        rng.check("x", value, **kw)
    assert str(e.value) == message
    return e.value


@pytest.mark.parametrize("rng,text", [
    (Range(0.0, 1.0, unit="m"), "0 ≤ value ≤ 1 m"),
    (Range(0.0, 3600.0, lo_open=True, unit="s"), "0 < value ≤ 3600 s"),
    (Range(0.0, 2.0, lo_open=True, hi_open=True), "0 < value < 2"),
    (Range(-1.0, 0.5, hi_open=True, unit="m"), "-1 ≤ value < 0.5 m"),
    (Range(0.0, lo_open=True, unit="mas"), "value > 0 mas"),
    (Range(0.0, unit="s"), "value ≥ 0 s"),
    (Range(hi=1e15, unit="e-"), "value ≤ 1e+15 e-"),
    (Range(8, 1024, unit="px", integer=True), "an integer, 8 ≤ value ≤ 1024 px"),
    (Range(0, integer=True), "an integer, value ≥ 0"),
    (Range(integer=True), "an integer"),
    (Range(unit="mas/s"), "a finite number, in mas/s"),
    (Range(), "a finite number"),
])
def test_a_range_states_what_it_accepts(rng, text):
    assert str(rng) == text


def test_a_value_out_of_its_range_is_named_with_the_range_and_why():
    pupil = Range(16, 1024, integer=True, unit="px", why="pixels across D")
    refused(pupil, 2000, "x 2000: accepted an integer, 16 ≤ value ≤ 1024 px (pixels across D)")
    refused(pupil, 48.5, "x 48.5: accepted an integer, 16 ≤ value ≤ 1024 px (pixels across D)")
    gain = Range(0.0, 2.0, lo_open=True, hi_open=True)
    refused(gain, 0, "x 0: accepted 0 < value < 2")
    refused(gain, 2.0, "x 2: accepted 0 < value < 2")
    assert gain.check("x", 1.99) == 1.99 and Range(0.0, 1.0).check("x", 0) == 0 and Range(0.0, 1.0).check("x", 1) == 1
    refused(Range(0.0, lo_open=True, unit="mas"), -1e-300, "x -1e-300: accepted value > 0 mas")
    refused(Range(0.0, 1.0), 10**5000, "x an integer of 5001 digits: accepted 0 ≤ value ≤ 1")
    refused(Range(0.0, 1.0), -(10**20), "x -an integer of 21 digits: accepted 0 ≤ value ≤ 1")
    # `shown`: the text the user wrote.
    refused(Range(0.0001, 10.0, why="a Real"), 20.0, "x mount.radius=20: accepted 0.0001 ≤ value ≤ 10 (a Real)",
            shown="mount.radius=20")


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf, np.float64("nan")])
def test_nan_and_infinities_are_told_a_finite_number(value):
    shown = _g(float(value))
    refused(Range(0.001, 100.0, unit="m"), value, f"x {shown}: accepted a finite number, 0.001 ≤ value ≤ 100 m")
    refused(Range(0.0, lo_open=True), value, f"x {shown}: accepted a finite number, value > 0")
    refused(Range(unit="mas"), value, f"x {shown}: accepted a finite number, in mas")
    refused(Range(), value, f"x {shown}: accepted a finite number")
    refused(Range(1, 6, integer=True, unit="rings"), value, f"x {shown}: accepted an integer, 1 ≤ value ≤ 6 rings")
    refused(Range(integer=True), value, f"x {shown}: accepted an integer")


@pytest.mark.parametrize("value", [True, False, np.bool_(True), "1", None, 1j, "a" * 200])
def test_what_is_not_a_real_number_is_refused_as_written(value):
    shown = repr(value)[:80]  # a bool is not a number: `True`, not 1
    refused(Range(0.0, 1.0), value, f"x {shown}: accepted 0 ≤ value ≤ 1")
    refused(Range(), value, f"x {shown}: accepted a finite number")


def test_a_value_in_its_range_is_the_number_checked():
    counts = Range(1, 100, integer=True)
    for value in (48, 48.0, np.int64(48), np.float32(48.0), np.uint8(48)):
        got = counts.check("x", value)
        assert got == 48 and type(got) is int
    for value in (0.5, np.float64(0.5), np.float32(0.5)):
        got = Range(0.0, 1.0).check("x", value)
        assert got == float(value) and type(got) is float


def test_every_package_raises_this_error():
    from inchworm_dask import inputs as dask_inputs
    from inchworm_optics import inputs as optics_inputs
    from inchworm_segments import config as segments_config

    for module in (dask_inputs, optics_inputs, segments_config):
        assert module.InputError is InputError and module.Range is Range
    assert issubclass(InputError, ValueError)


# ---- the bounded reading ----
def sparse(path, size):
    with open(path, "wb") as f:
        f.truncate(size)
    return path


def test_a_regular_file_past_its_bound_is_refused_unread(tmp_path):
    big = sparse(tmp_path / "big", 1 << 33)  # 8 GiB, nothing on disk: refused by its size
    with pytest.raises(InputError, match=re.escape(f"{big}: {1 << 33} bytes: accepted at most 100 bytes")):
        open_bounded(big, 100)
    with pytest.raises(InputError, match=re.escape(f"{big}: {1 << 33} bytes: accepted a plan of at most 100 bytes")):
        read_bounded(big, 100, "a plan")
    with open_bounded(sparse(tmp_path / "edge", 100), 100) as f:
        assert f.read() == bytes(100)
    assert read_bounded(tmp_path / "edge", 100) == bytes(100)
    with pytest.raises(FileNotFoundError):
        read_bounded(tmp_path / "none", 100)


@pytest.mark.skipif(not os.path.exists("/dev/zero"), reason="no /dev/zero")
def test_an_endless_stream_is_refused_at_its_bound():
    with pytest.raises(InputError, match=re.escape("/dev/zero: longer than 1000 bytes: accepted a plan")):
        read_bounded("/dev/zero", 1000, "a plan")
    with open_bounded("/dev/zero", 1000) as f, pytest.raises(InputError, match="zero: line 1: longer than 64 bytes"):
        list(bounded_lines(f, "zero", 1000, 64))


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs")
def test_a_fifo_is_read_within_its_bound(tmp_path):
    fifo = tmp_path / "fifo"

    def writer(data, endless):
        try:
            with open(fifo, "wb") as w:
                w.write(data)
                while endless:
                    w.write(b"x" * 4096)
        except BrokenPipeError:
            pass  # the reader stopped at its bound

    for data, endless in ((b"a,b\n1,2\n", False), (b"", True)):
        os.mkfifo(fifo)
        t = threading.Thread(target=writer, args=(data, endless), daemon=True)
        t.start()
        try:
            if endless:
                with pytest.raises(InputError, match="longer than 10000 bytes"):
                    read_bounded(fifo, 10000)
            else:
                assert read_bounded(fifo, 10000) == data
        finally:
            t.join(10)
            os.unlink(fifo)
        assert not t.is_alive()


def test_lines_past_their_length_or_the_whole_past_its_bound_are_refused():
    lines = lambda data, max_bytes=1000, max_line=8: list(bounded_lines(io.BytesIO(data), "f", max_bytes, max_line))  # noqa: E731
    # Lines cut after b"\n" only, as the binary's reader cuts them; the cap leaves the "\n" aside.
    assert lines(b"12345678\na\rb\n\nlast") == [(1, b"12345678\n"), (2, b"a\rb\n"), (3, b"\n"), (4, b"last")]
    assert lines(b"") == []
    with pytest.raises(InputError, match=re.escape("f: line 2: longer than 8 bytes")):
        lines(b"ok\n123456789\n")
    with pytest.raises(InputError, match=re.escape("f: line 1: longer than 8 bytes")):
        lines(b"123456789")
    with pytest.raises(InputError, match=re.escape("f: longer than 10 bytes")):
        lines(b"1234\n1234\n1234\n", max_bytes=10)
    assert len(lines(b"1234\n1234\n", max_bytes=10)) == 2


def test_a_text_stream_counts_characters_in_a_line_and_bytes_in_all():
    def lines(data, max_bytes=1000, max_line=6):
        text = io.TextIOWrapper(io.BytesIO(data), encoding="utf-8-sig", newline="")
        return list(bounded_lines(text, "f", max_bytes, max_line))

    assert lines("ééééé\r\nab\rc".encode()) == [(1, "ééééé\r\n"), (2, "ab\r"), (3, "c")]
    with pytest.raises(InputError, match=re.escape("f: line 1: longer than 6 characters")):
        lines("ééééééé\n".encode())
    with pytest.raises(InputError, match=re.escape("f: longer than 10 bytes")):
        lines("ééééé\n".encode(), max_bytes=10)  # 6 characters, 11 bytes
    with pytest.raises(InputError, match=re.escape("f: not UTF-8 text, near line 1 (invalid start byte)")):
        lines(b"a,\xff\n")
