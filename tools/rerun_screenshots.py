"""Regenerate the screenshots of the rerun viewer in docs/images/ (shown in docs/output_formats.md).

Each scene is run with ``flexbody run SCENE --rerun FILE.rrd``; the viewer then opens the recording under
a virtual X server (Xvfb) with the recording's own blueprint (:func:`flexbody.outputs.rerun_log.blueprint`)
and a time panel that follows the last step (so the picture shows the end of the run), renders it in
software (Mesa's llvmpipe through Vulkan) and saves a screenshot (``rerun --screenshot-to``). The PNG is
then halved to the window's size in points.

Needs: rerun-sdk (the viewer ships in its wheel), Xvfb and a software Vulkan driver; on Debian
``apt-get install xvfb mesa-vulkan-drivers libgl1-mesa-dri``, and Pillow for the resize.

    python tools/rerun_screenshots.py [--out docs/images] [--size 1400x900] [--keep DIR]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: (file stem, scene, --set parameters): a static path and a spinning membrane
SHOTS = [
    ("rerun_static_end_moment", "cantilever_end_moment", []),
    ("rerun_spinning_membrane", "spinning_membrane", []),
]


def _env() -> dict:
    path = os.pathsep.join(filter(None, [str(REPO), os.environ.get("PYTHONPATH")]))
    return dict(os.environ, PYTHONPATH=path)


def record(scene: str, params: list[str], rrd: Path) -> None:
    """Run the scene with a rerun recording."""
    sets = [arg for p in params for arg in ("--set", p)]
    subprocess.run([sys.executable, "-m", "flexbody.cli", "run", scene, *sets, "--rerun", str(rrd), "--quiet"],
                   check=True, env=_env(), stdout=subprocess.DEVNULL)


def screenshot_blueprint(scene: str, params: list[str], path: Path) -> None:
    """The recording's blueprint with the time panel following the last step, saved as a .rbl file."""
    import rerun.blueprint as rrb

    from flexbody.cli.scene_input import build_scene, open_source
    from flexbody.cli.values import parse_sets
    from flexbody.outputs.rerun_log import TIMELINES, blueprint
    built = build_scene(open_source(scene), parse_sets(params))
    references = tuple(built.reference.values) if built.reference is not None else ()
    layout = blueprint([o.name for o in built.outputs], built.kind, references)
    timeline = TIMELINES[built.kind]
    rrb.Blueprint(layout.root_container, rrb.TimePanel(timeline=timeline, play_state="following", expanded=False),
                  collapse_panels=True).save("flexbody", str(path))


def shoot(rrd: Path, rbl: Path, png: Path, size: str) -> None:
    """Open the recording in the viewer under Xvfb and save a screenshot."""
    width, height = (int(v) for v in size.split("x"))
    command = ["xvfb-run", "-a", "-s", f"-screen 0 {width + 200}x{height + 200}x24", "rerun", str(rrd), str(rbl),
               "--window-size", size, "--screenshot-to", str(png)]
    out = subprocess.run(command, capture_output=True, text=True, timeout=300,
                         env=dict(_env(), XDG_RUNTIME_DIR=tempfile.gettempdir()))
    if out.returncode != 0 or not png.exists():
        tail = "\n".join((out.stdout + out.stderr).splitlines()[-15:])
        raise RuntimeError(f"the viewer saved no screenshot (exit code {out.returncode}):\n{tail}")


def shrink(png: Path, size: str) -> None:
    """Resize the screenshot (saved at twice the points) to the window's size in points."""
    from PIL import Image
    width, height = (int(v) for v in size.split("x"))
    with Image.open(png) as image:
        small = image.convert("RGB").resize((width, height), Image.LANCZOS)
    small.save(png, optimize=True)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(REPO / "docs" / "images"), help="directory of the PNGs")
    parser.add_argument("--size", default="1400x900", help="viewer window in points, WIDTHxHEIGHT")
    parser.add_argument("--keep", metavar="DIR", help="keep the recordings and blueprints in DIR")
    args = parser.parse_args(argv)
    missing = [tool for tool in ("xvfb-run", "rerun") if shutil.which(tool) is None]
    if missing:
        print(f"rerun_screenshots: missing {', '.join(missing)} (apt-get install xvfb mesa-vulkan-drivers; "
              "pip install rerun-sdk)", file=sys.stderr)
        return 1
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="flexbody-shots-"))
    work.mkdir(parents=True, exist_ok=True)
    try:
        for stem, scene, params in SHOTS:
            rrd, rbl, png = work / f"{stem}.rrd", work / f"{stem}.rbl", out / f"{stem}.png"
            record(scene, params, rrd)
            screenshot_blueprint(scene, params, rbl)
            shoot(rrd, rbl, png, args.size)
            shrink(png, args.size)
            print(f"written          {png}")
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
