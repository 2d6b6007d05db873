"""Make the rho_dt table file shipped with the package.

``python -m shellrepair.appearance.reflectance.table`` builds the table from its fixed
parameters (:func:`shellrepair.appearance.reflectance.albedo._build_table`, about 40 s
of CPU) and writes it to :data:`shellrepair.appearance.reflectance.albedo.SHIPPED_TABLE`
(``shellrepair/appearance/reflectance/rho_dt_table.npz``, package data), encoded by
:func:`~shellrepair.appearance.reflectance.albedo.encode_table`.  Run it after changing
one of the table's parameters (the ``_TABLE_*`` constants, the ranges, the
rule) and commit the file; until then the package builds the table on
first use and caches it (:func:`~shellrepair.appearance.reflectance.albedo.rho_dt_table`),
and tests/test_rho_dt_file.py fails.  The same parameters always give the
same values (the build is deterministic NumPy), though not the same bytes
(the zip records the time).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from shellrepair.appearance.reflectance import albedo

__all__ = ["write_table", "main"]


def write_table(path=None):
    """Build the table and write it, compressed, to ``path``.

    Parameters
    ----------
    path : str or Path, optional
        Where to write (default :data:`~shellrepair.appearance.reflectance.albedo.SHIPPED_TABLE`);
        written to a temporary file beside it and renamed, so a reader
        never sees half a file.

    Returns
    -------
    table : RhoDtTable
        The table as a reader of the file gets it.
    """
    import io

    from shellrepair.files import atomic_write

    path = os.fspath(path or albedo.SHIPPED_TABLE)
    arrays = albedo.encode_table(albedo._build_table())
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    # package data: readable by all, as a checkout's files are
    atomic_write(path, buf.getvalue(), mode=0o644, os_errors=True)
    return albedo.decode_table(arrays)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m shellrepair.appearance.reflectance.table", description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default=albedo.SHIPPED_TABLE,
                    help="where to write (default: the package's own file)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    write_table(args.output)
    print(f"wrote {args.output} ({os.path.getsize(args.output) / 1e6:.2f} MB) in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
