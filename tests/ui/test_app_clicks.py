"""The rig designer's buttons act on the values the page showed when they were clicked.

The trame page defers its state updates while a request is in flight but sends a click at
once, so the server can see a click before the name typed just before it.  The buttons that
read a field (Save, Load, Render, remove light) therefore carry that field with the click.
Tested on an app built in this process (no server, no browser): the server's state holds a
stale value, the click carries the new one.
"""

from __future__ import annotations

import pytest

from rigsim.config.rig import load_rig


@pytest.fixture()
def app(tmp_path):
    from rigsim.ui.app import create_app

    a = create_app(workdir=tmp_path, name=f"clicks-{tmp_path.name}")
    yield a
    a.pool.shutdown(wait=False)
    a.plotter.close()


def test_save_uses_the_name_sent_with_the_click(app, tmp_path):
    app.state.save_name = "stale.toml"  # what the server last heard
    app.save_rig("typed.toml", "work", False)  # what the page showed at the click
    assert "Saved work/typed.toml" in app.state.file_message, app.state.file_message
    assert (tmp_path / "typed.toml").is_file() and not (tmp_path / "stale.toml").exists()
    assert app.state.save_name == "typed.toml"
    load_rig(tmp_path / "typed.toml")

    app.save_rig("../escape.toml", "work", False)
    assert app.state.file_message.startswith("Refused") and "../escape.toml" in app.state.file_message
    app.save_rig("typed.toml", "work", False)  # exists, overwrite not ticked
    assert app.state.file_message.startswith("Refused"), app.state.file_message
    app.save_rig("typed.toml", "work", True)
    assert app.state.file_message.startswith("Saved"), app.state.file_message


def test_load_and_remove_use_the_values_sent_with_the_click(app, tmp_path):
    app.save_rig("two.toml", "work", False)
    n = len(app.doc.light_names())
    assert n >= 2, "the default rig has two strobes"
    names = app.doc.light_names()
    app.state.light_index = 0
    app.remove_light(n - 1)  # the page showed the last light selected
    assert app.doc.light_names() == names[:-1]

    app.state.file_sel = None  # stale: nothing chosen yet
    app.load_rig("work/two.toml")
    assert app.state.file_message == "Loaded work/two.toml", app.state.file_message
    assert app.doc.light_names() == names
