"""Benchmark outputs already run, pooled without rerunning (``gymtrack benchmark-pool``).

Paper: Section IV (Tables 3 and 5) and Section III-D's judging measurements; the rule that a
headline figure is reported with its spread (:mod:`.pooled`). Each output folder's ``rows.csv``
(written by ``gymtrack benchmark``) is read back; an output whose routine names carry no
``s<seed>/`` prefix is one suite, one of ``--seeds`` is as many suites as its prefixes. Routine
names gain an ``o<k>/`` prefix (k: the output's place in the list) so that they stay unique, and
each row a ``suite`` field (the output folder, and the seed prefix if any) that the pooled figures
count suites by. The pooled tracking ratios and judging targets are written as ``report.md``,
``pooled_ratios.csv``, ``pooled_judging.csv`` and ``results.json``.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path
from typing import Sequence

from ..errors import InputError

__all__ = ["REQUIRED", "read_rows", "pool_outputs", "pooled_results", "write_pooled"]

#: the columns every benchmark row has (tracking columns may be missing: those figures are then left out)
REQUIRED: tuple[str, ...] = ("routine", "apparatus", "n_cam", "method")
_PREFIX = re.compile(r"s(\d+)/")


def read_rows(folder: str | Path) -> list[dict]:
    """The rows of one benchmark output's ``rows.csv``; an InputError naming the file (and line and
    field) when the folder is not a benchmark output or a row cannot be pooled."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError("not a folder (expected a gymtrack benchmark output with rows.csv)", source=folder)
    path = folder / "rows.csv"
    if not path.is_file():
        raise InputError("missing: not a gymtrack benchmark output (gymtrack benchmark --out writes rows.csv, report.md, "
                         "results.json)", source=path)
    csv.field_size_limit(2**31 - 1)  # judge_parts cells are long JSON documents
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        missing = [c for c in REQUIRED if c not in (reader.fieldnames or [])]
        if missing:
            raise InputError(f"no column {', '.join(missing)}: not the rows of a gymtrack benchmark (columns: "
                             f"{', '.join((reader.fieldnames or [])[:8]) or 'none'})", source=path, line=1)
        rows = []
        for r in reader:
            line = reader.line_num
            if None in r or any(r[c] is None for c in REQUIRED):
                raise InputError("a row with more or fewer cells than the header", source=path, line=line)
            try:
                r["n_cam"] = int(r["n_cam"])
            except ValueError:
                raise InputError(f"expected an integer, got {r['n_cam']!r}", source=path, line=line, field="n_cam") from None
            for c in ("judge_parts", "judge_truth_parts"):
                if r.get(c):
                    try:
                        r[c] = json.loads(r[c])
                    except json.JSONDecodeError as exc:
                        raise InputError(f"not JSON ({exc.msg} at character {exc.pos})", source=path, line=line, field=c) from None
            rows.append(r)
    if not rows:
        raise InputError("no rows", source=path)
    return rows


def pool_outputs(folders: Sequence[str | Path], out: str | Path | None = None) -> list[dict]:
    """The rows of every output, names made unique (``o<k>/``) and each with its ``suite``;
    ``out``: the folder the pooled files will go to, checked first (not one of the outputs)."""
    if not folders:
        raise InputError("give one benchmark output folder or more", field="OUTPUTS")
    if out is not None:
        _check_out(out, folders)
    seen: dict[Path, Path] = {}
    out = []
    for k, folder in enumerate(folders):
        key = Path(folder).resolve()
        if key in seen:
            raise InputError(f"given twice (also as {seen[key]})", source=folder)
        seen[key] = Path(folder)
        rows = read_rows(folder)
        prefixed = [bool(_PREFIX.match(r["routine"])) for r in rows]
        if any(prefixed) and not all(prefixed):
            i = prefixed.index(not prefixed[0])
            raise InputError(f"mixes routine names with and without an s<seed>/ prefix ({rows[0]['routine']!r}, "
                             f"{rows[i]['routine']!r})", source=Path(folder) / "rows.csv", field="routine")
        for r in rows:
            m = _PREFIX.match(r["routine"])
            r["suite"] = f"{folder} s{m.group(1)}" if m else str(folder)
            r["routine"] = f"o{k}/{r['routine']}"
        out += rows
    return out


def pooled_results(rows: Sequence[dict], n_boot_judging: int = 1000, n_boot: int = 2000, level: float = 0.9,
                   seed: int = 0) -> tuple[list[str], dict[str, list[dict]]]:
    """The pooled sections (markdown: tracking ratios, judging targets) and their records
    (``pooled_ratios``, ``pooled_judging``: for results.json and one CSV each)."""
    from .pooled import pooled_judging, pooled_judging_markdown, pooled_markdown, pooled_ratios

    judging = pooled_judging(rows, n_boot_judging, level, seed)
    sections = [pooled_markdown(rows, level, n_boot, seed), pooled_judging_markdown(judging, level, n_boot_judging, seed)]
    return sections, {"pooled_ratios": [r.as_dict() for r in pooled_ratios(rows, n_boot, level, seed)],
                      "pooled_judging": [c.as_dict() for c in judging]}


def write_pooled(out: str | Path, folders: Sequence[str | Path], sections: Sequence[str], records: dict[str, list[dict]]) -> dict[str, Path]:
    """``report.md``, one CSV per record list and ``results.json`` under ``out`` (never one of the inputs)."""
    from .render import _jsonable, write_csv

    out = _check_out(out, folders)
    out.mkdir(parents=True, exist_ok=True)
    files = {}
    for name, recs in records.items():
        if recs:
            files[name] = write_csv(out / f"{name}.csv", recs)
    head = ["# gymtrack benchmark-pool", "", "Benchmark outputs pooled (each output without s<seed>/ prefixes is one suite):", ""]
    head += [f"- o{k}: {f}" for k, f in enumerate(folders)]
    body = [s for s in sections if s] or ["No pooled figure: the outputs' rows have neither the tracking columns nor judging rows.\n"]
    files["report"] = out / "report.md"
    files["report"].write_text("\n".join(head) + "\n\n" + "\n".join(body))
    files["json"] = out / "results.json"
    files["json"].write_text(json.dumps(_jsonable({"meta": {"outputs": [str(f) for f in folders]}, **records}), indent=1))
    return files


def _check_out(out: str | Path, folders: Sequence[str | Path]) -> Path:
    out = Path(out)
    if any(out.resolve() == Path(f).resolve() for f in folders):
        raise InputError("is one of the outputs pooled: give another folder (its report.md would be overwritten)",
                         source=out, field="--out")
    return out
