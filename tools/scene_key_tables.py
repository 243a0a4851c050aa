"""Write the key tables of docs/scenes.md from the scene-file table specs (:mod:`flexbody.scenes.toml_spec`).

Usage::

    python tools/scene_key_tables.py            # rewrite the generated regions of docs/scenes.md
    python tools/scene_key_tables.py --check    # exit 1 (and say so) if docs/scenes.md lags the specs

The regions are marked ``<!-- generated: scene keys NAME -->`` ... ``<!-- end generated -->``
(:mod:`flexbody.scenes.toml_key_tables`); the text around them is left as it is.
"""

from __future__ import annotations

import argparse
from pathlib import Path
import sys

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from flexbody.scenes.toml_key_tables import regions, rewrite  # noqa: E402

DOC = ROOT / "docs" / "scenes.md"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="only check that docs/scenes.md is up to date")
    parser.add_argument("--doc", type=Path, default=DOC, help="the markdown file (default: docs/scenes.md)")
    args = parser.parse_args(argv)
    text = args.doc.read_text(encoding="utf-8")
    new = rewrite(text)
    if args.check:
        if new != text:
            print(f"{args.doc} lags the scene-file specs; run python tools/scene_key_tables.py", file=sys.stderr)
            return 1
        print(f"{args.doc}: {len(regions(text))} generated key tables up to date")
        return 0
    if new != text:
        args.doc.write_text(new, encoding="utf-8")
        print(f"{args.doc}: {len(regions(text))} generated key tables rewritten")
    else:
        print(f"{args.doc}: {len(regions(text))} generated key tables already up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
