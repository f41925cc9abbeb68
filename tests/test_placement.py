"""The apparatus preset laid on a scene (gymtrack.placement): in the presets' own frame, and in a
venue's frame where the scene says where the apparatus is (docs/your-own-data.md, Option 2)."""

from __future__ import annotations

import numpy as np

from gymtrack.apparatus import BEAM_HEIGHT, BEAM_LENGTH
from gymtrack.formats.scene import preset_scene
from gymtrack.placement import apparatus_distance, scene_geometry
from gymtrack.scene import PlaneSpec


def test_a_preset_scene_keeps_the_presets_frame():
    geo = scene_geometry(preset_scene("balance_beam"))
    h = BEAM_LENGTH / 2
    assert np.allclose(geo.bar_a, [[-h, 0, BEAM_HEIGHT]]) and np.allclose(geo.bar_b, [[h, 0, BEAM_HEIGHT]])


def test_a_beam_written_in_the_venues_frame_lies_where_the_scene_says():
    """The guide's example: a beam centred at (12.4, 3.1), running along y (plane x = 12.4,
    focus over the centre). Its top edge runs from y = 3.1 - 2.5 to 3.1 + 2.5 at x = 12.4; a point
    on the beam is on it, and one at the preset's place (the origin) is 12 m away."""
    scene = preset_scene("balance_beam", planes=[PlaneSpec(point=(12.4, 3.1, 0.0), normal=(1.0, 0.0, 0.0))],
                         focus=(12.4, 3.1, 1.5))
    geo = scene_geometry(scene)
    ends = np.sort(np.r_[geo.bar_a, geo.bar_b][:, 1])
    h = BEAM_LENGTH / 2
    assert np.allclose(ends, [3.1 - h, 3.1 + h]) and np.allclose(np.r_[geo.bar_a, geo.bar_b][:, [0, 2]], [12.4, BEAM_HEIGHT])
    on, origin = np.array([[12.4, 4.5, BEAM_HEIGHT + 0.01]]), np.array([[0.0, 0.0, BEAM_HEIGHT]])
    assert apparatus_distance(on, geo)[0] < 0.02 and apparatus_distance(origin, geo)[0] > 11.0
