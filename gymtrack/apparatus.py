"""The seven Olympic apparatus: FIG dimensions and the domain knowledge the tracker uses.

Paper: Section III-C (the vertical plane the gymnast's centre keeps to) and III-D (performance
space ``S_perf`` and the identification heights ``h_top``, ``h_bot`` of Eq. 13).

World frame of every preset: origin on the floor under the apparatus centre, z up, the
apparatus' long axis (beam, horse, runway, bars' rails; the bar itself for horizontal bar,
uneven bars and rings) along world x.

* Along-axis apparatus (balance beam, pommel horse, vault, parallel bars): the gymnast moves
  along x, so the plane is ``y = 0`` (normal +y).
* Across-axis apparatus (horizontal bar, uneven bars, still rings): the gymnast swings around
  the bar, in the plane ``x = 0`` (normal +x) perpendicular to it.

Dimensions follow the FIG Apparatus Norms as summarised in the foundation issue: beam 5 m long
and 1.25 m high; pommel horse 1.15 m high and 1.6 m long; vault table 1.35 m (men) / 1.25 m
(women) with a run-up of up to 25 m; rings 2.8 m above the floor, 0.5 m apart; horizontal bar
2.8 m high and 2.4 m long; uneven bars 2.5 m and 1.7 m high, 1.3-1.8 m apart (diagonal);
parallel bars 2.0 m high, 3.5 m long, rails 0.42-0.52 m apart.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal


ApparatusName = Literal[
    "balance_beam", "pommel_horse", "vault", "still_rings", "horizontal_bar", "uneven_bars", "parallel_bars"
]
APPARATUS_NAMES: tuple[str, ...] = (
    "balance_beam",
    "pommel_horse",
    "vault",
    "still_rings",
    "horizontal_bar",
    "uneven_bars",
    "parallel_bars",
)
#: The paper's two-letter abbreviations (Table 3).
ABBREVIATIONS = {
    "balance_beam": "BB",
    "pommel_horse": "PH",
    "vault": "VT",
    "still_rings": "SR",
    "horizontal_bar": "HB",
    "uneven_bars": "UB",
    "parallel_bars": "PB",
}


@dataclass(frozen=True)
class Bar:
    """A cylindrical bar, rail or beam top edge: segment ``start``-``end`` (metres), ``radius``."""

    start: tuple[float, float, float]
    end: tuple[float, float, float]
    radius: float = 0.02


@dataclass(frozen=True)
class Block:
    """An axis-aligned solid block (beam body, horse, vault table): ``lo``/``hi`` corners."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]


@dataclass(frozen=True)
class Apparatus:
    """Geometry and domain knowledge of one apparatus preset.

    Attributes
    ----------
    name: one of :data:`APPARATUS_NAMES`.
    performance_space: ``[xmin, ymin, zmin, xmax, ymax, zmax]``, the paper's ``S_perf``.
    plane_point, plane_normal: the vertical plane the gymnast's centre keeps to.
    h_top, h_bot: Eq. 13 identification heights of the body's top and bottom.
    bars, blocks: solid parts (for drawing, occlusion and the simulator's motion).
    along_axis: True if the gymnast travels along x in the plane ``y = 0``.
    turn_axis: the horizontal axis the apparatus' saltos, giants and dismounts turn about (the
        judging analysis' somersault axis); None: the plane's normal. The pommel horse's is its
        length: its dismounts go over the horse from a handstand across it, turning about the horse.
    body_half_depth: metres, half the body's extent across the plane (Eq. 14's body box in views
        without a detection): a trunk's depth, or on pommel horse half a horizontal body's length.
    surfaces: ``(point, normal)`` of further scene surfaces where the vertical plane does not
        hold (the plane stage's candidates on them, as on the plane; the recipe's ``surfaces``).
    """

    name: str
    performance_space: tuple[float, float, float, float, float, float]
    plane_point: tuple[float, float, float]
    plane_normal: tuple[float, float, float]
    h_top: float
    h_bot: float
    along_axis: bool
    bars: tuple[Bar, ...] = field(default_factory=tuple)
    blocks: tuple[Block, ...] = field(default_factory=tuple)
    turn_axis: tuple[float, float, float] | None = None
    surfaces: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...] = ()
    body_half_depth: float = 0.25

    @property
    def somersault_axis(self) -> tuple[float, float, float]:
        """The somersault axis (unit, preset frame): :attr:`turn_axis`, else the plane's normal."""
        return self.plane_normal if self.turn_axis is None else self.turn_axis

    @property
    def abbreviation(self) -> str:
        return ABBREVIATIONS[self.name]

    @property
    def focus(self) -> tuple[float, float, float]:
        """Where the action is: above the apparatus centre (the world origin) at a typical body-centre
        height. Not the centre of the performance space, which for the vault lies mid-runway."""
        return (0.0, 0.0, FOCUS_HEIGHT)


