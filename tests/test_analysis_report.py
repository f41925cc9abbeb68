"""The routine sheet (``analysis/report.html``): built from hand-made angles.csv and elements.json,
parsed back with Python's own HTML parser (the element table holds each element's values, no
external URL, the figures are there and carry their data) and rendered by headless Chromium
(the screenshot has the window's size and is not blank)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from html.parser import HTMLParser

import numpy as np
import pytest

from gymtrack.errors import GymtrackError, InputError
from gymtrack.formats.elements import write_angles, write_elements

pytest.importorskip("matplotlib")

FPS = 50.0
FIRST = 101  # frame numbers as the input files carry them
TAKE_OFF, LANDING = 301, 340  # a 0.8 s flight


def synthetic_angles(n: int = 600, gap: tuple[int, int] = (480, 490)) -> dict[str, np.ndarray]:
    """A 12 s routine: stand, a tucked back salto with a half twist (frames 301-340), a landing,
    a handstand (420-470); frames 480-489 have no pose (a gap)."""
    frame = np.arange(FIRST, FIRST + n)
    t = (frame - TAKE_OFF) / FPS
    air = (frame >= TAKE_OFF) & (frame <= LANDING)
    dur = (LANDING - TAKE_OFF + 1) / FPS
    com_z = np.where(air, 1.0 + 4.0 * t - 9.81 / 2 * t ** 2, 1.0)  # apex 1.0 + 4^2/(2 g) = 1.816 m
    frac = np.clip(t / dur, 0, 1)
    knee = np.where(air, 180 - 130 * np.sin(np.pi * frac), 175.0)
    hip = np.where(air, 180 - 120 * np.sin(np.pi * frac), 170.0)
    incl = np.where((frame >= 420) & (frame <= 470), 174.0, 5.0)
    cols = {
        "frame": frame, "track_id": np.full(n, 3), "com_x": np.where(air, 2.0 * frac, np.where(frame > LANDING, 2.0, 0.0)) + 0.001 * (frame - FIRST),
        "com_y": 0.3 * np.sin((frame - FIRST) / 120), "com_z": com_z,
        "support": np.where(air, "none", "floor"), "left_knee": knee, "right_knee": knee + 3, "left_hip": hip,
        "right_hip": hip + 2, "left_elbow": np.full(n, 170.0), "right_elbow": np.full(n, 171.0),
        "left_shoulder": np.full(n, 30.0), "right_shoulder": np.full(n, 31.0), "split": 20 + 10 * np.sin(frame / 30),
        "inclination": incl, "somersault": 360 * frac, "twist": 180 * frac,
    }
    cols["split"][5] = np.nan  # a measure that could not be computed: an empty cell
    keep = (frame < FIRST + gap[0] - 1) | (frame >= FIRST + gap[1] - 1) if gap else np.ones(n, bool)
    return {k: np.asarray(v)[keep] for k, v in cols.items()}


ELEMENTS = {
    "track_id": 3, "fps": FPS, "apparatus": "floor", "source": "analysis", "version": "0.1.0",
    "missing": {"circle": "no bar in the scene's apparatus"},
    "elements": [
        {"kind": "flight", "start_frame": TAKE_OFF, "end_frame": LANDING, "duration_s": 0.8, "apex_z": 1.816,
         "apex_z_sd": 0.012, "height_gain": 0.816, "distance": 2.0, "somersault_deg": 357.0, "somersault_deg_sd": 4.0,
         "saltos": 1.0, "twist_deg": 176.0, "twists": 0.5, "shape": "tuck", "min_hip": 60.0, "min_knee": 50.0,
         "max_split": None, "missing": {"max_split": "no ankle seen in the flight"}, "airborne_somersault_deg": 301.5},
        {"kind": "landing", "frame": LANDING + 1, "steps": 1, "largest_step": 0.31, "stuck": False},
        {"kind": "hold", "start_frame": 420, "end_frame": 470, "duration_s": 1.02, "position": "handstand",
         "deviation": 6.5, "deviation_sd": 3.0},
        {"kind": "turn", "start_frame": 520, "end_frame": 545, "degrees": 180.0},
    ],
}


class _Page(HTMLParser):
    """Tables (id -> rows of cell texts), the attributes of every tag, the ids of figures, text."""

    def __init__(self):
        super().__init__()
        self.tables: dict[str, list[list[str]]] = {}
        self.attrs: list[tuple[str, dict]] = []
        self.figures: dict[str, int] = {}  # figure id -> number of <svg> elements inside
        self.svg_text: dict[str, list[str]] = {}
        self.text: list[str] = []
        self._table = self._row = self._cell = self._fig = None
        self._in_svg_text = False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.attrs.append((tag, a))
        if tag == "table":
            self._table = self.tables.setdefault(a.get("id", ""), [])
        elif tag == "tr" and self._table is not None:
            self._row = []
            self._table.append(self._row)
        elif tag in ("td", "th") and self._row is not None:
            self._cell = []
        elif tag == "figure":
            self._fig = a.get("id")
            self.figures[self._fig] = 0
            self.svg_text[self._fig] = []
        elif tag == "svg" and self._fig:
            self.figures[self._fig] += 1
        elif tag == "text" and self._fig:
            self._in_svg_text = True

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            self._row.append("".join(self._cell).strip())
            self._cell = None
        elif tag == "table":
            self._table = self._row = None
        elif tag == "figure":
            self._fig = None
        elif tag == "text":
            self._in_svg_text = False

    def handle_data(self, data):
        self.text.append(data)
        if self._cell is not None:
            self._cell.append(data)
        if self._in_svg_text and self._fig:
            self.svg_text[self._fig].append(data)


@pytest.fixture(scope="module")
def sheet(tmp_path_factory):
    from gymtrack.analysis.report import write_report

    folder = tmp_path_factory.mktemp("routine") / "out" / "analysis"
    write_angles(folder / "angles.csv", synthetic_angles())
    write_elements(folder / "elements.json", ELEMENTS)
    path = write_report(folder)
    page = _Page()
    page.feed(path.read_text(encoding="utf-8"))
    return path, page


def _table(page, name):
    head, *rows = page.tables[name]
    return [dict(zip(head, r)) for r in rows]


def test_the_table_holds_every_element_and_its_values(sheet):
    path, page = sheet
    assert path.name == "report.html" and path.parent.name == "analysis"
    (fl,) = _table(page, "flights")
    assert fl["frames"] == f"{TAKE_OFF}–{LANDING}" and fl["time (s)"] == f"{(TAKE_OFF - FIRST) / FPS:.2f}"
    assert fl["duration (s)"] == "0.80" and fl["apex (m)"] == "1.82 ± 0.01" and fl["height gain (m)"] == "0.82"
    assert fl["saltos"] == "1.00" and fl["somersault (°)"] == "357 ± 4" and fl["twists"] == "0.5"
    assert fl["twist (°)"] == "176" and fl["shape"] == "tuck" and fl["min hip (°)"] == "60" and fl["min knee (°)"] == "50"
    assert fl["max split (°)"] == "missing: no ankle seen in the flight"  # null: the reason, never a number
    assert "airborne somersault deg: 301.50" in fl["other"]  # a field without a column is still shown
    (ld,) = _table(page, "landings")
    assert (ld["frame"], ld["steps"], ld["largest step (m)"], ld["stuck"]) == (str(LANDING + 1), "1", "0.31", "no")
    (hd,) = _table(page, "holds")
    assert (hd["frames"], hd["duration (s)"], hd["position"], hd["deviation (°)"]) == ("420–470", "1.02", "handstand", "6.5 ± 3.0")
    (tn,) = _table(page, "turns")
    assert tn["degrees"] == "180" and tn["frames"] == "520–545"
    assert "circles" not in page.tables  # none found: the file says why
    text = "".join(page.text)
    assert "not measured: no bar in the scene's apparatus" in text
    assert "track 3" in text and "apparatus floor" in text and "50 fps" in text


def test_no_external_url(sheet):
    path, page = sheet
    for tag, attrs in page.attrs:
        for k in ("src", "href", "xlink:href", "data"):
            v = (attrs.get(k) or "").strip().lower()
            assert not v.startswith(("http:", "https:", "//", "ftp:")), (tag, k, v)
        assert tag not in ("script", "link", "iframe"), tag  # nothing loaded or run
    raw = path.read_text(encoding="utf-8")
    assert not re.search(r"url\(\s*['\"]?\s*(https?:)?//", raw)  # no CSS import of a font or image
    assert "@import" not in raw


def test_the_figures_are_inline_svg_carrying_the_data(sheet):
    _, page = sheet
    assert set(page.figures) == {"fig-com", "fig-rotation", "fig-joints", "fig-path"}
    assert all(n == 1 for n in page.figures.values())
    # text stays text: the annotations and labels can be read back
    com = " ".join(page.svg_text["fig-com"])
    assert "1 salto 0.5 twist tuck" in com and "flight" in com and "hold" in com and "landing" in com and "turn" in com
    assert "revolutions" in " ".join(page.svg_text["fig-rotation"])
    joints = " ".join(page.svg_text["fig-joints"])
    assert "left knee" in joints and "split" in joints


def test_a_gap_in_the_frames_breaks_the_lines():
    """Frames without a pose are not bridged by a line: one NaN row is inserted at the gap."""
    from gymtrack.analysis.report import _broken

    a = synthetic_angles()
    f, z = _broken(a["frame"], a["com_z"])
    assert np.isnan(z).sum() == 1 and np.isnan(f).sum() == 1  # one gap, one break
    i = int(np.flatnonzero(np.isnan(f))[0])
    assert f[i - 1] == FIRST + 478 and f[i + 1] == FIRST + 489


def test_a_file_without_rows_still_gives_the_table(tmp_path):
    """angles.csv with its header only: the elements are listed, the page says there is nothing to plot."""
    from gymtrack.analysis.report import write_report

    write_angles(tmp_path / "angles.csv", {k: v[:0] for k, v in synthetic_angles(10, gap=None).items()})
    doc = dict(ELEMENTS, elements=ELEMENTS["elements"] + [
        {"kind": "flight", "start_frame": 600, "end_frame": 620, "saltos": 2.0, "twists": 0.0}])
    write_elements(tmp_path / "elements.json", doc)
    page = _Page()
    page.feed(write_report(tmp_path, title="Beam <final>").read_text(encoding="utf-8"))
    fl = _table(page, "flights")
    assert [r["saltos"] for r in fl] == ["1.00", "2.00"] and fl[1]["time (s)"] == "–"
    assert fl[1]["apex (m)"] == "–" and fl[1]["shape"] == "–"  # not in the file, and no reason given
    assert page.figures == {} and "angles.csv has no rows" in "".join(page.text)
    assert "Beam <final>" in "".join(page.text)  # escaped in the source, read back as written


def test_bad_files_raise_input_errors_naming_the_file(tmp_path):
    from gymtrack.analysis.report import write_report

    write_angles(tmp_path / "angles.csv", synthetic_angles(50, gap=None))
    (tmp_path / "elements.json").write_text(json.dumps({"fps": 50, "elements": [{"kind": "salto", "start_frame": 1}]}))
    with pytest.raises(InputError, match=r"elements\.json.*elements\[0\]\.kind"):
        write_report(tmp_path)
    write_elements(tmp_path / "elements.json", ELEMENTS)
    (tmp_path / "angles.csv").write_text("frame,com_z\n1,2\n")
    with pytest.raises(InputError, match=r"angles\.csv.*line 1"):
        write_report(tmp_path)
    assert not (tmp_path / "report.html").exists()


def test_without_matplotlib_the_error_names_the_extra(tmp_path, monkeypatch):
    import sys

    from gymtrack.analysis.report import write_report

    write_angles(tmp_path / "angles.csv", synthetic_angles(50, gap=None))
    write_elements(tmp_path / "elements.json", ELEMENTS)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    monkeypatch.setitem(sys.modules, "matplotlib.figure", None)
    with pytest.raises(GymtrackError, match=r"pip install 'gymtrack\[plot\]'"):
        write_report(tmp_path)
    assert not (tmp_path / "report.html").exists()


def _chromium() -> str | None:
    return next((p for p in (shutil.which(n) for n in ("chromium", "chromium-browser", "google-chrome")) if p), None)


def test_chromium_renders_a_readable_page(sheet, tmp_path):
    exe = _chromium()
    if exe is None:
        pytest.skip("headless Chromium is not installed (apt-get install chromium)")
    import cv2

    path, _ = sheet
    w, h = 1280, 2400
    shot = tmp_path / "sheet.png"
    r = subprocess.run([exe, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--no-first-run",
                        f"--user-data-dir={tmp_path / 'profile'}", f"--window-size={w},{h}", f"--screenshot={shot}",
                        path.resolve().as_uri()], capture_output=True, text=True, timeout=120)
    assert shot.is_file(), r.stderr[-2000:]
    img = cv2.imread(str(shot))
    assert img.shape[:2] == (h, w)
    grey = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY).astype(float)
    assert grey.std() > 20  # not blank: text, tables and plots
    # each band of the page holds something: the table at the top, the figures below
    bands = grey[: h // 4 * 4].reshape(4, h // 4, w).std(axis=(1, 2))
    assert (bands > 5).all(), bands
    # the shading colours of the element kinds appear (the figures were drawn, not left empty)
    b, g, rch = (img[..., k].astype(int) for k in range(3))
    bluish = (b > rch + 40) & (b > 150)
    assert bluish.sum() > 2000
