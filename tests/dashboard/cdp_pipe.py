"""A minimal Chrome DevTools Protocol client over --remote-debugging-pipe (fd 3 in, fd 4 out, messages ended by
NUL): no websocket library needed. Enough to open a page, evaluate JavaScript and take screenshots."""
import base64
import fcntl
import json
import os
import shutil
import subprocess
import tempfile
import threading


class Chromium:
    def __init__(self, width=1400, height=1000):
        binary = shutil.which("chromium") or shutil.which("chromium-browser")
        if not binary:
            raise RuntimeError("chromium not found: the browser tests need Debian's `chromium` (scripts/setup.sh installs it)")
        self.profile = tempfile.mkdtemp(prefix="varbo-chromium-")
        to_browser_r, to_browser_w = os.pipe()
        from_browser_r, from_browser_w = os.pipe()
        # High copies, so that putting them at 3 and 4 in the child cannot overwrite one another.
        hi_r = fcntl.fcntl(to_browser_r, fcntl.F_DUPFD, 100)
        hi_w = fcntl.fcntl(from_browser_w, fcntl.F_DUPFD, 100)

        def child_fds():
            os.dup2(hi_r, 3)
            os.dup2(hi_w, 4)

        self.proc = subprocess.Popen(
            [binary, "--headless=new", "--no-sandbox", "--disable-gpu", "--remote-debugging-pipe",
             "--no-first-run", "--no-default-browser-check", "--disable-extensions", "--disable-sync",
             "--disable-background-networking", "--disable-component-update", "--mute-audio",
             f"--user-data-dir={self.profile}", f"--window-size={width},{height}", "about:blank"],
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            preexec_fn=child_fds, pass_fds=(3, 4))
        for fd in (to_browser_r, from_browser_w, hi_r, hi_w):
            os.close(fd)
        self.out = to_browser_w
        self.inp = from_browser_r
        self.next_id = 0
        self.replies = {}
        self.cv = threading.Condition()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()
        self.session = None
        self.width, self.height = width, height

    def _read(self):
        buf = b""
        while True:
            chunk = os.read(self.inp, 1 << 16)
            if not chunk:
                break
            buf += chunk
            while b"\0" in buf:
                msg, buf = buf.split(b"\0", 1)
                m = json.loads(msg)
                if "id" in m:
                    with self.cv:
                        self.replies[m["id"]] = m
                        self.cv.notify_all()
        with self.cv:
            self.replies[-1] = {"error": {"message": "chromium closed the pipe"}}
            self.cv.notify_all()

    def send(self, method, params=None, session=True, timeout=90):
        with self.cv:
            self.next_id += 1
            mid = self.next_id
        msg = {"id": mid, "method": method, "params": params or {}}
        if session and self.session:
            msg["sessionId"] = self.session
        os.write(self.out, json.dumps(msg).encode() + b"\0")
        with self.cv:
            if not self.cv.wait_for(lambda: mid in self.replies or -1 in self.replies, timeout):
                raise TimeoutError(f"no answer to {method} in {timeout} s")
            reply = self.replies.pop(mid, None) or self.replies[-1]
        if "error" in reply:
            raise RuntimeError(f"{method}: {reply['error']}")
        return reply["result"]

    def open(self, url):
        # The first command waits for chromium's start, which took > 30 s on a loaded machine.
        target = self.send("Target.createTarget", {"url": "about:blank"}, session=False, timeout=150)["targetId"]
        self.session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True}, session=False)["sessionId"]
        self.send("Emulation.setDeviceMetricsOverride",
                  {"width": self.width, "height": self.height, "deviceScaleFactor": 1, "mobile": False})
        self.send("Page.enable")
        self.send("Page.navigate", {"url": url})

    def eval(self, expression):
        r = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True, "awaitPromise": True})
        if "exceptionDetails" in r:
            raise RuntimeError(f"{expression}: {r['exceptionDetails']}")
        return r["result"].get("value")

    def screenshot(self, path, full_page=True, scale=1.0, height=None):
        """PNG of the page (its whole height, or `height` CSS pixels), scaled by `scale`."""
        params = {"format": "png"}
        if full_page or height or scale != 1.0:
            h = height or self.eval("document.documentElement.scrollHeight")
            params.update(captureBeyondViewport=True, clip={"x": 0, "y": 0, "width": self.width, "height": h, "scale": scale})
        with open(path, "wb") as f:
            f.write(base64.b64decode(self.send("Page.captureScreenshot", params)["data"]))

    def close(self):
        try:
            self.send("Browser.close", session=False, timeout=5)
        except Exception:
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for fd in (self.out, self.inp):
            try:
                os.close(fd)
            except OSError:
                pass
        shutil.rmtree(self.profile, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