# FIG numbers used below, named once.
BEAM_LENGTH, BEAM_HEIGHT, BEAM_WIDTH = 5.0, 1.25, 0.10
HORSE_LENGTH, HORSE_HEIGHT, HORSE_WIDTH, POMMEL_HEIGHT, POMMEL_SPACING = 1.6, 1.15, 0.35, 0.12, 0.45
VAULT_TABLE_HEIGHT_MEN, VAULT_TABLE_HEIGHT_WOMEN, VAULT_RUNUP = 1.35, 1.25, 25.0
VAULT_TABLE_LENGTH, VAULT_TABLE_WIDTH = 1.2, 0.95
RINGS_HEIGHT, RINGS_SPACING = 2.8, 0.5
HIGH_BAR_HEIGHT, HIGH_BAR_LENGTH = 2.8, 2.4
UNEVEN_HIGH, UNEVEN_LOW, UNEVEN_LENGTH = 2.5, 1.7, 2.4
UNEVEN_HORIZONTAL_GAP = 1.5  # gives a 1.70 m diagonal, inside FIG's 1.3-1.8 m
PARALLEL_HEIGHT, PARALLEL_LENGTH, PARALLEL_SPACING = 2.0, 3.5, 0.47
#: pommel horse: the height of the body's centre in support (circles, flairs, scissors). The palms
#: rest on the leather (~1.05 m), the shoulders ride an arm's length (about 0.38 of the body's
#: height, Winter's segment table: 0.63 m for 1.65 m) above them, and the hips sit about 0.25 m
#: below the shoulders with the body in its shallow pike: ~1.4 m, a horizontal circle at nearly
#: constant height about the hands (Section III-C's plane holds it only within the circle's radius)
POMMEL_SUPPORT_CENTRE = 1.4
#: pommel horse: in circles and flairs the body lies near horizontal and turns about the hands'
#: vertical axis, so across the plane it reaches up to half its length from the centre (half a
#: 1.6-1.7 m gymnast), not the trunk's depth of the other apparatus
POMMEL_BODY_HALF_DEPTH = 0.8
FOCUS_HEIGHT = 1.5  # a gymnast's centre on the apparatus: 1.25 m beam + ~0.9 m, bars' hang ~1.5-2 m


