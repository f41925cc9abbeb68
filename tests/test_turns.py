"""The contract's circle count (gymtrack.turns.full_turns) on hand-worked angle series."""

import numpy as np

from gymtrack.turns import full_turns


def test_two_giants_one_direction_are_two_turns():
    # 20 deg a frame, rows 0..36: 720 deg. A turn ends at the first row with progress >= 360 k - 10:
    # row 18 (360; row 17 has 340), then row 36 (720; row 35 has 700), counted from row 0.
    s = 20.0 * np.arange(37)
    got = full_turns(s, np.arange(37), fps=30.0)
    assert got == [(0, 18, 1), (19, 36, 1)]


def test_a_swing_back_starts_a_new_count_and_the_direction_is_kept():
    # forward 300 deg (not a turn), then backward 400 deg: one backward turn counted from the turning point
    fwd = 10.0 * np.arange(31)                   # rows 0..30, 0 -> 300
    back = 300.0 - 10.0 * np.arange(1, 41)        # rows 31..70, 290 -> -100
    s = np.concatenate([fwd, back])
    got = full_turns(s, np.arange(len(s)), fps=30.0)
    assert len(got) == 1
    start, end, d = got[0]
    assert d == -1
    assert start == 30  # counted from the turning point (300 deg)
    assert s[start] - s[end] >= 350.0 and s[start] - s[end - 1] < 350.0


def test_a_sway_back_under_the_threshold_keeps_the_count():
    # a giant, a 12 deg sway back in the handstand (a measured skeleton's noise), then on: two turns
    # counted from row 0; a 30 deg return is a swing's turning point and restarts the count there
    a = 20.0 * np.arange(10)                        # 0 .. 180
    sway = np.array([174.0, 168.0, 174.0, 180.0])   # 12 deg back and forth
    b = 180.0 + 20.0 * np.arange(1, 28)             # 200 .. 720
    got = full_turns(np.concatenate([a, sway, b]), np.arange(41), fps=30.0)
    assert [(s, d) for s, _, d in got] == [(0, 1), (got[0][1] + 1, 1)] and len(got) == 2
    swing = np.array([170.0, 160.0, 150.0, 160.0, 170.0, 180.0])  # 30 deg back: a turning point at row 9
    got = full_turns(np.concatenate([a, swing, b]), np.arange(43), fps=30.0)
    assert got[0][0] == 12 and len(got) == 1  # from the lowest point (150 deg) on: 150 -> 720 is one turn


def test_a_slow_turn_is_no_circle_and_a_pause_keeps_direction():
    slow = np.linspace(0.0, 360.0, 200)  # 1.8 deg a frame over 6.6 s at 30 fps: a press, not a swing
    assert full_turns(slow, np.arange(200), fps=30.0) == []
    # a pause (rate under 0.5 deg a frame) inside a giant does not cut it
    s = np.concatenate([20.0 * np.arange(10), np.full(5, 180.0), 180.0 + 20.0 * np.arange(1, 10)])
    got = full_turns(s, np.arange(len(s)), fps=30.0)
    assert [(a, d) for a, _, d in got] == [(0, 1)]


def test_frame_numbers_not_rows_time_the_turn():
    # the same 360 deg in 19 rows, but the rows are 10 frames apart: 180 frames = 6 s > 3 s
    s = 20.0 * np.arange(19)
    assert full_turns(s, np.arange(19), fps=30.0) == [(0, 18, 1)]
    assert full_turns(s, 10 * np.arange(19), fps=30.0) == []
