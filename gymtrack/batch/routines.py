"""The routines of a batch and the completeness of their output folders.

Paper: none directly; the batch runs the pipeline of Sections III-IV (tracking, the pose stage of
III-D, the metrics of IV-A) over many routine folders. A routine folder is one holding a
``scene.yaml`` (``shared/formats.md``); its outputs go to ``<out>/<routine path relative to the
input>/``.

Completeness: an output folder is complete when it holds the atomic-output marker
(:data:`gymtrack.formats.atomic.MARKER`, written last by
:func:`~gymtrack.formats.atomic.atomic_output`) of a batch run whose ``inputs`` name the steps and
mode asked for (:func:`output_complete`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError
from ..formats.atomic import MARKER, read_marker

__all__ = ["MARKER", "STEPS", "BatchRoutine", "parse_steps", "find_routines", "output_complete", "marker_inputs"]

#: The steps a batch can run, in the order they run.
STEPS: tuple[str, ...] = ("track", "pose", "analyse", "eval")


@dataclass(frozen=True)
class BatchRoutine:
    """One routine of a batch: ``name`` = its path relative to the input (posix), ``path`` its folder."""

    name: str
    path: str


def parse_steps(text: str) -> tuple[str, ...]:
    """``"track,pose,eval"`` -> the steps in pipeline order; InputError naming ``--steps`` when unknown."""
    want = [s.strip() for s in text.replace(" ", ",").split(",") if s.strip()]
    bad = [s for s in want if s not in STEPS]
    if bad or not want:
        raise InputError(f"unknown step {bad[0] if bad else text!r}; choose from {', '.join(STEPS)}", field="--steps")
    return tuple(s for s in STEPS if s in want)


def _is_routine(folder: Path) -> bool:
    return (folder / "scene.yaml").is_file()


def find_routines(source: str | Path) -> list[BatchRoutine]:
    """The routines of a folder (every folder below it holding a ``scene.yaml``, sorted; the folder
    itself when it is one) or of a list file (one routine folder a line, relative to the list's
    folder; blank lines and ``#`` comments skipped).

    Raises InputError naming the file and line of a listed folder that is not a routine.
    """
    source = Path(source)
    if source.is_file():
        out, seen = [], set()
        for k, line in enumerate(source.read_text().splitlines(), start=1):
            text = line.split("#", 1)[0].strip()
            if not text:
                continue
            p = Path(text) if Path(text).is_absolute() else source.parent / text
            if not p.is_dir():
                raise InputError(f"routine folder {text!r} not found", source=source, line=k)
            name = Path(os.path.relpath(p, source.parent)).as_posix()
            if name in seen:
                raise InputError(f"routine {text!r} listed twice", source=source, line=k)
            seen.add(name)
            out.append(BatchRoutine(name, str(p)))
        if not out:
            raise InputError("the list names no routine folder", source=source)
        return out
    if not source.is_dir():
        raise InputError("input not found: give a folder of routines or a list file", source=source)
    if _is_routine(source):
        return [BatchRoutine(source.resolve().name, str(source))]
    found = []
    for root, dirs, _ in os.walk(source):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        r = Path(root)
        if r != source and _is_routine(r):
            found.append(BatchRoutine(r.relative_to(source).as_posix(), str(r)))
            dirs[:] = []  # a routine's own sub-folders (detections/, gt/) are not routines
    if not found:
        raise InputError("no routine folders (a folder with a scene.yaml) below the input", source=source)
    return sorted(found, key=lambda b: b.name)


# ----------------------------------------------------------------------------- completeness
def output_complete(folder: str | Path, steps: tuple[str, ...], mode: str) -> bool:
    """True when ``folder`` holds a complete output of at least ``steps`` in ``mode`` (nothing to redo):
    the atomic-output marker of a batch run with those inputs."""
    m = read_marker(folder)
    if m is None or m.get("command") != "batch":
        return False
    inputs = m.get("inputs") or {}
    done = set(str(inputs.get("steps", "")).split(","))
    return set(steps) <= done and inputs.get("mode") == mode


def marker_inputs(routine: str, steps: tuple[str, ...], mode: str) -> dict:
    """What a batch records in the marker (read back by :func:`output_complete`)."""
    return {"routine": routine, "steps": ",".join(steps), "mode": mode}
