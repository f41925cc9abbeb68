"""``scene.yaml``: reading and writing the scene file (the model is :mod:`gymtrack.scene`).

Paper: the file holds the performance space ``S_perf`` and buffer ``beta`` (Eq. 4), the
vertical plane(s) (Eq. 7), the identification heights (Eq. 13) and the parameters of Section
III-E; validation errors name the file and the offending field. ``Scene``, ``Params``,
``PlaneSpec``, ``TargetSpec`` and ``in_box`` are re-exported here for compatibility.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from ..errors import SceneError
from ..scene import Params, PlaneSpec, Scene, TargetSpec, Vec3, in_box
from .textfile import read_text, what_is

__all__ = [
    "Params", "PlaneSpec", "Scene", "TargetSpec", "Vec3", "in_box",
    "scene_from_dict", "load_scene", "save_scene", "preset_scene",
]


def scene_from_dict(data: Any, source: str | Path = "scene.yaml") -> Scene:
    """Validate a parsed scene mapping; errors name ``source`` and the offending field."""
    if not isinstance(data, dict):
        raise SceneError(f"expected a mapping of keys (apparatus, performance_space, ...), got {what_is(data, 'an empty file')}",
                         source=source)
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        errors = exc.errors()
        field, problem = pydantic_problem(errors[0])
        if problem.startswith("too few values"):  # one message for all the missing items of a list
            same = [e for e in errors if e["type"] == "missing" and [str(p) for p in e["loc"][:-1]] == (field or "").split(".")]
            if len(same) > 1:
                problem = f"too few values: items {int(same[0]['loc'][-1]) + 1} to {int(same[-1]['loc'][-1]) + 1} are missing"
                errors = [e for e in errors if e not in same[1:]]
        more = f" (and {len(errors) - 1} more problem{'s' if len(errors) > 2 else ''})" if len(errors) > 1 else ""
        raise SceneError(f"{problem}{more}", source=source, field=field) from None


def pydantic_problem(e: dict) -> tuple[str | None, str]:
    """(dotted field, problem in the project's words) of one pydantic error: no "Value error, "
    prefix, the offending value named, a missing list item said as such."""
    loc = [str(p) for p in e.get("loc", ())]
    kind, ctx, value = e.get("type", ""), e.get("ctx") or {}, e.get("input")
    msg = str(e.get("msg", ""))
    if kind in ("value_error", "assertion_error"):
        problem = str(ctx.get("error", "")) or msg.split(", ", 1)[-1]
    elif kind == "missing" and loc and loc[-1].isdigit():
        return ".".join(loc[:-1]) or None, f"too few values: item {int(loc[-1]) + 1} is missing"
    elif kind == "missing":
        problem = "required, but missing"
    elif kind == "extra_forbidden":
        problem = "unknown key (check the spelling)"
    elif kind.startswith(("float_", "int_", "bool_")):
        what = {"float": "a number", "int": "a whole number", "bool": "true or false"}[kind.split("_")[0]]
        problem = f"must be {what}, got {what_is(value)}"
    elif kind in ("greater_than", "greater_than_equal", "less_than", "less_than_equal"):
        op = {"greater_than": ">", "greater_than_equal": ">=", "less_than": "<", "less_than_equal": "<="}[kind]
        limit = next(iter(ctx.values()), "")
        problem = f"must be {op} {limit}, got {value!r}"
    else:
        problem = f"{msg[:1].lower()}{msg[1:]}" + ("" if kind.startswith(("too_", "tuple", "list")) else f", got {what_is(value)}")
    return ".".join(loc) or None, problem


def load_scene(path: str | Path) -> Scene:
    """Read and validate a ``scene.yaml``."""
    path = Path(path)
    text = read_text(path, SceneError)
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        line = getattr(getattr(exc, "problem_mark", None), "line", None)
        raise SceneError(f"not valid YAML: {getattr(exc, 'problem', exc)}", source=path, line=None if line is None else line + 1) from None
    return scene_from_dict(data, source=path)


def save_scene(scene: Scene, path: str | Path) -> None:
    """Write ``scene`` as ``scene.yaml`` (keys in the model's order)."""
    Path(path).write_text(yaml.safe_dump(scene.to_yaml_dict(), sort_keys=False))


def preset_scene(apparatus: str, **overrides: Any) -> Scene:
    """The scene of an apparatus preset, with optional overrides (``fps=60``...)."""
    return scene_from_dict({"apparatus": apparatus, **overrides}, source=f"preset {apparatus}")
