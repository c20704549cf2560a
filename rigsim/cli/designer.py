"""``rigsim app``: start the rig designer web app (trame + PyVista) — a thin wrapper over :mod:`rigsim.ui.app`."""

from __future__ import annotations

from pathlib import Path

import typer

from rigsim.cli import app


@app.command("app")
def run_app(
    port: int = typer.Option(8080, "--port", help="TCP port to listen on."),
    host: str = typer.Option("127.0.0.1", "--host", help="Address to listen on (0.0.0.0: every interface)."),
    workdir: Path = typer.Option(None, "--workdir", help="Your folder for rig files (read and written, besides rigs/)."),
    rig: str = typer.Option(None, "--rig", help="Rig file to open (inside rigs/ or --workdir)."),
    view: str = typer.Option("server", "--view", help="3-D view rendering: server (images, no GPU needed) or client (WebGL)."),
    open_browser: bool = typer.Option(False, "--open", help="Open a browser tab."),
    preview_width: int = typer.Option(960, "--preview-width", min=64, max=4096,
                                      help="Width of the live predicted photograph (px)."),
):
    """Open the rig designer: 3-D rig layout, predicted photographs, contrast/SNR/ΔE, side-by-side comparisons."""
    from rigsim.errors import ConfigError
    from rigsim.ui.app import main

    if view not in ("server", "client"):
        raise ConfigError(f"unknown view {view!r}", field="--view", allowed="server, client")
    main(host=host, port=port, workdir=str(workdir) if workdir else None, rig=rig, open_browser=open_browser,
         view=view, preview_width=preview_width)
