"""The input discipline of the Python packages (inchworm_optics, inchworm_segments,
inchworm_dask), one implementation for all of them, as `inchworm_output` is their output
discipline:

* `InputError` (a ValueError): an input a package cannot use, in a one-line message that
  names the input, its value and what is accepted. Each package's `InputError` is this
  class (`inchworm_optics.inputs`, `inchworm_segments.config`, `inchworm_dask.inputs`).
* `Range`: an accepted range, stated once, and its check: `Range(16, 1024, integer=True,
  unit="px", why="pixels across D").check("pupil_px", 2000)` raises `pupil_px 2000:
  accepted an integer, 16 ≤ value ≤ 1024 px (pixels across D)`. `_g` is how the messages
  show a number.
* The bounded reading of a file: `open_bounded` refuses a regular file past its bound
  unread, `read_bounded` reads a whole file and `bounded_lines` its lines, each refusing
  what goes past its bound as it is read, so that /dev/zero or a FIFO that never ends is
  refused instead of hanging the command or filling the memory.
* `command(prog, body, refused, failed)`: a command's `main`, one shape for all of them:
  `body()`'s exit code, or a one-line `prog: error: …` and 2 for a refused input or output,
  1 for a failure of the system (`OSError` and the like).

The standard library only: the commands check their arguments with it before importing
numpy, poppy, hcipy or dask.
"""
from dataclasses import dataclass
import io
import math
import numbers
import os
import stat

__all__ = ["InputError", "Range", "open_bounded", "read_bounded", "bounded_lines"]


class InputError(ValueError):
    """An input the package cannot use; the message names it and what is accepted."""


def _g(x):
    """A number as the messages show it: `%g` for a float, an integer's digits (or their
    count, past what `str` converts: Python refuses more than 4300 digits)."""
    if isinstance(x, float):
        return f"{x:g}"
    if isinstance(x, int) and abs(x) >= 10**18:
        return f"{'-' if x < 0 else ''}an integer of {int(math.log10(abs(x))) + 1} digits"
    return str(x)


def _number(value):
    """`value` as an int (an integral number: Python's, numpy's) or a float (another real
    number); None if it is not a real number (a bool, a string, None, ...) or has no
    float."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        return None
    if isinstance(value, numbers.Integral):
        return int(value)
    try:
        return float(value)
    except (OverflowError, ValueError):
        return None


@dataclass(frozen=True)
class Range:
    """lo ≤ value ≤ hi (`<` where `lo_open`/`hi_open`), finite (an integer where
    `integer`), in `unit`; `why` says where the bounds come from. Its text (`str`) is what
    the messages and the docs say is accepted: `0 < value ≤ 3600 s`, `value > 0 mas`, `an
    integer, 8 ≤ value ≤ 1024 px`, `a finite number, in mas`."""

    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    unit: str = ""
    why: str = ""
    integer: bool = False

    def __str__(self):
        lo = "" if self.lo == -math.inf else f"{_g(self.lo)} {'<' if self.lo_open else '≤'} "
        hi = "" if self.hi == math.inf else f" {'<' if self.hi_open else '≤'} {_g(self.hi)}"
        if lo and not hi:  # "value > 0" reads better than "0 < value"
            lo, hi = "", f" {'>' if self.lo_open else '≥'} {_g(self.lo)}"
        kind = "an integer" if self.integer else "a finite number"
        if not (lo or hi):
            return kind + (f", in {self.unit}" if self.unit else "")
        return (f"{kind}, " if self.integer else "") + f"{lo}value{hi}" + (f" {self.unit}" if self.unit else "")

    def check(self, name, value, shown=None):
        """`value` if it is in the range, as an int where the range is of integers (48.0
        and numpy's int64 are 48) and a float elsewhere; else an `InputError` naming `name`
        and the value (as `shown`, if given: the text the user wrote). A bool is not a
        number; a NaN or an infinity is told the range wants a finite number."""
        x = _number(value)
        ok = x is not None and (isinstance(x, int) or (math.isfinite(x) and (not self.integer or x.is_integer())))
        if ok:
            ok = (self.lo < x if self.lo_open else self.lo <= x) and (x < self.hi if self.hi_open else x <= self.hi)
        if not ok:
            shown = shown if shown is not None else _g(x) if x is not None else repr(value)[:80]
            accepted = str(self)
            if isinstance(x, float) and not math.isfinite(x) and not accepted.startswith(("a finite", "an integer")):
                accepted = "a finite number, " + accepted
            raise InputError(f"{name} {shown}: accepted {accepted}" + (f" ({self.why})" if self.why else ""))
        return int(x) if self.integer else x


# ---- files ----
def open_bounded(path, max_bytes, what=""):
    """`path` open for reading bytes; an InputError if it is a regular file larger than
    `max_bytes` (`what` names what is accepted: "a plan"), refused unread. A stream
    without a size (a FIFO, a device) is bounded while it is read (`read_bounded`,
    `bounded_lines`). An unreadable file is the OSError of `open`."""
    f = open(path, "rb")
    try:
        st = os.fstat(f.fileno())
        if stat.S_ISREG(st.st_mode) and st.st_size > max_bytes:
            raise InputError(f"{path}: {st.st_size} bytes: accepted {what + ' of ' if what else ''}at most "
                             f"{max_bytes} bytes")
    except BaseException:
        f.close()
        raise
    return f


def read_bounded(path, max_bytes, what=""):
    """The bytes of the file at `path`, at most `max_bytes`: a regular file larger is
    refused unread (`open_bounded`), a stream once it has given one byte more; an
    InputError naming `path` (and `what` is accepted). An unreadable file is the OSError
    of `open`."""
    with open_bounded(path, max_bytes, what) as f:
        data = f.read(max_bytes + 1)
    if len(data) > max_bytes:
        raise InputError(f"{path}: longer than {max_bytes} bytes" + (f": accepted {what}" if what else ""))
    return data


def bounded_lines(stream, name, max_bytes, max_line):
    """(line number, line) of every line of `stream`, the first 1, each line read at most
    `max_line` + 1 at a time: a line longer than `max_line` (its "\\n" aside), or more than
    `max_bytes` bytes in all, is an InputError naming `name` (and the line) once that much
    is read. A binary stream's lines are bytes, cut after each b"\\n" (as Rust's
    `read_until` cuts them), `max_line` bytes; a text stream's (UTF-8) are what its
    `readline` cuts, `max_line` characters, their UTF-8 counted towards `max_bytes`, and
    bytes that are not UTF-8 an InputError too."""
    text = isinstance(stream, io.TextIOBase)
    unit, newline = ("characters", "\n") if text else ("bytes", b"\n")
    number = total = 0
    while True:
        try:
            line = stream.readline(max_line + 1)
        except UnicodeDecodeError as e:
            raise InputError(f"{name}: not UTF-8 text, near line {number + 1} ({e.reason})") from None
        if not line:
            return
        number += 1
        total += len(line) if not text or line.isascii() else len(line.encode("utf-8", "surrogatepass"))
        if len(line) > max_line and not line.endswith(newline):
            raise InputError(f"{name}: line {number}: longer than {max_line} {unit}")
        if total > max_bytes:
            raise InputError(f"{name}: longer than {max_bytes} bytes")
        yield number, line


def command(prog, body, refused=(InputError,), failed=(OSError,)):
    """`body()`'s exit code; an exception of `refused` (the inputs or outputs a command
    refuses) prints `prog: error: <message>` on stderr and gives 2, one of `failed` (the
    system's failures) the same and 1."""
    import sys

    try:
        return body()
    except refused as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 2
    except failed as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return 1
