"""The rig designer in a real browser: start the app, load the page in headless Chromium, edit, compare.

Checks what a diver sees: changing the water preset and a strobe's angle changes the
predicted image and its numbers; an invalid edit is refused with a message (no crash);
saving outside ``rigs/`` and the work folder is refused; saving inside it writes a rig
file that the CLI's loader reads back.  A screenshot is kept under
``artifacts/ui/rig_designer.png`` (path printed).
"""

from __future__ import annotations

import math
import os
import shutil
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CHROMIUM = os.environ.get("RIGSIM_CHROMIUM", "/usr/bin/chromium")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking"]



def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    if not (Path(CHROMIUM).is_file() or shutil.which(CHROMIUM)):
        pytest.skip(f"no Chromium at {CHROMIUM} (set RIGSIM_CHROMIUM)")
    pytest.importorskip("playwright.sync_api", reason="playwright (pip) is needed for the browser test")
    work = tmp_path_factory.mktemp("work")
    port = _free_port()
    log = open(work.parent / "app.log", "w")
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, str(ROOT / "apps" / "rig_designer.py"), "--port", str(port),
                             "--workdir", str(work)], cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, env=env)
    url = f"http://127.0.0.1:{port}/"
    deadline = time.time() + 60
    while True:
        try:
            urllib.request.urlopen(url, timeout=2)
            break
        except Exception:
            if proc.poll() is not None or time.time() > deadline:
                proc.kill()
                log.close()
                raise AssertionError("the app did not start:\n" + (work.parent / "app.log").read_text()[-3000:])
            time.sleep(0.5)
    yield {"url": url, "work": work, "proc": proc}
    proc.terminate()
    try:
        proc.wait(timeout=10)
    except subprocess.TimeoutExpired:
        proc.kill()
    log.close()


_STATE_JS = """() => {
  const text = (sel) => { const el = document.querySelector(sel); return el ? el.textContent : null; };
  const img = document.querySelector('#preview-img');
  const metrics = {};
  for (const k of ['contrast_radiance', 'contrast_image', 'backscatter_share', 'snr_white', 'delta_e_mean'])
    metrics[k] = text('#m-' + k);
  return {info: text('#preview-info'), title: text('#preview-title'),
          src: img ? img.getAttribute('src') : null, metrics: metrics,
          busy: document.querySelectorAll('.v-card-title .v-progress-circular').length > 0};
}"""


def _state(page) -> dict:
    """The preview's title, info, image and numbers, read in one go inside the page: read one
    by one, an update arriving between the reads paired new titles with old numbers."""
    return page.evaluate(_STATE_JS)


def _wait_new_preview(page, before: dict, timeout_s: float = 40.0, want: str | None = None) -> dict:
    """Wait until the preview shows a newer generation (whose title contains ``want``, when
    given: the conditions just chosen), and nothing is pending."""
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        now = _state(page)
        if now["info"] != before["info"] and now["src"] and not now["busy"] and (want is None or want in now["title"]):
            return now
        time.sleep(0.3)
    raise AssertionError(f"the preview did not update: {before['info']!r}")


def _wait_text(page, selector: str, *needles: str, timeout_s: float = 60.0) -> str:
    """Wait until the element's text contains every needle; on timeout, say what it showed."""
    deadline = time.time() + timeout_s
    text = None
    while time.time() < deadline:
        text = page.evaluate("(s) => { const e = document.querySelector(s); return e ? e.textContent : null; }",
                             selector)
        if text is not None and all(n in text for n in needles):
            return text
        time.sleep(0.3)
    raise AssertionError(f"{selector} never showed {needles!r} within {timeout_s:g} s; it shows {text!r}")


_SENT_JS = """() => { const st = window.trame && window.trame.state;
  return !st || !st.dirtyKeys || st.dirtyKeys.size === 0; }"""


