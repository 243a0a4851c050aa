"""``--json -`` on every command that has ``--json``: standard output is the JSON document alone (read with
``json.loads``), the printed text goes to standard error. ``flexbody run``: tests/test_cli_show.py. Captured
at the file descriptors (``capfd``): a library printing from C would show up on standard output too."""

import importlib.util
import json
import os
from pathlib import Path

import pytest

from flexbody.cli import main

pytestmark = pytest.mark.usefixtures("one_numba_thread")

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
ANNULUS, PLATE = str(EXAMPLES / "kicked_spinning_annulus.toml"), str(EXAMPLES / "compressed_plate_scene.py")


def _json_alone(capfd):
    captured = capfd.readouterr()
    return json.loads(captured.out), captured.err


def test_modes_json_dash(capfd):
    assert main(["modes", ANNULUS, "--set", "n_radial=2", "--set", "n_circ=16",
                 "--count", "3", "--json", "-"]) == 0
    data, err = _json_alone(capfd)
    assert len(data["frequencies_rad_s"]) == 3 and data["frame"] == "co-rotating"
    assert "written          standard output" in err and "rad/s" in err       # the table went to stderr


def test_modes_sweep_json_dash(capfd):
    assert main(["modes", ANNULUS, "--set", "n_radial=2", "--set", "n_circ=16",
                 "--count", "2", "--sweep", "omega=0,10", "--json", "-", "--quiet"]) == 0
    data, err = _json_alone(capfd)
    assert data["parameter"] == "omega" and len(data["frequencies_rad_s"]) == 2
    assert "Campbell diagram" in err


def test_buckling_json_dash(capfd):
    assert main(["modes", PLATE, "--buckling", "--count", "2", "--json", "-"]) == 0
    data, err = _json_alone(capfd)
    assert len(data["load_factors"]) == 2 and data["load_factors"][0] > 0
    assert "critical load factor" in err


def test_sweep_json_dash(tmp_path, capfd):
    assert main(["sweep", "cantilever_end_shear", "--grid", "nx=2,3", "--set", "steps=2", "--workers", "0",
                 "--out", str(tmp_path), "--json", "-"]) == 0
    data, err = _json_alone(capfd)
    assert data == json.loads((tmp_path / "sweep.json").read_text())
    assert [r["status"] for r in data["runs"]] == ["ok", "ok"] and "sweep            2 of 2" in err


@pytest.mark.skipif(importlib.util.find_spec("exudyn") is None, reason="needs exudyn")
def test_compare_json_dash(capfd):
    assert main(["compare", "cantilever_end_shear", "--set", "nx=2", "--set", "steps=4",
                 "--set", "exudyn_model=beam2d", "--json", "-"]) == 0
    data, err = _json_alone(capfd)
    assert data["ok"] is True and data["scene"] == "cantilever_end_shear"
    assert "minus_U_tip" in err and "written          standard output" in err


def test_json_file_is_unchanged_and_nothing_is_left_behind(tmp_path, capfd, monkeypatch):
    """A file name still means the file (the table on stdout); ``-`` leaves no temporary file."""
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    out = tmp_path / "b.json"
    assert main(["modes", PLATE, "--buckling", "--count", "1", "--json", str(out)]) == 0
    assert "critical load factor" in capfd.readouterr().out and json.loads(out.read_text())["load_factors"]
    assert main(["modes", PLATE, "--buckling", "--count", "1", "--json", "-"]) == 0
    _json_alone(capfd)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.json"]


def test_what_a_library_prints_at_the_file_descriptor_goes_to_stderr(capfd, monkeypatch):
    """A library writing to descriptor 1 itself (as C code does) while the command runs: it lands on stderr."""
    import flexbody.buckling
    original = flexbody.buckling.linear_buckling

    def noisy(*args, **kwargs):
        os.write(1, b"printed from C\n")
        return original(*args, **kwargs)

    monkeypatch.setattr(flexbody.buckling, "linear_buckling", noisy)
    assert main(["modes", PLATE, "--buckling", "--count", "1", "--json", "-"]) == 0
    data, err = _json_alone(capfd)
    assert data["load_factors"] and "printed from C" in err
