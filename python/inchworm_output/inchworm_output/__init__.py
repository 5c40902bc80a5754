"""The output discipline of the Python packages, as `inchworm_cosim::output` is the Rust
programs' (README, "Reliability: your files"):

* `check(outputs, inputs)` before any work: each output is a file, not a folder, in a
  folder it can write (made if missing), distinct from every other output and from every
  input, by resolved path and by device and inode (a hard link counts);
* `replacing(path)` writes a uniquely named temporary beside the target,
  `.<name>.<random>.partial.<ext>` (never a fixed name that may be a user's), and renames
  it over the target only when the block completes; a failure or a signal leaves the
  target as it was and no temporary behind. `replacing_path(path)` is the same for a
  writer that takes a path (matplotlib's `savefig`, which reads the format from the
  extension the temporary keeps).

No dependencies beyond the standard library.
"""
import contextlib
import os
import pathlib
import tempfile


class OutputError(ValueError):
    """An output that cannot be written without losing data; the message names it."""


def _identity(path):
    """(resolved path, (device, inode) if it exists)."""
    p = pathlib.Path(path)
    try:
        st = p.stat()
        node = (st.st_dev, st.st_ino)
    except OSError:
        node = None
    return os.path.realpath(p), node


def _same(a, b):
    return a[0] == b[0] or (a[1] is not None and a[1] == b[1])


def check(outputs, inputs=()):
    """Refuses, before any work, outputs that would destroy data: `outputs` maps a role
    (as the user named it, e.g. "--out") to a path, `inputs` lists the paths read. Makes
    each output's folder if missing and proves it takes a new file."""
    seen = []
    ins = [(pathlib.Path(i), _identity(i)) for i in inputs]
    for role, path in outputs.items():
        path = pathlib.Path(path)
        if str(path) == "" or path.is_dir():
            raise OutputError(f"{role} {path}: is a folder, not a file")
        folder = path.parent
        try:
            folder.mkdir(parents=True, exist_ok=True)
            fd, probe = tempfile.mkstemp(prefix=".inchworm-check.", dir=folder)
            os.close(fd)
            os.unlink(probe)
        except OSError as e:
            raise OutputError(f"{role} {path}: its folder {folder} cannot take a new file ({e.strerror or e})") from e
        me = _identity(path)
        for i, ident in ins:
            if _same(me, ident):
                raise OutputError(f"{role} {path}: is the input {i}, which it would overwrite")
        for other, ident in seen:
            if _same(me, ident):
                raise OutputError(f"{role} {path}: is also {other}; two outputs would overwrite each other")
        seen.append((role, me))


def _temporary(path):
    path = pathlib.Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".partial{path.suffix}", dir=path.parent)
    return fd, pathlib.Path(tmp)


@contextlib.contextmanager
def replacing_path(path):
    """A temporary path beside `path` to write, renamed over `path` when the block
    completes; removed if it raises (any exception, KeyboardInterrupt and SystemExit
    included)."""
    fd, tmp = _temporary(path)
    os.close(fd)
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def replacing(path, mode="w", newline=""):
    """A file open for writing (text with `newline`, or binary with mode "wb") on a
    temporary beside `path`, renamed over `path` when the block completes."""
    with replacing_path(path) as tmp:
        kw = {} if "b" in mode else {"newline": newline, "encoding": "utf-8"}
        with open(tmp, mode, **kw) as f:
            yield f