def _save_as(page, name: str, outcome: str, server: dict) -> None:
    """Type ``name`` into "save as", click Save and wait for the message naming it.

    Typed and clicked at machine speed, the name may still be only in the page (trame defers a
    page's state while a request is in flight, and a state message from the server then
    overwrites it); the click carries the name anyway, but waiting until the page has sent what
    was typed is what a person's pace gives. On a timeout the failure says what the field showed
    and what the app logged."""
    field = page.locator("#save-name")
    field.fill(name)
    assert field.input_value() == name
    held = "() => window.trame ? window.trame.state.get('save_name') : null"
    try:  # the click carries the page's state, not the field's text: wait until the state holds the name
        page.wait_for_function("(n) => window.trame && window.trame.state.get('save_name') === n", arg=name,
                               timeout=10_000)
        page.wait_for_function(_SENT_JS, timeout=10_000)
    except Exception:
        pass  # still pending after 10 s: click anyway (the failure below says what the page held)
    before_click = page.evaluate(held)
    page.locator("#save-btn").click()
    try:
        _wait_text(page, "#file-message", outcome, name, timeout_s=45)
    except AssertionError as exc:
        log = server["work"].parent / "app.log"
        tail = log.read_text(errors="replace")[-4000:] if log.is_file() else "(no log)"
        raise AssertionError(f"{exc}; the field shows {field.input_value()!r}; the page's state held {before_click!r} "
                             f"at the click and {page.evaluate(held)!r} now; the app's log ends:\n{tail}") from None


def _number(text: str) -> float:
    """The first number in a metric's text ('12.4 %' -> 12.4, '209 : 1  (46.4 dB)' -> 209)."""
    return float(text.split()[0])


def _view_settled(page, before: bytes, timeout_s: float = 30.0) -> None:
    """Wait until the 3-D view shows a new picture (not ``before``) that stays the same for a moment."""
    view = page.locator(".rs-view")
    deadline = time.time() + timeout_s
    last = before
    while time.time() < deadline:
        time.sleep(0.5)
        now = view.screenshot()
        if now == last and now != before:
            return
        last = now
    raise AssertionError("the 3-D view did not settle on a new picture")


def _handle_xy(page, timeout_s: float = 20.0) -> tuple[float, float]:
    """Page coordinates of the selected light's sphere in the 3-D view: the centre of its
    orange pixels (the handle and the head are drawn in HANDLE_SELECTED_COLOUR)."""
    import cv2
    import numpy as np

    from rigsim.ui.handles import HANDLE_SELECTED_COLOUR

    hue = cv2.cvtColor(np.uint8([[np.array(HANDLE_SELECTED_COLOUR)[::-1] * 255]]), cv2.COLOR_BGR2HSV)[0, 0, 0]
    view = page.locator(".rs-view")
    deadline = time.time() + timeout_s
    while time.time() < deadline:
        box = view.bounding_box()
        png = view.screenshot()
        img = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
        hsv = cv2.cvtColor(img, cv2.COLOR_BGR2HSV).astype(int)
        # the saturated orange of the handle and head, shaded (the chart seen through water is pale)
        mask = ((abs(hsv[..., 0] - int(hue)) <= 6) & (hsv[..., 1] > 170) & (hsv[..., 2] > 90)).astype(np.uint8)
        n, labels, stats, centres = cv2.connectedComponentsWithStats(mask)
        if n > 1:
            big = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
            if stats[big, cv2.CC_STAT_AREA] >= 30:
                cx, cy = centres[big]
                sx, sy = box["width"] / img.shape[1], box["height"] / img.shape[0]
                return box["x"] + float(cx) * sx, box["y"] + float(cy) * sy
        time.sleep(0.5)
    shot = ROOT / "artifacts" / "ui" / "view_no_handle.png"
    shot.parent.mkdir(parents=True, exist_ok=True)
    shot.write_bytes(png)
    raise AssertionError(f"the selected light's sphere is not visible in the 3-D view (what it showed: {shot})")


def _choose(page, select_id: str, option: str):
    page.locator(f"#{select_id}").click(force=True)
    page.get_by_role("option", name=option, exact=True).first.click()
    page.keyboard.press("Escape")


