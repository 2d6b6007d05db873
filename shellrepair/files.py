"""Writing files whole or not at all.

Writing always goes to a temporary file in the target folder that is
flushed to disk and renamed into place, so a failed write never leaves a
partial file behind; :func:`atomic_write_many` does this for a mesh and its
report together.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from shellrepair.errors import MeshError

__all__ = ["check_output_path", "check_output_folder", "new_file_mode", "atomic_write", "atomic_write_many"]


def _probe(folder):
    """Raise OSError unless a file can be created in ``folder``: one is
    created and removed again. (``os.access`` answers yes to root
    everywhere, even in /proc, where nothing can be created.)"""
    fd, tmp = tempfile.mkstemp(prefix=".shellrepair-probe.", suffix=".tmp", dir=str(folder))
    os.close(fd)
    os.unlink(tmp)


def check_output_path(path, *, what="output"):
    """Raise :class:`MeshError` unless ``path`` can be written as a new or replaced file.

    Parameters
    ----------
    path : str or Path
    what : str
        Names the file in the message (``"output"``, ``"report"``).
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise MeshError(f"{what} folder " + ("is not a directory" if path.parent.exists() else "does not exist"),
                        path)
    if path.is_dir():
        raise MeshError(f"{what} path is a directory", path)
    if path.exists() and not path.is_file():
        raise MeshError(f"{what} path exists and is not a regular file", path)
    if not os.access(path.parent, os.W_OK):
        raise MeshError(f"{what} folder is not writable", path)
    try:
        _probe(path.parent)
    except OSError as exc:
        raise MeshError(f"{what} folder is not writable ({exc.strerror or exc})", path) from None


def check_output_folder(path, *, what="output folder"):
    """Raise :class:`MeshError` unless files can be written in the folder
    ``path``: an existing folder, or one that can be created (its parent
    exists); nothing is created.

    Parameters
    ----------
    path : str or Path
    what : str
        Names the folder in the message.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise MeshError(f"{what} exists and is not a directory", path)
    exists = path.exists()
    where = path if exists else path.parent
    if not exists and not where.is_dir():
        raise MeshError(f"the {what}'s parent " + ("is not a directory" if where.exists() else "does not exist"),
                        path)
    try:
        _probe(where)
    except OSError as exc:
        why = exc.strerror or exc
        raise MeshError(f"{what} is not writable ({why})" if exists else
                        f"{what} cannot be created in {where} ({why})", path) from None

def new_file_mode():
    """Permissions of a newly created file under the current umask (0o666 & ~umask)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write(path, payload, *, mode=None, os_errors=False):
    """Write ``payload`` (bytes or str) to ``path`` through a temp file + rename
    (:func:`atomic_write_many` of one file; the same parameters)."""
    atomic_write_many([(path, payload)], mode=mode, os_errors=os_errors)


def atomic_write_many(items, *, mode=None, os_errors=False):
    """Write several files, none of them partially.

    The one atomic write of the package: meshes, reports, pages, pictures
    (:func:`shellrepair.appearance.render.save_image`) and the shading's tables
    (:mod:`shellrepair.appearance.reflectance`) all go through it.

    Parameters
    ----------
    items : list of (path, payload)
        ``payload`` is bytes or str (written as UTF-8).
    mode : int, optional
        Permissions of the written files; default as a plain ``open()``
        would give them (:func:`new_file_mode`), not ``mkstemp``'s 0600.
    os_errors : bool
        Raise the ``OSError`` itself (its ``filename`` the target) instead
        of a :class:`MeshError`, for callers that promise ``OSError``.

    Notes
    -----
    Every payload goes to a temporary file beside its target (same folder,
    so the rename cannot cross file systems) and is flushed to disk; only
    when all are written are they renamed into place, in order, so a
    failure while writing (disk full, interrupted) leaves every target as
    it was. If a rename fails, the targets this call created are removed
    again (a target that existed before keeps its new content). Any
    failure removes the temporary files and raises :class:`MeshError`
    naming the target (``OSError`` with ``os_errors``).
    """
    mode = new_file_mode() if mode is None else int(mode)

    def failed(exc, path):
        if os_errors:
            return OSError(exc.errno, exc.strerror or str(exc), str(path))
        return MeshError(f"cannot write: {exc.strerror or exc}", path)

    tmps = []
    created = []  # targets that did not exist before and were already renamed into place
    try:
        for path, payload in items:
            path = Path(path)
            if isinstance(payload, str):
                payload = payload.encode("utf-8")
            try:
                fd, tmp = tempfile.mkstemp(prefix="." + path.name + ".", suffix=".tmp", dir=str(path.parent))
            except OSError as exc:
                raise failed(exc, path) from None
            tmps.append((tmp, path))
            try:
                os.fchmod(fd, mode)
                with os.fdopen(fd, "wb") as fh:
                    fh.write(payload)
                    fh.flush()
                    os.fsync(fh.fileno())
            except OSError as exc:
                raise failed(exc, path) from None
        for i, (tmp, path) in enumerate(tmps):
            existed = path.exists()
            try:
                os.replace(tmp, path)
            except OSError as exc:
                raise failed(exc, path) from None
            tmps[i] = (None, path)
            if not existed:
                created.append(path)
    except BaseException:
        for path in created:  # a later target failed: take back the new files of this call
            try:
                os.unlink(path)
            except OSError:
                pass
        raise
    finally:
        for tmp, _ in tmps:
            if tmp is not None and os.path.exists(tmp):
                os.unlink(tmp)
