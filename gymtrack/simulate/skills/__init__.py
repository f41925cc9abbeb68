"""The target gymnast's routine on each apparatus: walking in, salute, mount, skills, dismount,
landing, salute, walking out.

Paper: Section III-C (the gymnast's centre keeps to a vertical plane during much of the
routine, with moments off it) and III-D (the performance space; the target's top and bottom
rise above ``h_top`` / ``h_bot`` once the routine starts). Section IV lists the seven apparatus.

Every routine is built from the physics primitives of :mod:`gymtrack.simulate.motion`, with
per-routine randomness (body height, skill choice and order, speeds, heights, rotations):

* balance beam: walks, turns, leaps rising 0.3-0.5 m, jumps, saltos, walkovers and balances
  along the 5 m beam, a springboard mount and a salto dismount off the end;
* pommel horse: circles of ~1 s period and 0.2-0.4 m radius travelling along the horse, flairs,
  scissors, a handstand dismount to the side;
* vault: a 7.5-8.5 m/s run-up of up to 25 m, hurdle, board, pre-flight, table, post-flight peaking
  at 2.4-3.0 m, landing (a second vault if time allows);
* still rings: coach lift to hang (centre ~1.8 m), swings, support, L-sit, press to handstand
  (centre ~3.8 m), cross, swings to a salto dismount;
* horizontal bar and uneven bars: giants (centre circling ~1.0 m around the bar, 1.3-1.6 s a
  turn), casts, releases and regrasps, transitions between the uneven bars, a salto dismount;
* parallel bars: support swings about the shoulders, handstands, walking on the hands, a
  release salto, a moment on one rail, a salto dismount.

Off-plane drift (a few cm on beam and rings, up to 0.5 m on the bars) is added by
:func:`add_drift`, linear in time during flights so that gravity stays the only force there.

One module per apparatus family (:mod:`.beam`, :mod:`.pommel`, :mod:`.vault`, :mod:`.rings`,
:mod:`.bars`), the shared state and moves in :mod:`.choreography`, the dispatch and the drift in
:mod:`.routines`.
"""

from .choreography import CROUCH_LIGHT, CROUCH_MID, PUSH, TWO_PI, Choreography, Event, Layout
from .routines import DRIFT, ROUTINES, add_drift, target_routine

__all__ = ["CROUCH_LIGHT", "CROUCH_MID", "PUSH", "TWO_PI", "Choreography", "Event", "Layout", "DRIFT", "ROUTINES",
           "add_drift", "target_routine"]
