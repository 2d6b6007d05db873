"""The build's two warm-up processes (``warmup.warm_up(share=1|2)``, run
side by side by the Makefile) cover what one ``warm_up()`` does, never
cache one kernel for different types, and lock Numba's cache
(:mod:`shellrepair.cachelock`)."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from shellrepair import cachelock, compiled

pytest.importorskip("numba")
pytestmark = pytest.mark.skipif(not compiled.ENABLED, reason="the compiled kernels are off (SHELLREPAIR_NO_NUMBA)")

ROOT = Path(__file__).resolve().parents[1]

_SIGNATURES = """
import json, sys
from shellrepair import compiled, warmup
share = None if sys.argv[1] == "all" else int(sys.argv[1])
assert warmup.warm_up(share) if share else warmup.warm_up()
print(json.dumps({k: sorted(str(s) for s in v.jit.signatures) for m, ks in compiled.REGISTRY.items()
                  if m.endswith("_kernels") for k, v in ks.items() if v.jit is not None and v.jit.signatures}))
"""


def _run(code, *args, env=None):
    env = dict(os.environ if env is None else env)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    p = subprocess.run([sys.executable, "-c", textwrap.dedent(code), *args], cwd=ROOT, env=env,
                       capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, p.stderr[-3000:]
    return json.loads(p.stdout.strip().splitlines()[-1])


@pytest.mark.slow
def test_the_two_shares_make_what_one_warm_up_makes_and_share_no_kernel():
    # each in its own interpreter, as the build runs them. Loaded from the
    # cache the build left, only the kernels called from Python have
    # signatures; where a share compiles (a kernel module changed since
    # the build) the kernels called inside others have theirs too, so the
    # check then covers those as well
    # (the JIT's warm-ups: the build's way where the ahead-of-time build fails)
    env = dict(os.environ, SHELLREPAIR_NO_AOT="1")
    one, two, whole = (_run(_SIGNATURES, a, env=env) for a in ("1", "2", "all"))
    both = sorted(set(one) & set(two))
    assert all(one[k] == two[k] for k in both), {k: (one[k], two[k]) for k in both if one[k] != two[k]}
    assert {"_vf_buckets", "_vf_count", "_vf_scatter"} <= set(both)      # vertex_faces, the same types in both
    missing = {k: v for k, v in whole.items() if not set(v) <= set(one.get(k, [])) | set(two.get(k, []))}
    assert missing == {}, f"warm_up() compiles these, neither share does: {missing}"


@pytest.mark.slow
def test_the_cache_lock_wraps_numbas_load_and_save(tmp_path):
    # a kernel cached in a fresh folder under the lock: the lock file sits
    # beside its index, and a second interpreter loads it from there
    (tmp_path / "twicemod.py").write_text(textwrap.dedent("""
        import numba

        @numba.njit(cache=True)
        def twice(x):
            return 2 * x
        """))
    code = f"""
    import json, sys
    from shellrepair import cachelock
    assert cachelock.install() and cachelock.install()     # idempotent
    from numba.core import caching
    assert caching.IndexDataCacheFile.save.__wrapped__ and caching.IndexDataCacheFile.load.__wrapped__
    sys.path.insert(0, {str(tmp_path)!r})
    from twicemod import twice
    assert twice(21) == 42
    print(json.dumps(sum(twice.stats.cache_hits.values())))
    """
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"))
    assert _run(code, env=env) == 0                                     # compiled and saved
    locks = list((tmp_path / "cache").rglob(cachelock.LOCK_NAME))
    assert len(locks) == 1 and list(locks[0].parent.glob("twicemod.twice-*.nbi"))
    assert _run(code, env=env) == 1                                     # loaded from the cache
