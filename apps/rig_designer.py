"""Rig designer web app (trame + PyVista).

Run it with ``rigsim app [--port P] [--host H] [--workdir DIR]`` or directly::

    python apps/rig_designer.py --port 8080 --workdir ~/my-rigs

The app itself lives in :mod:`rigsim.ui.app` (so that the installed ``rigsim``
command can start it); this script only parses the same options.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--port", type=int, default=8080)
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--workdir", default=None, help="your folder for rig files (besides rigs/)")
    p.add_argument("--rig", default=None, help="rig file to open (inside rigs/ or --workdir)")
    p.add_argument("--view", default="server", choices=("server", "client"))
    a = p.parse_args(argv)
    from rigsim.errors import RigsimError
    from rigsim.ui.app import main as run

    try:
        run(host=a.host, port=a.port, workdir=a.workdir, rig=a.rig, view=a.view)
    except RigsimError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)


if __name__ == "__main__":
    main()
