"""Reference solutions shipped with flexbody (flexbody/reference/*.csv, sources in their '#' lines)."""

from __future__ import annotations

from importlib import resources

import numpy as np


def read_reference_csv(name: str) -> tuple[dict[str, np.ndarray], list[str]]:
    """Columns of a packaged reference CSV and its source comment lines."""
    text = resources.files("flexbody").joinpath("reference", name).read_text()
    comments = [line[1:].strip() for line in text.splitlines() if line.startswith("#")]
    rows = [line for line in text.splitlines() if line and not line.startswith("#")]
    header = rows[0].split(",")
    data = np.array([[float(v) for v in row.split(",")] for row in rows[1:]])
    return {h: data[:, k] for k, h in enumerate(header)}, comments
