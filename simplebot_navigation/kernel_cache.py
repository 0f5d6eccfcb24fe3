"""Keeps numba's on-disk caches of kernels that call each other consistent.

numba keys a cached function on its own source file only. A kernel that calls (and so inlines) a
function of another module keeps running the old callee after only that module changed, e.g. after
an update or a checkout: a new edge family silently missing from the solver. One fingerprint over
the sources of such a group drops all the group's cache entries whenever any of them changes.
"""

from __future__ import annotations

import hashlib
from pathlib import Path


#: geometry_kernels.py, which kernels of several packages inline
SHARED_KERNELS = Path(__file__).with_name("geometry_kernels.py")


def drop_stale_kernel_caches(package_dir: str | Path, modules: tuple[str, ...], inlined: tuple[Path, ...] = ()
                             ) -> None:
    """Delete the numba cache files of ``modules`` (in ``package_dir``) unless their sources, and those of the
    ``inlined`` files of other packages they call, are unchanged since the caches were written; call it before
    any of their functions is compiled or loaded."""
    package_dir = Path(package_dir)
    cache_dir = package_dir / "__pycache__"
    try:
        sources = [package_dir / f"{m}.py" for m in modules] + [Path(p) for p in inlined]
        digest = hashlib.sha256(b"".join(path.read_bytes() for path in sources)).hexdigest()
        stamp = cache_dir / f"numba-{'+'.join(modules)}.sha256"
        if stamp.is_file() and stamp.read_text() == digest:
            return
        for module in modules:
            for cached in cache_dir.glob(f"{module}.*.nb[ic]"):
                cached.unlink(missing_ok=True)
        cache_dir.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:
        pass   # a read-only install: numba then cannot write caches there either