def test_page_edit_compare_and_files(server):
    from playwright.sync_api import sync_playwright

    t0 = time.time()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        page = browser.new_page(viewport={"width": 1600, "height": 1200})
        errors = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server["url"])
        page.wait_for_selector("#preview-img", timeout=60_000)
        first = _wait_new_preview(page, {"info": ""})
        assert first["metrics"]["contrast_radiance"] not in (None, "–")

        # drag the left strobe outward in the 3-D view (seen from behind the housing: image
        # left is screen left): its arm gets longer, backscatter drops, contrast rises
        before = page.locator(".rs-view").screenshot()
        page.locator("#view-behind").click()
        _view_settled(page, before)
        arm0 = float(page.locator("#l_arm_length_m").input_value())
        x, y = _handle_xy(page)
        page.mouse.move(x, y)
        page.mouse.down()
        for k in range(1, 11):
            page.mouse.move(x - 9 * k, y, steps=2)
            time.sleep(0.05)
        page.mouse.up()
        deadline = time.time() + 30
        while (arm1 := float(page.locator("#l_arm_length_m").input_value())) == arm0 and time.time() < deadline:
            time.sleep(0.3)
        assert arm1 > arm0 + 0.05, f"the drag did not lengthen the arm: {arm0} -> {arm1} m"
        dragged = _wait_new_preview(page, first)
        assert _number(dragged["metrics"]["backscatter_share"]) < _number(first["metrics"]["backscatter_share"])
        assert _number(dragged["metrics"]["contrast_radiance"]) > _number(first["metrics"]["contrast_radiance"])
        first = dragged

        # water preset: coastal → clear
        _choose(page, "water-sel", "clear")
        clear = _wait_new_preview(page, first, want="· clear ·")
        assert clear["src"] != first["src"], "the predicted image did not change with the water"
        assert clear["metrics"]["contrast_radiance"] != first["metrics"]["contrast_radiance"]
        assert clear["metrics"]["backscatter_share"] != first["metrics"]["backscatter_share"]

        # turn the left strobe 35° outwards (yaw −35°: towards the image's left)
        page.locator("#l_yaw_deg").fill("-35")
        page.locator("#l_yaw_deg").press("Tab")
        turned = _wait_new_preview(page, clear)
        assert turned["src"] != clear["src"], "the predicted image did not change with the strobe angle"
        assert turned["metrics"] != clear["metrics"]

        # an impossible edit is refused with a message, and the app keeps working
        page.locator("#l_arm_length_m").fill("0.05")
        page.locator("#l_arm_length_m").press("Tab")
        page.wait_for_selector("#message", timeout=60_000)
        msg = page.locator("#message").text_content()
        assert "Refused" in msg and "housing" in msg, msg
        page.locator("#l_arm_length_m").fill("0.6")
        page.locator("#l_arm_length_m").press("Tab")
        wider = _wait_new_preview(page, turned)
        assert wider["src"] != turned["src"]

        # beside the numbers: how far the preview is from Monte Carlo in this water (or that it was not checked)
        agree = page.locator("#agreement-text").text_content()
        assert "Monte Carlo" in agree, agree

        # the comparison panel fills with images for both waters and the plot
        page.wait_for_selector("#compare-plot", timeout=60_000)
        # the cells (320 px photographs) may finish after the plot
        page.wait_for_function("document.querySelector('#compare-info').textContent.startsWith('2 images')",
                               timeout=60_000)

        # a converged render, with progress, replaces the preview
        _choose(page, "render-quality", "draft 240 px, 16 spp")
        page.locator("#render-btn").click()
        page.wait_for_function("() => (document.querySelector('#render-message')||{}).textContent"
                               "?.includes('converged render done')", timeout=120_000)
        conv = _state(page)
        assert "240×160" in conv["info"] and conv["src"] != wider["src"]
        shot = ROOT / "artifacts" / "ui" / "rig_designer.png"
        shot.parent.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(shot), full_page=True)
        print(f"\nscreenshot: {shot}")
        print(f"metrics coastal: {first['metrics']}\nmetrics clear: {clear['metrics']}\n"
              f"metrics turned: {turned['metrics']}\nmetrics arm 0.6 m: {wider['metrics']}\n"
              f"converged: {conv['info']} {conv['metrics']}\narm dragged {arm0} -> {arm1} m")

        arm_angle = float(page.locator("#l_arm_angle_deg").input_value())

        # files: refused outside the sandbox, written inside
        page.get_by_text("Rig file", exact=True).click()
        for bad in ("../../etc/x.toml", "/tmp/x.toml", "../escape.toml"):
            _save_as(page, bad, "Refused", server)
        assert not Path("/tmp/x.toml").exists() or Path("/tmp/x.toml").stat().st_mtime < t0
        _save_as(page, "my-rig.toml", "Saved", server)
        browser.close()
    assert not errors, errors
    saved = server["work"] / "my-rig.toml"
    assert saved.is_file()
    from rigsim.config.rig import load_rig

    rig = load_rig(saved)
    left = rig.lights[0]
    assert abs(left.position_m[0] - 0.6 * abs(math.cos(math.radians(arm_angle)))) < 0.01
    assert left.aim[0] > 0.5  # turned towards the image's left = world +x
    assert server["proc"].poll() is None, "the server died"
    print(f"browser test took {time.time() - t0:.1f} s")
