"""The rig designer under abuse, over its real interface (HTTP and the wslink websocket of a
running ``rigsim app``), not in-process: where it listens, path traversal in Save/Load, malformed
and oversized messages, and rapid concurrent edits from two pages.

The client (``tests/ui/wsclient.py``) speaks the page's protocol: it says hello, reads the state,
sends state updates and presses buttons by the trigger names in the page's template.
"""

from __future__ import annotations

import asyncio
import http.client
import os
import random
import socket
import tomllib
from pathlib import Path

import msgpack
import pytest

from rigsim.ui.app import _CARRIED_BY_CLICKS
from tests.ui.wsclient import ROOT, Page, frame, start_app

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.fixture(scope="module")
def app(tmp_path_factory):
    base = tmp_path_factory.mktemp("designer")
    work = base / "work"
    work.mkdir()
    outside = base / "outside"
    outside.mkdir()
    (outside / "secret.toml").write_text('[rig]\nname = "outside"\n')
    os.symlink(outside, work / "link-dir")
    os.symlink(outside / "secret.toml", work / "link-file.toml")
    # abuse, not image size, is tested here: a small live preview keeps each edit's work short on a
    # loaded 2-core machine (the photograph-sized default is tested in test_app_browser.py)
    a = start_app(work, extra=["--preview-width", "240"])
    a.outside = outside
    yield a
    a.stop()


def run(coro):
    return asyncio.run(coro)


def _listening(port: int) -> list[str]:
    """Local addresses of listening TCP sockets on ``port`` (from /proc/net/tcp and tcp6)."""
    out = []
    for name in ("tcp", "tcp6"):
        try:
            lines = Path(f"/proc/net/{name}").read_text().splitlines()[1:]
        except OSError:
            continue
        for ln in lines:
            parts = ln.split()
            local, st = parts[1], parts[3]
            addr, p = local.rsplit(":", 1)
            if int(p, 16) == port and st == "0A":  # LISTEN
                out.append(addr)
    return out


def _lan_address() -> str | None:
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            s.connect(("10.255.255.255", 1))
            ip = s.getsockname()[0]
    except OSError:
        return None
    return None if ip.startswith("127.") else ip


# ------------------------------------------------------------------------------------ where it listens

def test_listens_on_loopback_only_by_default(app):
    addrs = _listening(app.port)
    assert addrs and all(a in ("0100007F", "00000000000000000000000001000000") for a in addrs), addrs
    lan = _lan_address()
    if lan:
        with pytest.raises(OSError):
            socket.create_connection((lan, app.port), timeout=2).close()
    assert "warning" not in app.log_text()


def test_every_interface_only_when_asked_and_with_a_warning(tmp_path):
    work = tmp_path / "w"
    work.mkdir()
    a = start_app(work, host="0.0.0.0")
    try:
        assert "00000000" in _listening(a.port)
        log = a.log_text()
        assert "warning: the rig designer listens on 0.0.0.0" in log and "127.0.0.1 keeps it local" in log
    finally:
        a.stop()


def test_a_port_in_use_is_one_line(app, tmp_path):
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-m", "rigsim.cli", "app", "--port", str(app.port)], cwd=ROOT,
                       capture_output=True, text=True, timeout=120, env={**os.environ, "RIGSIM_GL_CHECK": "0"})
    assert r.returncode == 2 and "Traceback" not in r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and "--port" in lines[0] and "in use" in lines[0], r.stderr


# ------------------------------------------------------------------------------------ Save / Load paths

#: Names that must be refused in either folder (names fine in rigs/, like link-file.toml, only in work/:
#: nothing here may write into the repository's rigs/).
SAVE_NAMES = ["../escaped.toml", "../../escaped.toml", "/tmp/rigsim-escaped.toml", "~/rigsim-escaped.toml",
              "..%2fescaped.toml", "%2e%2e%2fescaped.toml", "%2E%2E/escaped.toml", "sub/../../escaped.toml",
              "escaped.toml\x00.txt", "..\\escaped.toml", "x" * 300 + ".toml", "escaped.py", "",
              str(ROOT / "pyproject.toml"), str(ROOT / "rigs" / ".." / "escaped.toml")]
WORK_ONLY = ["link-dir/escaped.toml", "link-file.toml", "....//escaped.toml"]


