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
from .textfile import read_text

__all__ = [
    "Params", "PlaneSpec", "Scene", "TargetSpec", "Vec3", "in_box",
    "scene_from_dict", "load_scene", "save_scene", "preset_scene",
]


def scene_from_dict(data: Any, source: str | Path = "scene.yaml") -> Scene:
    """Validate a parsed scene mapping; errors name ``source`` and the offending field."""
    if not isinstance(data, dict):
        raise SceneError(f"expected a mapping of keys, got {type(data).__name__}", source=source)
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        loc = ".".join(str(p) for p in e["loc"]) or None
        more = f" (and {len(exc.errors()) - 1} more problems)" if len(exc.errors()) > 1 else ""
        raise SceneError(f"{e['msg']}{more}", source=source, field=loc) from None


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
