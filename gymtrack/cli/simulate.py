"""``gymtrack simulate`` and ``gymtrack simulate-suite``: routines with ground truth.

* ``gymtrack simulate --apparatus A --n-cam {2,3,4} --seed N [--seconds S] --out DIR [--plot]``
  writes one routine folder (``shared/formats.md``): cameras.yaml, scene.yaml,
  detections/<camera>.txt and gt/. The same seed gives the same files bit for bit.
  ``--video [--video-size W]`` also renders ``videos/<camera>.mp4`` (:mod:`gymtrack.simulate.render`);
  the other files do not change.
* ``gymtrack simulate-suite --per-apparatus K --out DIR [--seconds S] [--seed N]`` writes the
  7 apparatus x K routines x n_cam 2, 3, 4 grid as ``DIR/<apparatus>/ncam<n>/r<k>/`` and an index
  ``DIR/suite.json`` (path, apparatus, n_cam, seed of every routine).

Paper: Section IV-A (the evaluation dataset: seven apparatus, n_cam = 2, 3, 4).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console
from rich.table import Table

from gymtrack.cli import app

console = Console()

_APPARATUS_HELP = "balance_beam | pommel_horse | vault | still_rings | horizontal_bar | uneven_bars | parallel_bars"


def _seconds(value: Optional[float]) -> Optional[float]:
    """``None`` or ``0``: the simulator's default length for the apparatus."""
    return None if value is None or value == 0 else value


@app.command()
def simulate(
    apparatus: str = typer.Option(..., "--apparatus", "-a", help=_APPARATUS_HELP),
    n_cam: int = typer.Option(4, "--n-cam", help="views that can detect the target: 4 all, 3 one blind to it, 2 only the opposite pair cam0/cam1"),
    seed: int = typer.Option(0, "--seed", help="random seed; the same seed gives the same files bit for bit"),
    seconds: Optional[float] = typer.Option(None, "--seconds", help="routine length (default 60 s, vault 20 s; 0 = default)"),
    out: Path = typer.Option(..., "--out", "-o", help="routine folder to write"),
    plot: bool = typer.Option(False, "--plot", help="also write plot_top.png and plot_side.png (needs matplotlib)"),
    video: bool = typer.Option(False, "--video", help="also render every view to videos/<camera>.mp4 (needs the 'video' extra)"),
    video_size: int = typer.Option(0, "--video-size", help="rendered frame width in pixels (0: the cameras' own; smaller "
                                   "for previews and tests -- frame pixels are then camera pixels times width / camera width)"),
) -> None:
    """Simulate one gymnastics routine seen by four cameras, with ground truth."""
    from gymtrack.errors import InputError
    from gymtrack.simulate import simulate_routine

    if video_size < 0 or 0 < video_size < 16:
        raise InputError(f"--video-size must be 0 or a width of at least 16 pixels, got {video_size}", field="--video-size")
    t0 = time.perf_counter()
    sim = simulate_routine(apparatus, n_cam, seed, _seconds(seconds), out=out, plot=plot)
    t_video = None
    if video:
        from gymtrack.simulate.render import write_videos

        t1 = time.perf_counter()
        paths = write_videos(sim, out, video_size or None, progress=lambda cam, k: console.print(f"  rendered {cam}: {k} frames"))
        t_video = (time.perf_counter() - t1, sum(p.stat().st_size for p in paths.values()))
    s = sim.summary()
    tab = Table(title=f"Simulated {apparatus}, seed {seed}, n_cam {n_cam}", title_justify="left")
    tab.add_column("what")
    tab.add_column("value", justify="right")
    tab.add_row("frames", f"{s['frames']} ({s['seconds']:g} s at {sim.fps:g} fps)")
    tab.add_row("persons", f"{s['persons']} (target id {sim.target_id})")
    for cam, n in s["detections"].items():
        tab.add_row(f"detections {cam}", str(n))
    tab.add_row("false positives", str(s["false_positives"]))
    tab.add_row("dropped at the image border", str(s["dropped_at_border"]))
    tab.add_row("views allowed to see the target", ", ".join(s["target_views"]))
    frac = "  ".join(f"{k}:{float(v):.2f}" for k, v in s["target_views_detected_fraction"].items())
    tab.add_row("target detected in k views (performing)", frac)
    if t_video is not None:
        tab.add_row("videos (render + encode)", f"{t_video[0]:.1f} s, {t_video[1] / 1e6:.1f} MB")
    tab.add_row("seconds", f"{time.perf_counter() - t0:.2f}")
    console.print(tab)
    console.print(f"wrote [bold]{out}[/]")


@app.command("simulate-suite")
def simulate_suite_cmd(
    per_apparatus: int = typer.Option(..., "--per-apparatus", "-k", help="routines per apparatus (each written with n_cam = 2, 3 and 4)"),
    out: Path = typer.Option(..., "--out", "-o", help="suite folder: <out>/<apparatus>/ncam<n>/r<k>/ and <out>/suite.json"),
    seconds: Optional[float] = typer.Option(None, "--seconds", help="routine length (default 60 s, vault 20 s; 0 = default)"),
    seed: int = typer.Option(0, "--seed", help="base seed of the suite"),
    apparatus: Optional[List[str]] = typer.Option(None, "--apparatus", "-a", help=f"only these apparatus (repeat the option); {_APPARATUS_HELP}"),
    plot: bool = typer.Option(False, "--plot", help="also write the two plots of every routine"),
) -> None:
    """Simulate the suite: 7 apparatus x K routines x n_cam 2, 3, 4, with a suite.json index."""
    from gymtrack.errors import InputError
    from gymtrack.simulate import simulate_suite
    from gymtrack.apparatus import APPARATUS_NAMES

    for a in apparatus or []:
        if a not in APPARATUS_NAMES:
            raise InputError(f"unknown apparatus {a!r}; choose one of {', '.join(APPARATUS_NAMES)}", field="--apparatus")
    t0 = time.perf_counter()
    entries = simulate_suite(out, per_apparatus, seconds=_seconds(seconds), seed=seed, apparatus=apparatus or None, plot=plot,
                             progress=lambda e: console.print(f"  {e['path']}  seed {e['seed']}  {e['frames']} frames"))
    console.print(f"wrote {len(entries)} routines and [bold]{Path(out) / 'suite.json'}[/] in {time.perf_counter() - t0:.1f} s")
