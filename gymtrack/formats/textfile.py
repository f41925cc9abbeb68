"""Reading a user's text file with errors that name it, and writing numbers and CSV tables (shared by
every reader and writer of :mod:`gymtrack.formats`)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Sequence

import numpy as np

from ..errors import InputError


def read_text(path: Path, error: type[InputError] = InputError) -> str:
    """The UTF-8 text of ``path``; a missing file, a folder or undecodable bytes raise ``error``
    naming the file."""
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise error("file not found", source=path) from None
    except IsADirectoryError:
        raise error("is a folder, expected a file", source=path) from None
    except UnicodeDecodeError:
        raise error("not UTF-8 text", source=path) from None


def what_is(value, empty: str = "nothing") -> str:
    """A value's kind in a user's words (``"a list"``, ``"the text 'abc'"``), for messages that
    would otherwise say ``got NoneType``; ``empty`` is what None (an empty file or field) reads as."""
    if value is None:
        return empty
    if isinstance(value, bool):
        return f"the boolean {value}"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the text {value[:40]!r}"
    if isinstance(value, (list, tuple)):
        return f"a list of {len(value)} item{'s' if len(value) != 1 else ''}"
    if isinstance(value, dict):
        return "a mapping"
    return f"a value of type {type(value).__name__}"


def fixed(values, digits: int) -> list[str]:
    """(N,) numbers as text with ``digits`` decimals, "" where not finite (a missing value); one pass
    over Python floats (per-value numpy calls cost more on the writers' long columns)."""
    return ["" if x != x or x in (float("inf"), float("-inf")) else f"{x:.{digits}f}"
            for x in np.asarray(values, dtype=np.float64).tolist()]


def write_csv(path: Path, header: Sequence[str], columns: Sequence[Sequence]) -> Path:
    """Write a CSV table of equal-length columns under ``header`` (folders created); returns the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(header)
        w.writerows(zip(*columns))
    return path
