"""A test client of the rig designer over its real interface: HTTP and trame's wslink websocket.

wslink frames are binary: a 12-byte header (message id, offset, total size; little-endian
uint32) and a chunk of a msgpack-encoded message ``{"wslink": "1.0", "id": ..., "method": ...,
"args": [...]}``.  A page says ``wslink.hello`` with the secret first, then calls
``trame.state.get``, ``trame.state.update`` (a list of ``{"key", "value"}``) and
``trame.trigger`` (a button's trigger name, its arguments); the server publishes state
changes on ``trame.state.topic``.

:func:`start_app` starts ``rigsim app`` in a child process and waits until it serves.
"""

from __future__ import annotations

import asyncio
import itertools
import os
import re
import secrets
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import msgpack

ROOT = Path(__file__).resolve().parents[2]
SECRET = "wslink-secret"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def frame(payload: bytes, *, msg_id: int | None = None, offset: int = 0, total: int | None = None) -> bytes:
    """One wslink chunk: header + payload (``total`` may lie, for abuse tests)."""
    msg_id = secrets.randbits(32) if msg_id is None else msg_id
    total = len(payload) if total is None else total
    return (msg_id.to_bytes(4, "little") + offset.to_bytes(4, "little") + (total & 0xFFFFFFFF).to_bytes(4, "little")
            + payload)


class App:
    """A running ``rigsim app`` (child process)."""

    def __init__(self, proc: subprocess.Popen, port: int, host: str, log: Path, workdir: Path):
        self.proc, self.port, self.host, self.log, self.workdir = proc, port, host, log, workdir

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}/"

    @property
    def ws_url(self) -> str:
        return f"ws://127.0.0.1:{self.port}/ws"

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self):
        if self.alive():
            self.proc.terminate()
            try:
                self.proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def log_text(self) -> str:
        return self.log.read_text(errors="replace")


def start_app(workdir: Path, *, host: str | None = None, extra: list[str] = (), timeout: float = 120,
              env: dict | None = None) -> App:
    port = free_port()
    log = workdir.parent / f"app-{port}.log"
    argv = [sys.executable, "-m", "rigsim.cli", "app", "--port", str(port), "--workdir", str(workdir), *extra]
    if host is not None:
        argv += ["--host", host]
    fh = open(log, "w")
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=fh, stderr=subprocess.STDOUT,
                            env={**os.environ, "PYTHONUNBUFFERED": "1", **(env or {})})
    app = App(proc, port, host or "127.0.0.1", log, workdir)
    deadline = time.time() + timeout
    while True:
        try:
            urllib.request.urlopen(app.url, timeout=2)
            return app
        except Exception:  # noqa: BLE001 - not up yet
            if proc.poll() is not None or time.time() > deadline:
                app.stop()
                raise AssertionError("the app did not start:\n" + app.log_text()[-3000:])
            time.sleep(0.3)


def _busy_processes() -> str:
    """``ps`` of the processes using the most CPU (to tell a slow server from a loaded machine)."""
    try:
        r = subprocess.run(["ps", "-eo", "pid,ppid,pcpu,rss,etime,args", "--sort=-pcpu"], capture_output=True,
                           text=True, timeout=10)
        return "\n".join(r.stdout.splitlines()[:12])
    except (OSError, subprocess.SubprocessError) as e:
        return f"(ps failed: {e})"


