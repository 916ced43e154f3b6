"""Headless Chromium for the report tests: the DevTools protocol over a pipe.

``--remote-debugging-pipe`` (no port, no websocket library: the standard
library alone) lets a test load a local page, collect what a user's console
would show (console errors and warnings, uncaught exceptions, failed loads,
dialogs such as ``alert``), evaluate expressions, send real mouse events and
take a screenshot.

    with Browser() as browser, browser.open(path) as page:
        assert page.problems() == []
        page.evaluate("document.title")

One browser serves many pages (each a new tab); ``Page.open(path)`` starts one
for a single page.
"""

from __future__ import annotations

import base64
import contextlib
import json
import os
import select
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--disable-dev-shm-usage",
    "--hide-scrollbars",
    "--mute-audio",
    "--force-device-scale-factor=1",
)
# The Debian wrapper /usr/bin/chromium runs a shell check that prints noise; the binary does not.
_BINARIES = ("/usr/lib/chromium/chromium", "chromium", "chromium-browser", "google-chrome")


def find_chromium() -> str | None:
    for name in _BINARIES:
        path = name if os.path.isabs(name) and os.access(name, os.X_OK) else shutil.which(name)
        if path:
            return path
    return None


class Browser:
    """One headless Chromium, spoken to over fds 3 (commands) and 4 (replies, events)."""

    def __init__(self) -> None:
        binary = find_chromium()
        if binary is None:
            raise RuntimeError("Chromium is not installed (apt-get install -y chromium)")
        self._profile = tempfile.mkdtemp(prefix="chromium-profile-")
        to_chrome_r, self._to_chrome = os.pipe()
        self._from_chrome, from_chrome_w = os.pipe()
        # Chromium reads fd 3 and writes fd 4: a one-line Python trampoline puts the
        # pipe ends there (no preexec_fn, unsafe with threads; no /bin/sh, which
        # refuses fd numbers above 9).
        trampoline = (
            "import os, sys; os.dup2(int(sys.argv[1]), 3); os.dup2(int(sys.argv[2]), 4); "
            "os.execv(sys.argv[3], sys.argv[3:])"
        )
        self._process = subprocess.Popen(
            [
                sys.executable,
                "-I",
                "-c",
                trampoline,
                str(to_chrome_r),
                str(from_chrome_w),
                binary,
                *FLAGS,
                f"--user-data-dir={self._profile}",
                "--remote-debugging-pipe",
                "about:blank",
            ],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            pass_fds=(to_chrome_r, from_chrome_w),
        )
        os.close(to_chrome_r)
        os.close(from_chrome_w)
        self._buffer = b""
        self._id = 0
        self._dialogs = 0
        self.events: list[dict[str, Any]] = []

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _read(self, deadline: float) -> dict[str, Any]:
        while b"\0" not in self._buffer:
            left = max(0.0, deadline - time.monotonic())
            ready, _, _ = select.select([self._from_chrome], [], [], left)
            if not ready:
                raise TimeoutError("no answer from Chromium")
            chunk = os.read(self._from_chrome, 1 << 20)
            if not chunk:
                raise RuntimeError("Chromium closed the pipe")
            self._buffer += chunk
        raw, self._buffer = self._buffer.split(b"\0", 1)
        message: dict[str, Any] = json.loads(raw)
        if message.get("method") == "Page.javascriptDialogOpening":
            # An alert() would stop the page: dismiss it (problems() reports it). Its
            # reply has an id of its own range, never one that send() waits for.
            self._dialogs += 1
            dismiss = {
                "id": 1_000_000 + self._dialogs,
                "method": "Page.handleJavaScriptDialog",
                "params": {"accept": False},
                "sessionId": message.get("sessionId"),
            }
            os.write(self._to_chrome, json.dumps(dismiss).encode() + b"\0")
        return message

    def send(
        self,
        method: str,
        params: dict[str, Any] | None = None,
        session: str | None = None,
        timeout: float = 30.0,
    ) -> Any:
        self._id += 1
        message: dict[str, Any] = {"id": self._id, "method": method, "params": params or {}}
        if session is not None:
            message["sessionId"] = session
        os.write(self._to_chrome, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        while True:
            reply = self._read(deadline)
            if reply.get("id") == self._id:
                if "error" in reply:
                    raise RuntimeError(f"{method}: {reply['error']}")
                return reply["result"]
            self.events.append(reply)

    def wait_for(self, method: str, session: str, timeout: float = 30.0) -> dict[str, Any]:
        def matches(event: dict[str, Any]) -> bool:
            return event.get("method") == method and event.get("sessionId") == session

        for i, event in enumerate(self.events):
            if matches(event):
                return self.events.pop(i)
        deadline = time.monotonic() + timeout
        while True:
            event = self._read(deadline)
            if matches(event):
                return event
            self.events.append(event)

    def open(
        self, html: Path, *, width: int = 1280, height: int = 900, timeout: float = 30.0
    ) -> Page:
        """``html`` in a new tab of ``width`` x ``height`` CSS pixels, loaded."""
        target = self.send("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True})[
            "sessionId"
        ]
        page = Page(self, target, session)
        try:
            for domain in ("Page", "Runtime", "Log"):
                page.send(f"{domain}.enable")
            page.send(
                "Emulation.setDeviceMetricsOverride",
                {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False},
            )
            page.send("Page.navigate", {"url": html.resolve().as_uri()})
            self.wait_for("Page.loadEventFired", session, timeout)
        except BaseException:
            page.close()
            raise
        return page

    def close(self) -> None:
        with contextlib.suppress(Exception):  # already gone
            self.send("Browser.close", timeout=5)
        try:
            self._process.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait()
        os.close(self._to_chrome)
        os.close(self._from_chrome)
        shutil.rmtree(self._profile, ignore_errors=True)


class Page:
    """One tab of a :class:`Browser`."""

    def __init__(self, browser: Browser, target: str, session: str) -> None:
        self.browser = browser
        self._target = target
        self._session = session
        self._own_browser = False

    @classmethod
    def open(cls, html: Path, *, width: int = 1280, height: int = 900) -> Page:
        """A browser of its own with ``html`` loaded; closing the page closes it."""
        browser = Browser()
        try:
            page = browser.open(html, width=width, height=height)
        except BaseException:
            browser.close()
            raise
        page._own_browser = True
        return page

    def __enter__(self) -> Page:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def send(self, method: str, params: dict[str, Any] | None = None) -> Any:
        return self.browser.send(method, params, session=self._session)

    def evaluate(self, expression: str) -> Any:
        reply = self.send(
            "Runtime.evaluate",
            {"expression": expression, "returnByValue": True, "awaitPromise": True},
        )
        if "exceptionDetails" in reply:
            raise RuntimeError(f"{expression[:60]}...: {reply['exceptionDetails']}")
        return reply["result"].get("value")

    def mouse(self, kind: str, x: float, y: float, buttons: int = 0) -> None:
        """A real mouse event (``mouseMoved``, ``mousePressed``, ``mouseReleased``) at page x, y."""
        params: dict[str, Any] = {"type": kind, "x": x, "y": y, "buttons": buttons}
        if kind != "mouseMoved":
            params.update(button="left", clickCount=1)
        self.send("Input.dispatchMouseEvent", params)

    def screenshot(self, path: Path, full_page: bool = False) -> None:
        params: dict[str, Any] = {"format": "png"}
        if full_page:
            size = self.send("Page.getLayoutMetrics")["cssContentSize"]
            params.update(
                captureBeyondViewport=True,
                clip={"x": 0, "y": 0, "width": size["width"], "height": size["height"], "scale": 1},
            )
        path.write_bytes(base64.b64decode(self.send("Page.captureScreenshot", params)["data"]))

    def problems(self) -> list[str]:
        """Console errors and warnings, uncaught exceptions, failed loads and dialogs so far."""
        self.evaluate("0")  # takes in the events sent up to now
        found = []
        for event in self.browser.events:
            if event.get("sessionId") != self._session:
                continue
            method, params = event.get("method"), event.get("params", {})
            if method == "Runtime.consoleAPICalled" and params["type"] in (
                "error",
                "warning",
                "assert",
            ):
                words = [str(a.get("value", a.get("description"))) for a in params["args"]]
                found.append(f"console.{params['type']}: {' '.join(words)}")
            elif method == "Runtime.exceptionThrown":
                details = params["exceptionDetails"]
                text = details.get("exception", {}).get("description", details.get("text"))
                found.append(f"exception: {text}")
            elif method == "Log.entryAdded" and params["entry"]["level"] in ("error", "warning"):
                entry = params["entry"]
                found.append(f"log.{entry['level']}: {entry['text']} {entry.get('url', '')}")
            elif method == "Page.javascriptDialogOpening":
                found.append(f"dialog: {params['type']}: {params['message']}")
        return found

    def close(self) -> None:
        browser = self.browser
        with contextlib.suppress(Exception):  # the browser is gone
            browser.send("Target.closeTarget", {"targetId": self._target}, timeout=5)
        browser.events = [e for e in browser.events if e.get("sessionId") != self._session]
        if self._own_browser:
            browser.close()


# Non-transparent pixels of each <canvas> (by data-plot), and the pixels near a
# colour: the plots have drawn, and drawn what they should.
CANVAS_INK = """Object.fromEntries([...document.querySelectorAll('canvas.base')].map(c => {
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i]) n++;
  return [c.dataset.plot, n]; }))"""


def pixels_near(selector: str, rgb: tuple[int, int, int], tolerance: int = 40) -> str:
    """An expression: how many pixels of the canvas ``selector`` are within
    ``tolerance`` of ``rgb`` in each channel (and mostly opaque)."""
    r, g, b = rgb
    return f"""(() => {{ const c = document.querySelector({json.dumps(selector)});
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data; let n = 0;
  for (let i = 0; i < d.length; i += 4) if (d[i + 3] > 150 && Math.abs(d[i] - {r}) <= {tolerance}
    && Math.abs(d[i + 1] - {g}) <= {tolerance} && Math.abs(d[i + 2] - {b}) <= {tolerance}) n++;
  return n; }})()"""
