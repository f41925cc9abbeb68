"""scene.yaml validation and the FIG apparatus presets."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.apparatus import APPARATUS_NAMES, PRESETS, get_apparatus
from gymtrack.errors import SceneError
from gymtrack.formats.scene import Params, load_scene, preset_scene, save_scene, scene_from_dict


def _bar_heights(name):
    return sorted({round(b.start[2], 3) for b in get_apparatus(name).bars})


def test_fig_dimensions():
    beam = get_apparatus("balance_beam").bars[0]
    assert np.linalg.norm(np.subtract(beam.end, beam.start)) == pytest.approx(5.0)
    assert beam.start[2] == pytest.approx(1.25)
    assert _bar_heights("horizontal_bar") == [2.8]
    hb = get_apparatus("horizontal_bar").bars[0]
    assert np.linalg.norm(np.subtract(hb.end, hb.start)) == pytest.approx(2.4)
    assert _bar_heights("uneven_bars") == [1.7, 2.5]
    low, high = get_apparatus("uneven_bars").bars
    diagonal = np.hypot(high.start[1] - low.start[1], high.start[2] - low.start[2])
    assert 1.3 <= diagonal <= 1.8
    assert _bar_heights("parallel_bars") == [2.0]
    rails = get_apparatus("parallel_bars").bars
    assert 0.42 <= abs(rails[0].start[1] - rails[1].start[1]) <= 0.52
    assert np.linalg.norm(np.subtract(rails[0].end, rails[0].start)) == pytest.approx(3.5)
    rings = get_apparatus("still_rings").bars
    assert abs(rings[0].start[0] - rings[1].start[0]) == pytest.approx(0.5)
    assert rings[0].start[2] == pytest.approx(2.8)
    horse = get_apparatus("pommel_horse")
    assert horse.blocks[0].hi[0] - horse.blocks[0].lo[0] == pytest.approx(1.6)
    assert max(b.start[2] for b in horse.bars) == pytest.approx(1.15)
    vault = get_apparatus("vault")
    assert vault.blocks[0].hi[2] == pytest.approx(1.35)
    assert vault.performance_space[0] <= -25.0  # the 25 m run-up is inside the performance space


@pytest.mark.parametrize("name", APPARATUS_NAMES)
def test_presets_give_a_valid_scene(name):
    scene = preset_scene(name)
    app = PRESETS[name]
    assert scene.apparatus == name
    assert len(scene.planes) == 1
    normal = np.array(scene.planes[0].normal)
    assert normal[2] == 0, "the gymnast's plane is vertical"
    # along-axis apparatus: plane contains the x axis; across-axis: plane is perpendicular to x
    assert abs(normal[1] if app.along_axis else normal[0]) == pytest.approx(1.0)
    # every bar (or beam) centre lies inside the performance space
    lo, hi = np.array(scene.performance_space[:3]), np.array(scene.performance_space[3:])
    for bar in app.bars:
        mid = (np.array(bar.start) + np.array(bar.end)) / 2
        assert np.all(mid >= lo) and np.all(mid <= hi)
    # the paper's defaults, but the preset's body box across the plane (Eq. 14)
    assert scene.params == Params(body_half_depth=app.body_half_depth)


def test_tracking_space_grows_only_in_x_and_y():
    scene = preset_scene("balance_beam", buffer=0.5)
    s, t = np.array(scene.performance_space), scene.tracking_space
    np.testing.assert_allclose(t - s, [-0.5, -0.5, 0, 0.5, 0.5, 0])


def test_file_overrides_preset(tmp_path):
    p = tmp_path / "scene.yaml"
    p.write_text("apparatus: uneven_bars\nfps: 60\ntarget:\n  h_top: 2.2\nparams:\n  window: 12\n")
    scene = load_scene(p)
    assert scene.fps == 60 and scene.params.window == 12 and scene.params.step == 6
    assert scene.target.h_top == 2.2
    assert scene.target.h_bot == PRESETS["uneven_bars"].h_bot  # the preset still fills the rest


def test_round_trip(tmp_path):
    scene = preset_scene("vault")
    save_scene(scene, tmp_path / "scene.yaml")
    assert load_scene(tmp_path / "scene.yaml") == scene


@pytest.mark.parametrize(
    "data, field",
    [
        ({"apparatus": "trampoline"}, None),
        ({"performance_space": [0, 0, 0, -1, 1, 1]}, "performance_space"),
        ({"apparatus": "vault", "params": {"iou_threshold": 1.5}}, "params.iou_threshold"),
        ({"apparatus": "vault", "params": {"windw": 10}}, "params.windw"),
        ({"apparatus": "vault", "planes": [{"point": [0, 0, 0], "normal": [0, 0, 0]}]}, "planes.0.normal"),
        ({"apparatus": "vault", "fps": -30}, "fps"),
        ({"apparatus": "vault", "focus": [0, float("nan"), 1.5]}, "focus"),
        ({"apparatus": "vault", "focus": [0, 1]}, "focus"),  # "too few values: item 3 is missing"
        ({"apparatus": "vault", "params": {"relink_frames": -1}}, "params.relink_frames"),
        ({"apparatus": "vault", "params": {"window": 10, "min_tracklet_boxes": 11}}, "params"),
    ],
)
def test_invalid_scenes_name_the_field(data, field):
    with pytest.raises(SceneError) as exc:
        scene_from_dict(data, source="my/scene.yaml")
    msg = str(exc.value)
    assert "my/scene.yaml" in msg
    if field:
        assert f"'{field}'" in msg
    if data.get("apparatus") == "trampoline":
        assert "balance_beam" in msg  # lists the valid names
    assert "Value error" not in msg and "NoneType" not in msg  # pydantic's wording does not leak
    if data.get("focus") == [0, 1]:
        assert "item 3 is missing" in msg


def test_yaml_syntax_error_names_the_line(tmp_path):
    p = tmp_path / "scene.yaml"
    p.write_text("apparatus: vault\nparams: [window: 10\n")
    with pytest.raises(SceneError) as exc:
        load_scene(p)
    assert str(p) in str(exc.value) and "line" in str(exc.value)


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="not found"):
        load_scene(tmp_path / "nope.yaml")