def test_save_outside_the_folders_is_refused(app):
    async def go():
        async with Page(app) as p:
            for name, folder in [(n, f) for n in SAVE_NAMES for f in ("work", "rigs")] + [(n, "work") for n in WORK_ONLY]:
                if True:
                    await p.update(save_name=name, save_folder=folder, save_overwrite=True)
                    await p.click("save-btn", save_name=name, save_folder=folder, save_overwrite=True)
                    st = (await p.call("trame.state.get"))["result"]["state"]
                    assert st["file_message"].startswith("Refused"), (name, folder, st["file_message"])
            return p

    run(go())
    outside = app.outside
    assert sorted(x.name for x in outside.iterdir()) == ["secret.toml"]
    assert (outside / "secret.toml").read_text() == '[rig]\nname = "outside"\n'  # not overwritten via the link
    for p in (app.workdir.parent / "escaped.toml", app.workdir.parent.parent / "escaped.toml",
              Path("/tmp/rigsim-escaped.toml"), Path.home() / "rigsim-escaped.toml", ROOT / "escaped.toml"):
        assert not p.exists(), p
    assert not list(app.workdir.glob("*escaped*"))  # URL-encoded names are refused, not saved under odd names


LOAD_SELECTIONS = ["work/../../outside/secret.toml", "rigs/../pyproject.toml", "rigs/../../etc/passwd",
                   "work/link-file.toml", "work/link-dir/secret.toml", "work/%2e%2e%2foutside%2fsecret.toml",
                   "etc/passwd", "/etc/passwd", "work//etc/passwd", "rigs/" + "../" * 20 + "etc/passwd", "", None,
                   "work", "rigs/"]


def test_load_outside_the_folders_is_refused(app):
    async def go():
        async with Page(app) as p:
            before = p.state["save_name"]
            for sel in LOAD_SELECTIONS:
                await p.click("load-btn", file_sel=sel)
                st = (await p.call("trame.state.get"))["result"]["state"]
                assert st["file_message"].startswith("Refused"), (sel, st["file_message"])
                assert st["save_name"] == before  # no other rig was opened
            # the comparison's rig B goes through the same check
            await p.update(compare_mode="rigs", compare_rig_b="rigs/../pyproject.toml")
            st = await p.settle()
            assert "Refused" in st["compare_info"] and "pyproject" not in str(st["compare_cells"])
            await p.update(compare_mode="waters")

    run(go())


def test_http_paths_cannot_leave_the_web_root(app):
    for path in ["/../../../../etc/passwd", "/%2e%2e/%2e%2e/%2e%2e/etc/passwd", "/..%2f..%2f..%2fetc%2fpasswd",
                 "/static/../../../../etc/passwd", "//etc/passwd", "/rigs/twin-strobes-45-wide.toml",
                 "/%2e%2e%2f%2e%2e%2fpyproject.toml", "/..\\..\\pyproject.toml"]:
        c = http.client.HTTPConnection("127.0.0.1", app.port, timeout=10)
        c.request("GET", path)
        r = c.getresponse()
        body = r.read()
        c.close()
        assert b"root:x:0:0" not in body and b"[build-system]" not in body and b"[camera]" not in body, path
    assert app.alive()


# ------------------------------------------------------------------------------------ malformed messages

async def _still_works(app, water="clear") -> dict:
    """A fresh page connects, edits, and gets a new preview."""
    async with Page(app) as p:
        await p.settle()
        await p.update(water=water)
        st = await p.settle()
        assert f"· {water} ·" in st["preview_title"], st["preview_title"]
        return st


def _rss_mb(pid: int) -> float:
    for ln in Path(f"/proc/{pid}/status").read_text().splitlines():
        if ln.startswith("VmRSS:"):
            return int(ln.split()[1]) / 1024
    return 0.0


