"""The flight's count from its take-off position: upright or hanging, or a handstand the body held."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.analysis.contacts import settle_flights
from gymtrack.analysis.flights import G, flight_elements, held_handstand, runs
from gymtrack.analysis.support import FLOOR, NONE, TOUCH
from gymtrack.simulate import elements as gt_elements

FPS = 30.0


def _pommel_like():
    """Circles tilted 75 deg, a press to handstand, a held handstand, a half revolution over to the stand."""
    som = np.concatenate([np.full(15, 75.0), np.linspace(75, 180, 10), np.full(15, 180.0),
                          np.linspace(180, 360, 12)[1:-1], np.full(12, 360.0)])
    incl = np.where(som <= 180, som, 360 - som)
    M = som.size
    rows = {"somersault": som, "inclination": incl, "twist": np.zeros(M), "com_x": np.zeros(M), "com_y": np.zeros(M),
            "com_z": np.full(M, 1.0), "split": np.zeros(M)}
    for side in ("left", "right"):
        rows[f"{side}_hip"] = rows[f"{side}_knee"] = np.full(M, 175.0)
    cols = {k: v[None] for k, v in rows.items()}
    r = np.radians(som)  # A->S in the x-z plane, turning as the somersault
    axis = np.column_stack([np.sin(r), np.zeros(M), np.cos(r)])
    sup = np.full(M, FLOOR)
    sup[40:50] = NONE
    return np.arange(1, M + 1), cols, sup, axis, incl


def test_a_flight_from_a_held_handstand_counts_from_it():
    frame, cols, sup, axis, incl = _pommel_like()
    held = held_handstand(frame, axis, incl, FPS)
    assert held[27:37].all() and not held[:24].any() and not held[40:].any()
    el = flight_elements(frame, cols, sup, FPS, [(40, 49)], held=held)[0]
    assert el["saltos"] == 0.5 and el["rotation_from_position"] == "handstand"
    assert 25 <= el["rotation_from_frame"] - 1 <= 39
    # without the handstand among the take-off positions the circles' tilt is the most upright frame
    el = flight_elements(frame, cols, sup, FPS, [(40, 49)])[0]
    assert el["saltos"] == 0.75 and el["rotation_from_position"] == "upright"


@pytest.mark.parametrize("rate", [0.0, 20.0, 90.0, 200.0])
def test_held_handstand_agrees_with_the_ground_truths_rule(rate):
    """The analysis' and the simulator's rules (two implementations) mark the same frames."""
    n = 40
    ang = np.radians(170.0 + rate / FPS * np.arange(n))
    axis = np.column_stack([np.sin(ang), np.zeros(n), np.cos(ang)])
    incl = np.degrees(np.arccos(np.clip(axis[:, 2], -1, 1)))
    got = held_handstand(np.arange(n), axis, incl, FPS)
    want = gt_elements.held_handstand(axis, incl, FPS)
    assert np.array_equal(got, want)
    assert got.any() == (rate < 45.0)


def test_a_window_frame_without_a_twist_reading_gives_way_to_the_nearest_read_row():
    """The most upright frame before take-off is the poses' first row, whose twist was not read (no
    read row before it to interpolate from): the twist counts from the nearest read row towards the
    flight, where it was None; the half twist in the air is counted, the somersault still from the
    upright frame."""
    M = 40
    incl = np.concatenate([np.full(2, 5.0), np.full(8, 20.0), np.full(20, 30.0), np.full(10, 10.0)])
    twist = np.concatenate([np.full(10, 0.0), np.linspace(0, 180, 20), np.full(10, 180.0)])
    twist[:2] = np.nan  # the first rows: unread
    rows = {"somersault": np.zeros(M), "inclination": incl, "twist": twist, "com_x": np.zeros(M),
            "com_y": np.zeros(M), "com_z": np.full(M, 1.0), "split": np.zeros(M)}
    for side in ("left", "right"):
        rows[f"{side}_hip"] = rows[f"{side}_knee"] = np.full(M, 175.0)
    cols = {k: v[None] for k, v in rows.items()}
    sup = np.full(M, FLOOR)
    sup[10:30] = NONE
    frame = np.arange(100, 100 + M)
    el = flight_elements(frame, cols, sup, FPS, [(10, 29)])[0]
    assert el["rotation_from_frame"] == 101 and el["twist_from_frame"] == 102
    assert el["twists"] == 0.5 and el["saltos"] == 0.0
    # a twist read at the window's frame keeps the window
    cols["twist"][0, :2] = 0.0
    el = flight_elements(frame, cols, sup, FPS, [(10, 29)])[0]
    assert el["twists"] == 0.5 and "twist_from_frame" not in el


def test_a_pikes_straight_knees_are_read_with_the_layouts_noise_allowance():
    """A pike (hips closed to 40 deg, knees straight at 175) whose lower knee the pose stage read
    at 127 deg at the most closed frame, with a 6 deg sd: within 2 sd of 135, still a pike (it read
    "open"); a knee measured at 127 deg with a 1 deg sd is bent, "open"; exact (no sd): the plain rule."""
    from gymtrack.analysis.flights import SHAPES, shape_of

    M = 20
    hip = np.concatenate([np.linspace(170, 40, 10), np.linspace(40, 170, 10)])
    knee = np.full(M, 175.0)
    knee_l = knee.copy()
    knee_l[9] = 127.0  # the most closed frame: one knee read 48 deg bent
    cols = {"left_hip": hip[None], "right_hip": hip[None], "left_knee": knee_l[None], "right_knee": knee[None]}

    def sd(deg):
        return {f"{s}_{j}": np.full(M, deg) for s in ("left", "right") for j in ("hip", "knee")}

    assert SHAPES[shape_of(cols, 0, M - 1, sd(6.0))[0][0]] == "pike"
    assert SHAPES[shape_of(cols, 0, M - 1, sd(1.0))[0][0]] == "open"
    assert SHAPES[shape_of(cols, 0, M - 1)[0][0]] == "open"
    cols["left_knee"] = knee[None]
    assert SHAPES[shape_of(cols, 0, M - 1)[0][0]] == "pike"


def test_a_noisy_flights_shape_is_read_as_held_over_a_sixth_of_a_second():
    """Hips held at 95 deg (open: not under 90) with straight knees, read with +-5 deg of noise and
    one frame at 84: frame by frame the most closed frame is a pike; with an 8 deg sd the angles
    are read as held over 5 frames (30 Hz) and the flight is open; with a 1 deg sd (a marker or
    true skeleton) the single frame still decides."""
    from gymtrack.analysis.flights import SHAPES, held_angles, shape_of

    M = 24
    hip = np.concatenate([np.linspace(170, 95, 6), np.full(12, 95.0), np.linspace(95, 170, 6)])
    hip_read = hip + np.where(np.arange(M) % 2, 5.0, -5.0)
    hip_read[11] = 84.0
    knee = np.full(M, 178.0)
    cols = {"left_hip": hip_read[None], "right_hip": hip_read[None], "left_knee": knee[None], "right_knee": knee[None]}

    def sd(deg):
        return {f"{s}_{j}": np.full(M, deg) for s in ("left", "right") for j in ("hip", "knee")}

    assert SHAPES[shape_of(cols, 0, M - 1)[0][0]] == "pike"
    assert SHAPES[shape_of(cols, 0, M - 1, sd(1.0), fps=30.0)[0][0]] == "pike"
    assert SHAPES[shape_of(cols, 0, M - 1, sd(8.0), fps=30.0)[0][0]] == "open"
    # the held mean: NaN-aware, the ends average the frames the flight has
    x = np.array([[1.0, 2.0, np.nan, 4.0, 5.0]])
    np.testing.assert_allclose(held_angles(x, 3), [[1.5, 1.5, 3.0, 4.5, 4.5]])


def _jump(n_air: int = 9, noise: float = 0.0, seed: int = 0):
    """A jump sampled at FPS: standing rows 0..9, take-off contact at row 10 (the last row on the
    floor, already on the parabola), rows 11..10+n_air airborne, landing contact at the next row,
    then a stop. The joint nearest the floor leaves and meets it with the centre of mass, the contact
    distance of the last approach reached only at the contact row (a short flight: 1.6 m/s at the
    contacts, as hands onto a pommel horse's pommels)."""
    T = (n_air + 1) / FPS
    v0 = G * T / 2  # lands as high as it left
    t = (np.arange(n_air + 2)) / FPS
    z_air = 1.0 + v0 * t - G / 2 * t ** 2  # rows 10 .. 11 + n_air (both contacts on it)
    com = np.concatenate([np.full(10, 1.0), z_air, np.full(10, 1.0)])
    clear = com - 1.0
    rng = np.random.default_rng(seed)
    M = com.size
    com_n = com + rng.normal(0, noise / 3, M)
    clear_n = clear + rng.normal(0, noise, M)
    sup = np.where(clear_n < TOUCH, FLOOR, NONE)
    return np.arange(M), sup, clear_n, np.full(M, max(noise, 0.007)), com_n, np.full(M, max(noise / 3, 0.0025))


def _airborne_run(sup):
    air = np.flatnonzero(sup == NONE)
    return int(air.min()), int(air.max())


def test_a_flights_ends_move_to_the_contacts_through_the_touch_distance():
    """The 0.10 m touch distance reads the body as on the floor for the first and last airborne rows;
    with the joint still leaving or nearing the floor and the centre of mass on the parabola, the
    flight runs from the row after the take-off contact to the row before the landing contact."""
    frame, sup, clear, clear_sd, com, sz = _jump()
    a, b = _airborne_run(sup)
    assert a > 11 and b < 19  # the touch distance alone cuts the flight short at both ends
    fl, sup2, moved = settle_flights(frame, sup, [(a, b)], clear, clear_sd, com, sz, FPS)
    assert fl == [(11, 19)] and moved == (a - 11) + (19 - b)
    assert np.all(sup2[11:20] == NONE) and sup2[10] == FLOOR and sup2[20] == FLOOR


@pytest.mark.parametrize("seed", range(6))
def test_settling_a_noisy_flight_never_takes_a_contact_row(seed):
    """A markerless skeleton's noise (3 cm) hides the last centimetres: the flight may stay short,
    but never reaches into the contacts."""
    frame, sup, clear, clear_sd, com, sz = _jump(noise=0.03, seed=seed)
    a, b = max(runs(sup == NONE, frame, max_gap=1), key=lambda r: r[1] - r[0])
    (a2, b2), = settle_flights(frame, sup, [(a, b)], clear, clear_sd, com, sz, FPS)[0]
    assert 11 <= a2 <= a and b <= b2 <= 19
