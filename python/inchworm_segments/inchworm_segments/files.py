"""Reading the files this package reads (the poses CSV; a run's CSVs for `compare`): each is
bounded in size and in the length of its lines, UTF-8 text (a leading byte-order mark
taken), CSV records. Every way a file can fail to be that is an `InputError` naming the
file and the row; none reaches the caller as csv's, the codec's or another exception, and
no file is read past its bound (a FIFO or a device included), so a hostile file is refused
instead of hanging the command or filling the memory. The bounds are `inchworm_inputs`'
(`open_bounded`, `bounded_lines`: the one implementation every package shares); the CSV
records are this package's. An unreadable file is the OSError of `open`, as in
`inchworm_optics.telescope.Prescription.load`.
"""
import csv
import io

from inchworm_inputs import InputError, bounded_lines


def csv_rows(stream, name, max_bytes, max_line_chars):
    """(row number, fields) of each CSV record of the binary `stream`, the first row 1;
    an InputError naming `name` where the text is not UTF-8, a line is longer than
    `max_line_chars` characters, the whole is longer than `max_bytes` or a record is not CSV
    (csv's own limit on a field, 128 KiB, included)."""
    text = io.TextIOWrapper(stream, encoding="utf-8-sig", newline="")
    reader = csv.reader(line for _, line in bounded_lines(text, name, max_bytes, max_line_chars))
    row = 0
    while True:
        try:
            fields = next(reader)
        except StopIteration:
            return
        except csv.Error as e:
            raise InputError(f"{name}: row {row + 1}: not CSV ({e})") from None
        row += 1
        yield row, fields