class Page:
    """One page's websocket session (async; use inside ``asyncio.run``)."""

    _ids = itertools.count(1)

    def __init__(self, app: App):
        self.app = app
        self.state: dict = {}
        self.replies: dict[str, dict] = {}
        self.published = 0
        self._session = None
        self.ws = None
        self._reader = None
        self._events: dict[str, asyncio.Event] = {}
        self.client_id = "c0"

    async def open(self, *, hello: bool = True):
        import aiohttp

        self._session = aiohttp.ClientSession()
        self.ws = await self._session.ws_connect(self.app.ws_url, max_msg_size=0)
        self._reader = asyncio.ensure_future(self._read())
        if hello:
            r = await self.call("wslink.hello", [{"secret": SECRET}], system=True)
            self.client_id = r["result"]["clientID"]
            st = await self.call("trame.state.get")
            self.state.update(st["result"]["state"])
        return self

    async def close(self):
        if self._reader:
            self._reader.cancel()
        if self.ws is not None:
            await self.ws.close()
        if self._session is not None:
            await self._session.close()

    async def __aenter__(self):
        return await self.open()

    async def __aexit__(self, *exc):
        await self.close()

    async def _read(self):
        import aiohttp

        pending: dict[int, bytearray] = {}
        got: dict[int, int] = {}
        async for msg in self.ws:
            if msg.type != aiohttp.WSMsgType.BINARY:
                continue
            data = msg.data
            mid = int.from_bytes(data[0:4], "little")
            off = int.from_bytes(data[4:8], "little")
            total = int.from_bytes(data[8:12], "little")
            buf = pending.setdefault(mid, bytearray(total))
            buf[off:off + len(data) - 12] = data[12:]
            got[mid] = got.get(mid, 0) + len(data) - 12
            if got[mid] < total:
                continue
            del pending[mid], got[mid]
            try:
                m = msgpack.unpackb(bytes(buf), raw=False, strict_map_key=False)
            except Exception:  # noqa: BLE001 - attachments etc.
                continue
            rid = m.get("id", "") if isinstance(m, dict) else ""
            if isinstance(rid, str) and rid.startswith("publish:trame.state.topic"):
                res = m.get("result")
                if isinstance(res, dict):
                    self.state.update(res)
                    self.published += 1
            elif rid:
                self.replies[rid] = m
                ev = self._events.get(rid)
                if ev:
                    ev.set()

    async def send_raw(self, data: bytes):
        await self.ws.send_bytes(data)

    async def send(self, message: dict):
        await self.send_raw(frame(msgpack.packb(message, use_bin_type=True)))

    async def call(self, method: str, args=(), *, system: bool = False, timeout: float = 60) -> dict:
        rid = f"{'system' if system else 'rpc'}:{self.client_id}:{next(self._ids)}"
        ev = self._events[rid] = asyncio.Event()
        await self.send({"wslink": "1.0", "id": rid, "method": method, "args": list(args), "kwargs": {}})
        await asyncio.wait_for(ev.wait(), timeout)
        del self._events[rid]
        return self.replies.pop(rid)

    async def update(self, **changes) -> dict:
        self.state.update(changes)
        return await self.call("trame.state.update", [[{"key": k, "value": v} for k, v in changes.items()]])

    def trigger_name(self, element_id: str) -> tuple[str, list[str]]:
        """The trigger a button with HTML ``id`` sends, and the state names it passes (from the layout)."""
        for key, value in self.state.items():
            if not key.startswith("trame__template") or not isinstance(value, str):
                continue
            for tag in re.findall(r"<[^<>]*\bid=\"" + re.escape(element_id) + r"\"[^<>]*>", value):
                m = re.search(r"trigger\('([^']+)'(?:,\s*\[([^\]]*)\])?", tag.replace("&quot;", '"').replace("&#39;", "'"))
                if m:
                    names = [x.strip() for x in (m.group(2) or "").split(",") if x.strip()]
                    return m.group(1), names
        raise KeyError(f"no button with id {element_id!r} in the page's template")

    async def click(self, element_id: str, **values) -> dict:
        """Press a button as the page does: the trigger with the values it shows."""
        name, arg_names = self.trigger_name(element_id)
        args = [values.get(n, self.state.get(n)) for n in arg_names]
        return await self.call("trame.trigger", [name, args, {}])

    async def settle(self, key: str = "preview_busy", *, timeout: float = 120):
        """Wait until the server has finished the work of the last edits (``preview_busy`` false)."""
        t0 = time.time()
        while time.time() - t0 < timeout:
            st = (await self.call("trame.state.get"))["result"]["state"]
            if not st.get(key) and not st.get("compare_busy"):
                await asyncio.sleep(0.5)
                st2 = (await self.call("trame.state.get"))["result"]["state"]
                if not st2.get(key) and not st2.get("compare_busy"):
                    return st2
            await asyncio.sleep(0.3)
        busy = [k for k in (key, "compare_busy") if st.get(k)]
        raise TimeoutError(f"{' and '.join(busy) or key} still true after {timeout:g} s\n"
                           f"--- the app's log (end) ---\n{self.app.log_text()[-3000:]}\n"
                           f"--- busy processes ---\n{_busy_processes()}")
