"""``analysis/angles.csv`` and ``elements.json``: the analysis stage's files (``shared/formats.md``,
"Outputs of the analysis stage"; the simulator's ``gt/elements.json`` has the same form).

Paper: Section III-D, last paragraph and Fig. 8 -- the target's 3D pose sequence is segmented and
measured against the Code of Points for the judges; these are that measurement's file forms.

``elements.json``::

    {"track_id": 3, "fps": 30, "apparatus": "horizontal_bar",
     "elements": [{"kind": "flight", "start_frame": 812, "end_frame": 838, ...}, ...],
     "missing": {"landing": "no floor geometry in the scene"}}

gymtrack's additions to the contract, all optional when read:

- ``<measure>_sd`` beside any numeric measure: one standard deviation, propagated from the pose
  stage's per-joint errors (``14.0`` with ``deviation_sd: 3.0`` reads "14 +- 3 deg").
- ``missing`` on the file (a whole kind or measure that could not be computed) and on an element
  (one of its fields): ``{name: reason}``; such a field is ``null``, never guessed.
- ``airborne_somersault_deg`` / ``airborne_twist_deg`` on a flight (the rotation while airborne).
- ``source`` on the file: ``"analysis"`` or ``"ground truth"``; ``version``.

Element records stay plain dicts (the JSON objects), validated here per kind with pydantic, so the
simulator, the analysis stage and the scorer share one definition without importing each other.
"""

from __future__ import annotations

import csv
import io
import json
import math
from pathlib import Path
from typing import Any, Iterable, Literal, Mapping, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import InputError
from .textfile import fixed, read_text, write_csv

__all__ = ["ELEMENT_KINDS", "ANGLES_COLUMNS", "ANGLE_MEASURES", "SUPPORT_NAMES", "validate_elements", "read_elements",
           "write_elements", "read_angles", "write_angles"]

#: the element kinds of the contract, in the order the element table lists them
ELEMENT_KINDS: tuple[str, ...] = ("flight", "landing", "hold", "circle", "turn")
#: ``support`` values of angles.csv
SUPPORT_NAMES: tuple[str, ...] = ("none", "floor", "apparatus")
#: the contract's angles.csv columns, in order (extra columns may follow)
ANGLES_COLUMNS: tuple[str, ...] = (
    "frame", "track_id", "com_x", "com_y", "com_z", "support", "left_knee", "right_knee", "left_hip", "right_hip",
    "left_elbow", "right_elbow", "left_shoulder", "right_shoulder", "split", "inclination", "somersault", "twist")
#: the angle columns (degrees) of angles.csv
ANGLE_MEASURES: tuple[str, ...] = ANGLES_COLUMNS[6:]

Num = float | None


class _Element(BaseModel):
    model_config = ConfigDict(extra="allow")  # *_sd fields and anything a later version adds
    missing: dict[str, str] = Field(default_factory=dict)


class _Span(_Element):
    start_frame: int
    end_frame: int

    def model_post_init(self, _ctx: Any) -> None:
        if self.end_frame < self.start_frame:
            raise ValueError(f"end_frame {self.end_frame} is before start_frame {self.start_frame}")


class Flight(_Span):
    kind: Literal["flight"]
    duration_s: Num = None
    apex_z: Num = None
    height_gain: Num = None
    distance: Num = None
    somersault_deg: Num = None
    saltos: Num = None
    twist_deg: Num = None
    twists: Num = None
    shape: Literal["tuck", "pike", "layout", "open"] | None = None
    min_hip: Num = None
    min_knee: Num = None
    max_split: Num = None


class Landing(_Element):
    kind: Literal["landing"]
    frame: int
    steps: int | None = None
    largest_step: Num = None
    stuck: bool | None = None


class Hold(_Span):
    kind: Literal["hold"]
    duration_s: Num = None
    position: Literal["handstand", "horizontal", "upright", "other"] | None = None
    deviation: Num = None


class Circle(_Span):
    kind: Literal["circle"]
    turns: int = 1


class Turn(_Span):
    kind: Literal["turn"]
    degrees: Num = None


_MODELS: dict[str, type[_Element]] = {"flight": Flight, "landing": Landing, "hold": Hold, "circle": Circle, "turn": Turn}


class ElementsFile(BaseModel):
    model_config = ConfigDict(extra="allow")
    track_id: int | None = None
    fps: float = Field(gt=0)
    apparatus: str | None = None
    elements: list[dict[str, Any]]
    missing: dict[str, str] = Field(default_factory=dict)


def _clean(v: Any) -> Any:
    """numpy scalars to Python, NaN to None (JSON has no NaN)."""
    if isinstance(v, dict):
        return {str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_clean(x) for x in v]
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, float) and not math.isfinite(v):
        return None
    return v


def validate_elements(data: Mapping[str, Any], source: str | Path = "elements.json") -> dict[str, Any]:
    """Check an elements document against the contract; returns it as plain JSON types.

    Raises InputError naming the source and the field (``elements[3].end_frame``) that is wrong.
    """
    data = _clean(dict(data))
    try:
        ElementsFile.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        raise InputError(e["msg"], source=source, field=".".join(str(x) for x in e["loc"]) or None) from None
    for i, el in enumerate(data["elements"]):
        kind = el.get("kind") if isinstance(el, dict) else None
        if kind not in _MODELS:
            raise InputError(f"kind must be one of {', '.join(ELEMENT_KINDS)}, got {kind!r}", source=source,
                             field=f"elements[{i}].kind")
        try:
            _MODELS[kind].model_validate(el)
        except ValidationError as exc:
            e = exc.errors()[0]
            loc = ".".join(str(x) for x in e["loc"])
            raise InputError(e["msg"], source=source, field=f"elements[{i}]" + (f".{loc}" if loc else "")) from None
    return data