def _presets() -> dict[str, Apparatus]:
    along = (0.0, 1.0, 0.0)
    across = (1.0, 0.0, 0.0)
    origin = (0.0, 0.0, 0.0)
    hb, hl = BEAM_LENGTH / 2, HORSE_LENGTH / 2
    ug = UNEVEN_HORIZONTAL_GAP / 2
    pl, ps = PARALLEL_LENGTH / 2, PARALLEL_SPACING / 2
    return {
        "balance_beam": Apparatus(
            "balance_beam",
            (-hb - 1.5, -1.0, 0.0, hb + 1.5, 1.0, 4.5),
            origin, along, h_top=2.0, h_bot=0.6, along_axis=True,
            bars=(Bar((-hb, 0, BEAM_HEIGHT), (hb, 0, BEAM_HEIGHT), BEAM_WIDTH / 2),),
            blocks=(Block((-hb, -BEAM_WIDTH / 2, BEAM_HEIGHT - 0.16), (hb, BEAM_WIDTH / 2, BEAM_HEIGHT)),),
        ),
        "pommel_horse": Apparatus(
            "pommel_horse",
            (-hl - 1.0, -1.2, 0.0, hl + 1.0, 1.2, 3.2),
            origin, along, h_top=1.5, h_bot=0.6, along_axis=True,
            bars=tuple(
                Bar((x, -0.07, HORSE_HEIGHT), (x, 0.07, HORSE_HEIGHT), 0.015)
                for x in (-POMMEL_SPACING / 2, POMMEL_SPACING / 2)
            ),
            blocks=(Block((-hl, -HORSE_WIDTH / 2, HORSE_HEIGHT - POMMEL_HEIGHT - 0.35), (hl, HORSE_WIDTH / 2, HORSE_HEIGHT - POMMEL_HEIGHT)),),
            turn_axis=(1.0, 0.0, 0.0),  # n x z: the horse's length
            surfaces=(((0.0, 0.0, POMMEL_SUPPORT_CENTRE), (0.0, 0.0, 1.0)),),
            body_half_depth=POMMEL_BODY_HALF_DEPTH,
        ),
        "vault": Apparatus(
            "vault",
            (-VAULT_RUNUP - 1.0, -1.5, 0.0, 5.0, 1.5, 4.5),
            origin, along, h_top=2.0, h_bot=0.4, along_axis=True,
            blocks=(
                Block(
                    (-VAULT_TABLE_LENGTH / 2, -VAULT_TABLE_WIDTH / 2, VAULT_TABLE_HEIGHT_MEN - 0.25),
                    (VAULT_TABLE_LENGTH / 2, VAULT_TABLE_WIDTH / 2, VAULT_TABLE_HEIGHT_MEN),
                ),
            ),
        ),
        "still_rings": Apparatus(
            "still_rings",
            (-1.5, -2.0, 0.0, 1.5, 2.0, 5.0),
            origin, across, h_top=2.0, h_bot=0.6, along_axis=False,
            bars=tuple(Bar((x, 0, RINGS_HEIGHT), (x, 0, RINGS_HEIGHT + 0.18), 0.09) for x in (-RINGS_SPACING / 2, RINGS_SPACING / 2)),
        ),
        "horizontal_bar": Apparatus(
            "horizontal_bar",
            (-1.5, -2.5, 0.0, 1.5, 2.5, 5.0),
            origin, across, h_top=2.0, h_bot=0.6, along_axis=False,
            bars=(Bar((-HIGH_BAR_LENGTH / 2, 0, HIGH_BAR_HEIGHT), (HIGH_BAR_LENGTH / 2, 0, HIGH_BAR_HEIGHT), 0.014),),
        ),
        "uneven_bars": Apparatus(
            "uneven_bars",
            (-1.5, -2.8, 0.0, 1.5, 2.8, 4.5),
            origin, across, h_top=2.0, h_bot=0.6, along_axis=False,
            bars=(
                Bar((-UNEVEN_LENGTH / 2, -ug, UNEVEN_LOW), (UNEVEN_LENGTH / 2, -ug, UNEVEN_LOW), 0.02),
                Bar((-UNEVEN_LENGTH / 2, ug, UNEVEN_HIGH), (UNEVEN_LENGTH / 2, ug, UNEVEN_HIGH), 0.02),
            ),
        ),
        "parallel_bars": Apparatus(
            "parallel_bars",
            (-pl - 1.0, -1.2, 0.0, pl + 1.0, 1.2, 4.5),
            origin, along, h_top=2.0, h_bot=0.6, along_axis=True,
            bars=tuple(Bar((-pl, y, PARALLEL_HEIGHT), (pl, y, PARALLEL_HEIGHT), 0.025) for y in (-ps, ps)),
        ),
    }


PRESETS: dict[str, Apparatus] = _presets()


def get_apparatus(name: str) -> Apparatus:
    """The preset called ``name``; raises ``KeyError`` listing the valid names."""
    try:
        return PRESETS[name]
    except KeyError:
        raise KeyError(f"unknown apparatus {name!r}; choose one of {', '.join(APPARATUS_NAMES)}") from None
