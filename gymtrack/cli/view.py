"""``gymtrack view`` and ``gymtrack overlay``: look at what the tracker did.

* ``gymtrack view <routine> <out> [-o view.rrd] [--spawn]`` writes a Rerun recording: cameras,
  performance space and apparatus plane, every 3D track, the target and its skeleton, per view the
  detections, boxes, b_buf and keypoints, ground truth, and the analysis stage's elements on the
  frame timeline where it ran (:mod:`gymtrack.eval.viewer`).
* ``gymtrack overlay <routine> <out> [--camera cam0] -o video.mp4`` draws boxes with ids, b_buf,
  the 2D skeletons and the projected 3D one, and captions of the elements (flights' saltos and
  twists, the hold timer) on the videos, a grid of all views by default (:mod:`gymtrack.eval.overlay`).

Paper: Section III (every stage's output, shown) and III-D (b_buf).
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path
from typing import Optional

import typer
from rich.console import Console

from gymtrack.cli import app

console = Console()


@app.command()
def view(
    routine: Path = typer.Argument(..., help="routine folder (cameras.yaml, scene.yaml, detections/, optional videos/ and gt/)"),
    out: Path = typer.Argument(..., help="output folder of 'gymtrack track' (and 'gymtrack pose')"),
    rrd: Optional[Path] = typer.Option(None, "--rrd", "-o", help="recording to write (default: OUT/view.rrd)"),
    spawn: bool = typer.Option(False, "--spawn", help="open the Rerun viewer on the recording"),
    no_videos: bool = typer.Option(False, "--no-videos", help="leave the videos out of the recording (smaller file)"),
) -> None:
    """Write a Rerun recording (.rrd) of a routine, the tracker's outputs and the elements (needs the 'view' extra)."""
    from gymtrack.eval.viewer import write_recording

    t0 = time.perf_counter()
    path = rrd or Path(out) / "view.rrd"
    s = write_recording(routine, out, path, videos=not no_videos, progress=console.print)
    console.print(f"3D tracks {s['tracks_3d']} rows, target {s['target_3d']}, 3D poses {s['poses_3d']}; boxes {s['boxes']}, "
                  f"b_buf {s['b_buf']}, detections {s['detections']}, 2D poses {s['keypoints']}; ground truth: "
                  f"{'yes' if s['ground_truth'] else 'no'}; videos: {', '.join(s['videos']) or 'none'}; "
                  f"elements: {s['elements'] or 'none (no analysis/elements.json)'}")
    console.print(f"wrote [bold]{path}[/] ({path.stat().st_size / 1e6:.1f} MB) in {time.perf_counter() - t0:.1f} s")
    if spawn:
        subprocess.Popen([sys.executable, "-m", "rerun", str(path)])


@app.command()
def overlay(
    routine: Path = typer.Argument(..., help="routine folder (videos/<camera>.mp4 optional: a neutral canvas without)"),
    out: Path = typer.Argument(..., help="output folder of 'gymtrack track' (keypoints/ of 'gymtrack pose' optional)"),
    video: Path = typer.Option(..., "--output", "-o", help="video to write (.mp4 H.264; .mkv lossless)"),
    camera: Optional[str] = typer.Option(None, "--camera", "-c", help="one camera (default: a grid of all)"),
    width: Optional[int] = typer.Option(None, "--width", help="image width (default: a grid 1920, one camera its video's width)"),
    start: Optional[int] = typer.Option(None, "--start", help="first frame (default: the first with a box)"),
    stop: Optional[int] = typer.Option(None, "--stop", help="last frame, inclusive (default: the last with a box)"),
) -> None:
    """Draw boxes with ids, b_buf, the skeletons and the elements' captions on the videos (needs the 'video' extra)."""
    import numpy as np

    from gymtrack.eval.overlay import load_overlay_inputs, write_overlay

    t0 = time.perf_counter()
    frames = None
    if start is not None or stop is not None:
        all_frames = load_overlay_inputs(routine, out).frames
        lo = all_frames.min() if start is None else start
        hi = all_frames.max() if stop is None else stop
        frames = np.arange(lo, hi + 1)
    s = write_overlay(routine, out, video, camera=camera, width=width, frames=frames)
    size = f"{s['size'][0]}x{s['size'][1]}" if s["size"] else "-"
    console.print(f"{s['frames']} frames {size}; video: {', '.join(s['videos']) or 'none'}; canvas: {', '.join(s['canvas']) or 'none'}; "
                  f"3D poses {s['poses_3d']}; elements: {s['elements'] or 'none (no analysis/elements.json)'}")
    console.print(f"wrote [bold]{video}[/] ({Path(video).stat().st_size / 1e6:.1f} MB) in {time.perf_counter() - t0:.1f} s")
