"""Reference solutions: the :class:`Reference` a scene's run is compared with, the CSVs shipped with flexbody
(flexbody/reference/*.csv, sources in their '#' lines) and a user's own reference CSV (the same format) for a
scene file."""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Reference:
    """Reference values of some outputs at load factors (static scenes) or at times (dynamic scenes)."""

    load_factors: np.ndarray
    values: dict[str, np.ndarray]
    source: str = ""

    @property
    def times(self) -> np.ndarray:
        """The abscissae of a dynamic scene's reference (the same array as ``load_factors``)."""
        return self.load_factors


def parse_csv(text: str, source: str) -> tuple[dict[str, np.ndarray], list[str]]:
    """Columns and '#' comment lines of a reference CSV: comments, a header row, then numeric rows.

    Raises
    ------
    ValueError
        Naming ``source`` and the row, for a file without a header or data, a header naming a column twice
        (or an empty name), a short row, a non-number or a NaN/inf cell (naming its column).
    """
    comments = [line[1:].strip() for line in text.splitlines() if line.startswith("#")]
    rows = [(k + 1, line) for k, line in enumerate(text.splitlines()) if line.strip() and not line.startswith("#")]
    if len(rows) < 2:
        raise ValueError(f"reference CSV {source!r} needs a header row and at least one data row")
    header = [h.strip() for h in rows[0][1].split(",")]
    twice = [h for k, h in enumerate(header) if h in header[:k]]
    if twice or "" in header:
        problem = f"names column {twice[0]!r} twice" if twice else "has an empty column name"
        raise ValueError(f"reference CSV {source!r} line {rows[0][0]}: the header {problem}")
    data = []
    for lineno, row in rows[1:]:
        cells = row.split(",")
        if len(cells) != len(header):
            raise ValueError(f"reference CSV {source!r} line {lineno}: {len(cells)} values for "
                             f"{len(header)} columns")
        try:
            values = [float(v) for v in cells]
        except ValueError:
            raise ValueError(f"reference CSV {source!r} line {lineno}: not all numbers: {row.strip()!r}") from None
        bad = [k for k, v in enumerate(values) if not np.isfinite(v)]
        if bad:
            raise ValueError(f"reference CSV {source!r} line {lineno}, column {header[bad[0]]!r}: "
                             f"{cells[bad[0]].strip()!r} is not a finite number")
        data.append(values)
    array = np.array(data)
    return {h: array[:, k] for k, h in enumerate(header)}, comments


def read_reference_csv(name: str) -> tuple[dict[str, np.ndarray], list[str]]:
    """Columns of a packaged reference CSV and its source comment lines."""
    text = resources.files("flexbody").joinpath("reference", name).read_text()
    return parse_csv(text, name)


def read_csv_file(path: str | Path) -> tuple[dict[str, np.ndarray], list[str]]:
    """Columns and comment lines of a reference CSV file (format of :func:`parse_csv`)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"reference CSV {str(path)!r} does not exist")
    return parse_csv(path.read_text(), str(path))
