"""Writing files so that a crash, a kill or a full disk never leaves a partial file under its final
name, and saying so in one line when the disk is full.

`atomic_path(target)` yields a temporary path in the target's folder; when the block succeeds the
temporary file is flushed to disk (fsync), given the mode a plain new file would get (0666 less the
umask) and renamed over the target (os.replace, atomic on one file system), and the folder is
synced. When the block fails the temporary file is removed and the target keeps its previous
content. A failure for lack of space (ENOSPC, EDQUOT) becomes `DiskFull`, whose text names the
file, the space needed (the caller's estimate, or at least what was written) and the space free.

`atomic_h5(target)` does the same for an HDF5 file, which it builds in memory, and
`atomic_h5_update(path)` for a change to a small one: HDF5 never writes to the disk itself. A write HDF5 cannot finish leaves its library unable to close the file, and the
process then crashes at exit; a plain write of the finished image fails cleanly instead.
"""
from __future__ import annotations

import contextlib
import errno
import os
import tempfile
from pathlib import Path

NO_SPACE = (errno.ENOSPC, errno.EDQUOT)


class DiskFull(OSError):
    """No space left for `path`: an OSError with errno ENOSPC whose text says what to do."""

    def __init__(self, path, needed: int | None = None, at_least: bool = False):
        self.path = Path(path)
        self.needed = needed
        self.free = free_bytes(self.path)
        need = f"{'more than' if at_least else 'about'} {human_bytes(needed)} needed, " if needed else ""
        super().__init__(errno.ENOSPC,
                         f"cannot write {self.path}: no space left on device ({need}{human_bytes(self.free)} free "
                         f"on its file system). Fix: free space there, or set output.directory to a disk with room, "
                         f"and run again")

    def __str__(self) -> str:
        return self.strerror

    def __reduce__(self):
        """Pickled as it is (an error of a figure drawn in a helper process crosses to this one:
        drawing.py), not rebuilt from OSError's (errno, text)."""
        return _disk_full_as_was, (self.path, self.needed, self.free, self.strerror)


def _disk_full_as_was(path, needed, free, text) -> DiskFull:
    e = DiskFull.__new__(DiskFull)
    OSError.__init__(e, errno.ENOSPC, text)
    e.path, e.needed, e.free = path, needed, free
    return e


def is_no_space(e: BaseException) -> bool:
    """An error of a write that the file system refused for lack of space (also as HDF5 reports it)."""
    if isinstance(e, OSError) and e.errno in NO_SPACE:
        return True
    return isinstance(e, OSError) and "No space left on device" in str(e)


def human_bytes(n: int | None) -> str:
    if n is None:
        return "?"
    for unit, size in (("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= size:
            return f"{n / size:.1f} {unit}"
    return f"{n} B"


def free_bytes(path) -> int:
    """Bytes an unprivileged user may still write on the file system holding `path` (or its
    nearest existing parent)."""
    p = Path(path).absolute()
    while not p.exists() and p != p.parent:
        p = p.parent
    try:
        st = os.statvfs(p)
    except OSError:
        return 0
    return st.f_bavail * st.f_frsize


def _new_file_mode() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def _fsync(path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


@contextlib.contextmanager
def atomic_path(target, needed: int | None = None, suffix: str = ".part", mode: int | None = None):
    """Yield a temporary path beside `target` to write; put it in place only if the block succeeds
    (see the module's text). `needed`: the bytes the file will take, for the disk-full message;
    `suffix`: the temporary name's ending (a writer that picks its format by extension needs it);
    `mode`: the file's permissions (default: as a new file under the umask)."""
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=suffix, dir=target.parent)
    os.close(fd)
    try:
        try:
            yield Path(tmp)
            _fsync(tmp)
        except OSError as e:
            if is_no_space(e) and not isinstance(e, DiskFull):  # a DiskFull names its own file
                if needed:
                    raise DiskFull(target, needed) from e
                written = os.path.getsize(tmp) if os.path.exists(tmp) else 0
                raise DiskFull(target, written or None, at_least=True) from e
            raise
        os.chmod(tmp, _new_file_mode() if mode is None else mode)
        os.replace(tmp, target)
        with contextlib.suppress(OSError):
            _fsync(target.parent)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


@contextlib.contextmanager
def h5_in_memory(path, mode: int = 0o666):
    """Yield an h5py.File open for writing in memory; once the block succeeds, write its image to
    `path` (created with `mode` less the umask) with a plain write: on a full disk an OSError
    (ENOSPC), and no file at `path`."""
    import io

    import h5py

    buf = io.BytesIO()
    with h5py.File(buf, "w") as f:
        yield f
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_CLOEXEC, mode)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(buf.getbuffer())
    except OSError:
        with contextlib.suppress(OSError):
            os.unlink(path)
        raise


@contextlib.contextmanager
def atomic_h5(target, needed: int | None = None, mode: int | None = None):
    """h5_in_memory put in place through atomic_path (`needed`, `mode` as there)."""
    with atomic_path(target, needed, mode=mode) as tmp, h5_in_memory(tmp) as f:
        yield f


@contextlib.contextmanager
def atomic_h5_update(path):
    """Yield an existing (small) HDF5 file opened for changes in memory; once the block succeeds,
    put the changed file in place through atomic_path, with the file's permissions kept."""
    import io
    import stat

    import h5py

    path = Path(path)
    mode = stat.S_IMODE(path.stat().st_mode)
    buf = io.BytesIO(path.read_bytes())
    with h5py.File(buf, "r+") as f:
        yield f
    with atomic_path(path, mode=mode) as tmp, open(tmp, "wb") as fh:
        fh.write(buf.getbuffer())
