"""Run the Ctrl-C test ten times in a row, with the default numba cache and with NUMBA_CACHE_DIR set.

Not a test (pytest does not collect it): ``python tests/loop_ctrl_c.py [N]``. Each round runs
``test_ctrl_c_one_line_exit_130_nothing_half_written`` (a Ctrl-C during the imports, while the
routine is read and the kernels load from the cache, and while numba compiles into a fresh
NUMBA_CACHE_DIR); the second setting also sets NUMBA_CACHE_DIR (warm after its first round) for
the whole run. Prints one line per round and exits 1 if any failed (with its output).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main(n: int = 10) -> int:
    cache = Path(tempfile.gettempdir()) / "gymtrack-loop-numba-cache"
    settings = {"default cache": {}, f"NUMBA_CACHE_DIR={cache}": {"NUMBA_CACHE_DIR": str(cache)}}
    failed = 0
    for name, extra in settings.items():
        env = {**os.environ, **extra, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        for k in range(1, n + 1):
            t0 = time.perf_counter()
            p = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "tests/test_cli_outputs.py",
                                "-k", "ctrl_c"], cwd=REPO, env=env, capture_output=True, text=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
            last = (p.stdout.strip().splitlines() or ["?"])[-1]
            print(f"{name:>40} round {k:2d}: {last} ({time.perf_counter() - t0:.0f} s)", flush=True)
            if p.returncode:
                failed += 1
                print(p.stdout[-12000:], p.stderr[-2000:])
    print(f"{failed} failed rounds of {2 * n}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(int(sys.argv[1]) if len(sys.argv) > 1 else 10))
