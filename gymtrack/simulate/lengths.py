"""How long a simulated routine may be: what each apparatus's routine needs, and what memory allows.

Paper: Section IV's seven apparatus. A vault is one run-up, the vault and its landing: 5-7 s in
competition, so a vault routine may be as short as 5 s (shorter than 10 s it is one vault from
the start of its run-up, :mod:`.skills.vault`). The other apparatus's routines start with the
gymnast walking in, saluting and mounting; a routine must leave at least
:data:`PERFORMANCE_SECONDS` of performance after that (the frames the target is identified and
scored on), which :data:`ROUTINE_NEEDS` gives per apparatus: the longest entry over twelve seeds,
plus 2 s of performance, plus a margin of 1 s. A shorter routine is cut before the target
performs; the error says what the apparatus needs.

The longest routine is one hour (a session streamed for the soak benchmark), as far as memory
allows: the simulator holds every person's joints for every frame, about
:data:`BYTES_PER_SECOND` per simulated second, and refuses a length whose estimate exceeds the
memory available, saying how much it needs.
"""

from __future__ import annotations

import os

from ..errors import InputError

__all__ = ["ROUTINE_NEEDS", "MIN_SECONDS", "MAX_SECONDS", "PERFORMANCE_SECONDS", "BYTES_PER_SECOND",
           "check_seconds", "memory_needed"]

#: Seconds of performance a routine must hold after the gymnast's entry (walk in, salute, mount).
PERFORMANCE_SECONDS = 2.0

#: Shortest routine per apparatus (s) and what it is made of (said by the error).
ROUTINE_NEEDS: dict[str, tuple[float, str]] = {
    "vault": (5.0, "a run-up of at least 5 m, the vault and its landing"),
    "balance_beam": (6.0, "walking in, the salute, the mount and 2 s of performance"),
    "pommel_horse": (6.0, "walking in, the salute, the mount and 2 s of performance"),
    "parallel_bars": (6.0, "walking in, the salute, the mount and 2 s of performance"),
    "uneven_bars": (7.0, "walking in, the salute, the mount and 2 s of performance"),
    "still_rings": (8.0, "walking in, the salute, being lifted to the rings and 2 s of performance"),
    "horizontal_bar": (8.5, "walking in, the salute, being lifted to the bar and 2 s of performance"),
}

#: The shortest routine of any apparatus, and the longest (one hour).
MIN_SECONDS = min(v[0] for v in ROUTINE_NEEDS.values())
MAX_SECONDS = 3600.0

#: Peak memory of the simulator per simulated second (measured: 600 s of uneven bars, 4 cameras: 4.6 GB).
BYTES_PER_SECOND = 7.7e6


def memory_needed(seconds: float) -> float:
    """Estimated peak memory (bytes) of simulating ``seconds``."""
    return 0.3e9 + BYTES_PER_SECOND * float(seconds)


def _available_memory() -> float | None:
    """Bytes of memory available now (Linux ``MemAvailable``), or None where unknown."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return None


def check_seconds(apparatus: str, seconds: float) -> float:
    """``seconds`` when a routine of ``apparatus`` can be that long; InputError saying why not."""
    need, what = ROUTINE_NEEDS[apparatus]
    if not seconds >= need:  # also NaN
        raise InputError(f"a {apparatus} routine needs at least {need:g} s ({what}), got {seconds:g}", field="seconds")
    if seconds > MAX_SECONDS:
        raise InputError(f"seconds must be at most {MAX_SECONDS:g} (one hour), got {seconds:g}", field="seconds")
    avail = _available_memory()
    if avail is not None and memory_needed(seconds) > avail:
        raise InputError(f"simulating {seconds:g} s needs about {memory_needed(seconds) / 1e9:.1f} GB of memory "
                         f"(every person's joints for every frame); {avail / 1e9:.1f} GB are available", field="seconds")
    return float(seconds)