def test_malformed_and_oversized_messages_do_not_stop_the_server(app):
    import aiohttp

    async def attempt(sender, *, hello=True):
        p = Page(app)
        try:
            await p.open(hello=hello)
            await sender(p)
            await asyncio.sleep(0.2)
        except (aiohttp.ClientError, ConnectionError, asyncio.TimeoutError, RuntimeError):
            pass  # the server may close this connection: that is fine
        finally:
            await p.close()

    async def go():
        rss0 = _rss_mb(app.proc.pid)
        cases = [
            (lambda p: p.ws.send_str("not binary at all"), False),
            (lambda p: p.send_raw(b"\x00"), False),
            (lambda p: p.send_raw(os.urandom(11)), False),
            (lambda p: p.send_raw(os.urandom(5000)), False),
            (lambda p: p.send_raw(frame(b"\xc1\xc1 not msgpack")), True),
            (lambda p: p.send_raw(frame(msgpack.packb([1, 2, 3]))), True),
            (lambda p: p.send_raw(frame(msgpack.packb("id method"))), True),
            (lambda p: p.send_raw(frame(msgpack.packb({"id": "rpc:c0:9"}))), True),
            (lambda p: p.send({"wslink": "1.0", "id": "rpc:c0:9", "method": "no.such.method", "args": []}), True),
            (lambda p: p.send({"wslink": "1.0", "id": "rpc:c0:9", "method": "trame.state.update", "args": "x"}),
             True),
            (lambda p: p.send({"wslink": "1.0", "id": "rpc:c0:9", "method": "trame.state.update",
                               "args": [[{"nokey": 1}]]}), True),
            (lambda p: p.send({"wslink": "1.0", "id": "rpc:c0:9", "method": "trame.trigger",
                               "args": ["trigger__999", [], {}]}), True),
            (lambda p: p.send({"wslink": "1.0", "id": "rpc:c0:9", "method": "trame.trigger",
                               "args": ["trigger__4", [1, 2, 3, 4, 5, 6], {"bogus": 1}]}), True),
            # not authenticated: refused before anything runs
            (lambda p: p.send({"wslink": "1.0", "id": "rpc:c0:9", "method": "trame.state.update",
                               "args": [[{"key": "water", "value": "jerlov-II"}]]}), False),
            # oversized: a header claiming 3 GB (the server must not allocate it), a frame over 4 MB,
            # and many half-sent messages
            (lambda p: p.send_raw(frame(b"x" * 100, total=3 << 30)), True),
            (lambda p: p.send_raw(frame(b"x" * (5 << 20))), True),
            (lambda p: asyncio.gather(*[p.send_raw(frame(b"x" * 1000, total=8 << 20)) for _ in range(200)]), True),
            (lambda p: p.send_raw(frame(b"x" * 100, total=3 << 30)), False),
        ]
        for send, hello in cases:
            await attempt(send, hello=hello)
            assert app.alive(), app.log_text()[-2000:]
        await _still_works(app, "clear")
        assert _rss_mb(app.proc.pid) - rss0 < 500, "the server's memory grew by half a gigabyte"

    run(go())


DESIGNER_VARS = ["water", "use_constituents", "chl", "cdom", "small", "large", "depth_m", "distance_m", "target",
                 "target_size", "sensor", "exposure_mode", "shutter_inv", "iso", "flash_pct", "white_balance",
                 "light_index", "l_name", "l_arm_length_m", "l_arm_angle_deg", "l_arm_forward_m", "l_yaw_deg",
                 "l_pitch_deg", "l_beam_angle_deg", "l_spectrum", "l_guide_number_m", "l_flash_energy_J",
                 "l_power_fraction", "l_lumens", "l_aim_r", "l_aim_u", "l_aim_f", "l_aim_mode", "l_power_mode",
                 "c_focal_length_mm", "c_f_number", "c_housing_radius_m", "c_port_kind", "c_port_radius_m",
                 "c_rig_name", "compare_mode", "compare_waters", "compare_distances", "compare_rig_b",
                 "compare_auto", "render_quality", "save_name", "save_folder", "save_overwrite", "file_sel"]
WEIRD = [None, "", "abc", -1, 0, 1e308, float("nan"), float("inf"), -1e9, 2**63, True, [], {}, [1, 2], {"a": 1},
         "💧" * 50, "x" * 20000, "../../etc/passwd", [None], 3.5]


def test_state_updates_of_every_kind_do_not_break_the_designer(app):
    """Every variable a page can send, with values of the wrong type and range: the server stays
    up, refuses with a message, and a page can go on editing (the state is not left unusable)."""
    rnd = random.Random(19)

    async def go():
        async with Page(app) as p:
            await p.settle()
            for _round in range(3):
                for var in DESIGNER_VARS:
                    changes = {var: rnd.choice(WEIRD)}
                    if rnd.random() < 0.3:
                        changes[rnd.choice(DESIGNER_VARS)] = rnd.choice(WEIRD)
                    r = await p.update(**changes)
                    assert "error" not in r or r["error"]["code"] != -32001, r  # never "unauthorized"
                    assert app.alive(), app.log_text()[-2000:]
        # another page puts valid values back and the designer works again
        async with Page(app) as q:
            await q.update(water="coastal", use_constituents=False, depth_m=5, distance_m=1.5, target="colorchecker",
                           target_size="fills 50% of frame", sensor="sony_ilce-7rm2", exposure_mode="auto",
                           white_balance="auto", light_index=0, compare_mode="waters",
                           compare_waters=["coastal", "clear"], compare_auto=True)
            st = await q.settle()
            assert "· coastal ·" in st["preview_title"]
            await q.update(water="jerlov-II")
            st = await q.settle()
            assert "· jerlov-II ·" in st["preview_title"] and st["message_type"] != "error", st["message"]
            assert "Traceback" not in str(st.get("message"))

    run(go())
    assert app.alive()


# ------------------------------------------------------------------------------------ concurrent edits