def write_elements(path: str | Path, data: Mapping[str, Any]) -> Path:
    """Validate and write an elements document (elements sorted by their first frame); returns the path."""
    path = Path(path)
    data = validate_elements(data, source=path)
    data["elements"] = sorted(data["elements"], key=lambda e: (e.get("start_frame", e.get("frame")),
                                                              ELEMENT_KINDS.index(e["kind"])))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1) + "\n")
    return path


def read_elements(path: str | Path) -> dict[str, Any]:
    """Read and validate ``elements.json`` (the analysis stage's or the simulator's ``gt/elements.json``)."""
    path = Path(path)
    try:
        data = json.loads(read_text(path))
    except json.JSONDecodeError as exc:
        raise InputError(f"not JSON: {exc.msg}", source=path, line=exc.lineno) from None
    if not isinstance(data, dict):
        raise InputError("expected a JSON object with track_id, fps, apparatus and elements", source=path)
    return validate_elements(data, source=path)


# ------------------------------------------------------------------ angles.csv
def write_angles(path: str | Path, columns: Mapping[str, Sequence]) -> Path:
    """Write ``angles.csv`` from named columns: every contract column (``ANGLES_COLUMNS``), then any
    extra ones in the order given. ``support`` as names (``SUPPORT_NAMES``) or codes; metres with 4
    decimals, degrees with 2; NaN is an empty cell (a measure that could not be computed)."""
    path = Path(path)
    missing = [c for c in ANGLES_COLUMNS if c not in columns]
    if missing:
        raise ValueError(f"angles.csv needs the columns {', '.join(missing)}")
    names = list(ANGLES_COLUMNS) + [c for c in columns if c not in ANGLES_COLUMNS]
    n = len(columns["frame"])
    cells = []
    for c in names:
        v = columns[c]
        if c in ("frame", "track_id"):
            cells.append(np.asarray(v, np.int64).tolist())
        elif c == "support":
            a = np.asarray(v)
            cells.append(a.tolist() if a.dtype.kind in "US" or a.dtype == object else np.asarray(SUPPORT_NAMES)[a.astype(int)].tolist())
        else:
            a = np.asarray(v)
            cells.append(a.tolist() if a.dtype.kind in "US" or a.dtype == object
                         else np.asarray(a, np.int64).tolist() if a.dtype.kind in "iub"
                         else fixed(a, 4 if c.startswith("com") else 2))
        if len(cells[-1]) != n:
            raise ValueError(f"angles.csv column {c!r} has {len(cells[-1])} rows, frame has {n}")
    return write_csv(path, names, cells)


def read_angles(path: str | Path) -> dict[str, np.ndarray]:
    """Read ``angles.csv``: column name -> array (frame, track_id int64; support str; the rest float,
    NaN where empty; an extra column that is not numeric stays str)."""
    path = Path(path)
    rows = list(csv.reader(io.StringIO(read_text(path), newline="")))
    if not rows or tuple(rows[0][:len(ANGLES_COLUMNS)]) != ANGLES_COLUMNS:
        raise InputError(f"expected the header {','.join(ANGLES_COLUMNS)} (extra columns may follow)", source=path, line=1)
    header, body = rows[0], rows[1:]
    for i, r in enumerate(body):
        if len(r) != len(header):
            raise InputError(f"expected {len(header)} values, got {len(r)}", source=path, line=i + 2)
    out: dict[str, np.ndarray] = {}
    for k, name in enumerate(header):
        col = [r[k] for r in body]
        if name == "support":
            bad = [i for i, s in enumerate(col) if s not in SUPPORT_NAMES]
            if bad:
                raise InputError(f"support must be one of {', '.join(SUPPORT_NAMES)}, got {col[bad[0]]!r}", source=path,
                                 line=bad[0] + 2, field="support")
            out[name] = np.asarray(col, dtype=str)
            continue
        try:
            vals = np.array([float(s) if s != "" else np.nan for s in col], float)
        except ValueError:
            if name in ANGLES_COLUMNS:
                i = next(i for i, s in enumerate(col) if not _is_num(s))
                raise InputError(f"{name} must be a number, got {col[i]!r}", source=path, line=i + 2, field=name) from None
            out[name] = np.asarray(col, dtype=str)
            continue
        if name in ("frame", "track_id"):
            if not np.all(np.isfinite(vals)) or np.any(vals != np.round(vals)):
                i = int(np.flatnonzero(~np.isfinite(vals) | (vals != np.round(vals)))[0])
                raise InputError(f"{name} must be a whole number", source=path, line=i + 2, field=name)
            vals = vals.astype(np.int64)
        out[name] = vals
    return out


def _is_num(s: str) -> bool:
    try:
        float(s)
        return True
    except ValueError:
        return s == ""


def element_rows(data: Mapping[str, Any], kinds: Iterable[str] = ELEMENT_KINDS) -> list[dict[str, Any]]:
    """The elements of the given kinds, in frame order (a small helper for tables and scoring)."""
    kinds = tuple(kinds)
    els = [e for e in data["elements"] if e["kind"] in kinds]
    return sorted(els, key=lambda e: e.get("start_frame", e.get("frame")))
