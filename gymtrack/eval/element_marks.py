"""The analysis stage's elements where people look at a routine: captions on the overlay's frames and
entries on the Rerun viewer's frame timeline.

Paper: Section III-D, last paragraph and Fig. 8 (the pose sequence segmented into what the judges
measure), shown beside the tracking it comes from. Reads ``<out>/analysis/elements.json``
(``shared/formats.md``, "Outputs of the analysis stage"); nothing is drawn where it is absent.

* :func:`element_events` -- one entry at each element's first and last frame (a landing: its frame):
  what the element was (``flight 1: 1 salto, 0.5 twist, tuck, 0.80 s, apex 1.82 m``).
* :class:`ElementMarks` -- per frame, the elements going on and a caption for each: a flight's counts
  and its time in the air so far, the hold timer (``0.62 / 1.02 s``), a landing's steps for the
  first second after contact, the circle's number, the turn's degrees.

A measure that is null reads ``?`` (its reason is in the report and elements.json).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from ..analysis.report import KIND_COLOURS
from ..formats.elements import ELEMENT_KINDS, read_elements

LANDING_SHOWN_S = 1.0  # how long a landing's caption stays on after contact


def kind_bgr(kind: str) -> tuple[int, int, int]:
    """The element kind's colour (the routine sheet's) as OpenCV BGR."""
    h = KIND_COLOURS[kind].lstrip("#")
    r, g, b = (int(h[i:i + 2], 16) for i in (0, 2, 4))
    return b, g, r


def read_analysis_elements(out: str | Path) -> dict[str, Any] | None:
    """``<out>/analysis/elements.json`` read and validated, or None where the analysis has not run."""
    path = Path(out) / "analysis" / "elements.json"
    return read_elements(path) if path.is_file() else None


def _count(v: Any, word: str) -> str:
    if v is None:
        return f"? {word}s"
    return f"{v:g} {word}" + ("" if v == 1 or 0 < v < 1 else "s")


def _num(v: Any, fmt: str, unit: str = "") -> str:
    return "?" if v is None else f"{v:{fmt}}{unit}"


def _sd(el: Mapping[str, Any], name: str, fmt: str, unit: str) -> str:
    s = _num(el.get(name), fmt)
    sd = el.get(f"{name}_sd")
    return s + (f" ± {sd:{fmt}}" if sd is not None and el.get(name) is not None else "") + unit


def element_title(el: Mapping[str, Any], n: int) -> str:
    """A one-line summary of element ``el``, the ``n``-th of its kind."""
    k = el["kind"]
    if k == "flight":
        parts = [_count(el.get("saltos"), "salto"), _count(el.get("twists"), "twist"), el.get("shape") or "? shape",
                 _num(el.get("duration_s"), ".2f", " s"), "apex " + _sd(el, "apex_z", ".2f", " m")]
    elif k == "landing":
        steps = el.get("steps")
        parts = ["stuck" if el.get("stuck") else (f"{_count(steps, 'step')}" + (
            f" (largest {el['largest_step']:.2f} m)" if el.get("largest_step") is not None else ""))]
    elif k == "hold":
        parts = [el.get("position") or "? position", _num(el.get("duration_s"), ".2f", " s"),
                 "deviation " + _sd(el, "deviation", ".1f", "°")]
    elif k == "circle":
        parts = [_count(el.get("turns"), "turn")]
    else:
        parts = [_num(el.get("degrees"), ".0f", "°")]
    return f"{k} {n}: " + ", ".join(parts)


def element_events(doc: Mapping[str, Any]) -> tuple[np.ndarray, list[str], list[str]]:
    """(frame (N,), text, kind) of the timeline's entries: each element's start ("flight 1: ...") and,
    for spans, its end ("flight 1 ends"), in frame order."""
    frames, texts, kinds = [], [], []
    seen = dict.fromkeys(ELEMENT_KINDS, 0)
    for el in sorted(doc["elements"], key=lambda e: e.get("start_frame", e.get("frame"))):
        k = el["kind"]
        seen[k] += 1
        frames.append(el.get("start_frame", el.get("frame")))
        texts.append(element_title(el, seen[k]))
        kinds.append(k)
        if "end_frame" in el:
            frames.append(el["end_frame"])
            texts.append(f"{k} {seen[k]} ends")
            kinds.append(k)
    order = np.argsort(np.asarray(frames, np.int64), kind="stable")
    return np.asarray(frames, np.int64)[order], [texts[i] for i in order], [kinds[i] for i in order]


@dataclass(frozen=True, eq=False)
class ElementMarks:
    """The elements of one ``elements.json`` as spans of frames, looked up per frame.

    Attributes: ``start``, ``end`` (E,) int64 the frames each is shown (a landing: its frame and
    the next ``LANDING_SHOWN_S``); ``number`` (E,) its number within its kind; ``elements`` the records.
    """

    elements: list[dict[str, Any]]
    start: np.ndarray
    end: np.ndarray
    number: np.ndarray
    fps: float

    @classmethod
    def from_doc(cls, doc: Mapping[str, Any]) -> "ElementMarks":
        fps = float(doc["fps"])
        els = sorted(doc["elements"], key=lambda e: e.get("start_frame", e.get("frame")))
        start = np.array([e.get("start_frame", e.get("frame")) for e in els], np.int64)
        shown = int(round(LANDING_SHOWN_S * fps))
        end = np.array([e["end_frame"] if "end_frame" in e else e["frame"] + shown - 1 for e in els], np.int64)
        seen = dict.fromkeys(ELEMENT_KINDS, 0)
        number = []
        for e in els:
            seen[e["kind"]] += 1
            number.append(seen[e["kind"]])
        return cls(els, start, end, np.asarray(number, np.int64), fps)

    def at(self, frame: int) -> list[tuple[str, str]]:
        """(kind, caption) of every element going on at ``frame``, in frame order."""
        rows = np.flatnonzero((self.start <= frame) & (frame <= self.end))
        return [(self.elements[i]["kind"], self.caption(i, frame)) for i in rows.tolist()]

    def caption(self, i: int, frame: int) -> str:
        """What to show of element ``i`` at ``frame``: its counts, and the time into it."""
        el, n = self.elements[i], int(self.number[i])
        k = el["kind"]
        into = (frame - int(self.start[i]) + 1) / self.fps
        if k == "flight":
            return (f"flight {n}  {_count(el.get('saltos'), 'salto')} · {_count(el.get('twists'), 'twist')} · "
                    f"{el.get('shape') or '?'}  {into:.2f} s")
        if k == "hold":
            total = el.get("duration_s")
            return (f"hold {n}  {el.get('position') or '?'}  {into:.2f} / {_num(total, '.2f')} s  "
                    f"dev {_sd(el, 'deviation', '.1f', '°')}")  # the timer: time held so far / the hold's duration
        return element_title(el, n).replace(":", " ", 1).replace(",", " ·")

    def per_frame(self, frames: np.ndarray) -> list[str]:
        """The captions of each of ``frames`` joined by newlines ("" where nothing is going on)."""
        return ["\n".join(t for _, t in self.at(int(f))) for f in np.asarray(frames, np.int64)]