def test_twenty_rapid_concurrent_edits_from_two_pages_leave_a_consistent_state(app):
    angles = [60 + 3 * i for i in range(20)]
    waters = ["clear", "coastal", "jerlov-II", "oceanic"]

    async def go():
        a, b = Page(app), Page(app)
        await a.open()
        await b.open()
        try:
            await a.settle()
            await a.update(light_index=0)

            async def edits(page, mine):
                for i in mine:
                    await page.update(l_beam_angle_deg=angles[i], water=waters[i % 4], distance_m=1.0 + 0.1 * i)

            # 20 edits, interleaved from the two pages without waiting for any preview
            await asyncio.wait_for(asyncio.gather(edits(a, range(0, 20, 2)), edits(b, range(1, 20, 2))), 60)
            final = await a.settle(timeout=180)  # no deadlock: the work ends
            await asyncio.sleep(1.0)
            sa = (await a.call("trame.state.get"))["result"]["state"]
            sb = (await b.call("trame.state.get"))["result"]["state"]
            for k in ("l_beam_angle_deg", "water", "distance_m", "preview_title", "preview_gen", "light_items"):
                assert sa[k] == sb[k], (k, sa[k], sb[k])
                assert a.state.get(k) == b.state.get(k) == sa[k], (k, a.state.get(k), b.state.get(k), sa[k])
            # what the pages show is what the server computed: the preview is of the final values
            assert f"· {sa['water']} · {sa['distance_m']:g} m ·" in final["preview_title"], final["preview_title"]
            assert sa["preview_gen"] == final["preview_gen"]
            # and what it would save: the rig file has the final beam angle
            await a.update(save_folder="work", save_name="concurrent.toml", save_overwrite=True)
            await a.click("save-btn", save_name="concurrent.toml", save_folder="work", save_overwrite=True)
            saved = tomllib.loads((app.workdir / "concurrent.toml").read_text())
            assert saved["lights"][0]["beam_angle_deg"] == pytest.approx(float(sa["l_beam_angle_deg"]))
            assert float(sa["l_beam_angle_deg"]) in [float(x) for x in angles]
        finally:
            await a.close()
            await b.close()

    run(go())
    assert app.alive()


def test_the_save_as_name_a_page_types_is_not_sent_back_over_newer_typing(app):
    """The server sends every page its values of what was edited 0.4 s after the edits stop; for the "save as"
    name that crossed a newer name being typed (the page's state held the old name, and Save carried it): the
    values the file buttons carry are not sent back."""
    async def go():
        async with Page(app) as a:
            await a.settle()
            first = {"save_name": "first.toml", "save_folder": "rigs", "save_overwrite": False, "file_sel": None}
            newer = {"save_name": "second.toml", "save_folder": "work", "save_overwrite": True,
                     "file_sel": "rigs/twin-strobes-45-wide.toml"}
            assert set(first) == set(_CARRIED_BY_CLICKS)
            await a.update(**first)
            a.state.update(newer)  # changed since, still in the page
            await asyncio.sleep(1.5)  # past the server's resend of the values edited
            assert {k: a.state[k] for k in newer} == newer
            await a.update(distance_m=1.7)  # the values the server does send back still come
            a.state["distance_m"] = 9.9
            await asyncio.sleep(1.5)
            assert a.state["distance_m"] == pytest.approx(1.7)

    run(go())
    assert app.alive()


# ------------------------------------------------------------------------------------ in process

def test_every_variable_with_a_wrong_value_is_handled_by_its_callback(caplog):
    """In process, so that the server's own log can be read: no change callback fails on a value
    of the wrong type (trame would log and ignore it, and the page would get no message)."""
    import logging

    from rigsim.ui.app import create_app

    asyncio.set_event_loop(asyncio.new_event_loop())  # as in the server (asyncio.run above closed the last one)
    app = create_app(name="abuse-in-process")
    app.state.ready()
    with caplog.at_level(logging.WARNING):
        for var in DESIGNER_VARS:
            for v in WEIRD:
                with app.state:
                    app.state[var] = v
    ignored = [r.getMessage() for r in caplog.records if "callback exception" in r.getMessage()]
    assert not ignored, sorted(set(ignored))
    with app.state:  # and the selected light is a usable one again
        app.state.light_index = 0
    assert app.doc.light_view(app._index())["name"]


def test_the_server_serves_until_stopped(monkeypatch):
    """``rigsim app`` asks trame for no idle timeout (its default ends the server 300 s after the last
    page disconnects)."""
    import rigsim.ui.app as ui

    seen = {}

    class FakeServer:
        def start(self, **kw):
            seen.update(kw)

    class FakeApp:
        server = FakeServer()

        class sandbox:
            @staticmethod
            def describe():
                return "rigs"

    monkeypatch.setenv("RIGSIM_GL_CHECK", "0")
    monkeypatch.setattr(ui, "create_app", lambda **kw: FakeApp())
    from tests.ui.wsclient import free_port

    ui.main(port=free_port())
    assert seen["timeout"] == 0 and seen["host"] == "127.0.0.1"
