"""Play videos in a headless Chromium ``<video>`` element: does a browser decode them?

For each video the page served on localhost loads it in a ``<video>`` element, reads its duration
and size, seeks to a few times and draws each frame into a canvas; the page writes what it saw
(duration, size, and per seek the mean grey level and the column of the brightest pixel column,
or the error the browser reported) into the DOM and posts it back to the local server.

Needs Debian's ``chromium`` package (``apt-get install -y chromium``). Used by
``tests/io/test_video_browser.py`` and by hand on real outputs:

    python scripts/play_in_browser.py RUN/Trial_1/Trial_1_(cam01)_overlay.mp4

prints one JSON line per video.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import http.server
import json
import shutil
import subprocess
import sys
import tempfile
import threading
from pathlib import Path

#: Chromium's names on Debian and elsewhere.
CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "chrome")

_PAGE = """<!doctype html>
<html><body>
<video id="v" muted preload="auto"></video>
<canvas id="c"></canvas>
<pre id="result">pending</pre>
<script>
const seeks = %(seeks)s;
const video = document.getElementById("v");
const out = {seeks: []};
function finish(extra) {
  Object.assign(out, extra || {});
  const text = JSON.stringify(out);
  document.getElementById("result").textContent = text;
  fetch("/result", {method: "POST", body: text});
}
video.addEventListener("error", () => finish({error: video.error ? video.error.code + ": " +
    video.error.message : "unknown"}));
video.addEventListener("loadeddata", async () => {
  out.duration = video.duration;
  out.width = video.videoWidth;
  out.height = video.videoHeight;
  const canvas = document.getElementById("c");
  canvas.width = video.videoWidth;
  canvas.height = video.videoHeight;
  const ctx = canvas.getContext("2d", {willReadFrequently: true});
  for (const t of seeks) {
    // 'seeked' alone may come before the sought frame is presented (a loaded machine drew the
    // previous seek's frame): wait for the frame callback too, at most 5 s.
    const seeked = new Promise((resolve) => video.addEventListener("seeked", resolve,
                                                                   {once: true}));
    const shown = video.requestVideoFrameCallback
      ? new Promise((resolve) => video.requestVideoFrameCallback(() => resolve()))
      : Promise.resolve();
    video.currentTime = t;
    await seeked;
    await Promise.race([shown, new Promise((resolve) => setTimeout(resolve, 5000))]);
    ctx.drawImage(video, 0, 0);
    const data = ctx.getImageData(0, 0, canvas.width, canvas.height).data;
    const columns = new Array(canvas.width).fill(0);
    let total = 0;
    for (let i = 0; i < data.length; i += 4) {
      const grey = (data[i] + data[i + 1] + data[i + 2]) / 3;
      columns[(i / 4) %% canvas.width] += grey;
      total += grey;
    }
    const brightest = columns.indexOf(Math.max(...columns));
    out.seeks.push({time: t, current_time: video.currentTime, mean: total / (data.length / 4),
                    brightest_column: brightest});
  }
  finish();
});
// The whole file as a blob: seekable whatever the server (Python's answers no range requests)
fetch("%(src)s").then((r) => r.blob()).then((blob) => {
  out.bytes = blob.size;
  video.src = URL.createObjectURL(blob);
}).catch((e) => finish({error: "fetch: " + e}));
</script>
</body></html>
"""


def find_chromium() -> str | None:
    """The path of a Chromium (or Chrome) executable, or None."""
    for name in CHROMIUM_NAMES:
        found = shutil.which(name)
        if found:
            return found
    return None


@contextlib.contextmanager
def _serve(folder: Path):
    """Serve ``folder`` on 127.0.0.1 (a free port) while the block runs.

    Yields the base URL and a dict that receives the text the page POSTs to ``/result``
    (``"text"``) once its ``"done"`` event is set.
    """
    received = {"done": threading.Event()}
    handler = functools.partial(_Handler, received, directory=str(folder))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}", received
    finally:
        server.shutdown()
        server.server_close()
        thread.join()


class _Handler(http.server.SimpleHTTPRequestHandler):
    """Files of the folder; a POST to /result hands its body over."""

    def __init__(self, received, *args, **kwargs):
        self.received = received
        super().__init__(*args, **kwargs)

    def do_POST(self) -> None:
        length = int(self.headers.get("Content-Length", 0))
        self.received["text"] = self.rfile.read(length).decode()
        self.send_response(204)
        self.end_headers()
        self.received["done"].set()

    def log_message(self, *args) -> None:  # no request lines on stderr
        pass


def play(video, seeks=(0.0,), *, chromium: str | None = None, timeout: float = 120.0) -> dict:
    """What a headless Chromium ``<video>`` element shows of ``video``.

    The browser plays in real time (no virtual time: seeking then waits for the decoder), and
    is ended once the page has posted its result.

    Parameters
    ----------
    video : str or os.PathLike
        The video file.
    seeks : sequence of float
        Times (s) to seek to and draw.
    chromium : str, optional
        The browser executable (default: :func:`find_chromium`).
    timeout : float
        Seconds to wait for the page's result (a bound on a hung browser, not a speed
        requirement).

    Returns
    -------
    dict
        ``duration`` (s), ``width``, ``height``, ``bytes`` (of the file loaded) and ``seeks``
        (per seek: ``time`` asked, ``current_time`` reached, ``mean`` grey level 0–255,
        ``brightest_column``); or ``error`` with the browser's media error.
    """
    chromium = chromium or find_chromium()
    if chromium is None:
        raise FileNotFoundError("no chromium executable (apt-get install -y chromium)")
    video = Path(video).resolve()
    with tempfile.TemporaryDirectory(prefix="play_in_browser_") as tmp:
        site = Path(tmp) / "site"
        site.mkdir()
        (site / f"clip{video.suffix}").symlink_to(video)
        (site / "page.html").write_text(_PAGE % {"src": f"clip{video.suffix}",
                                                 "seeks": json.dumps(list(map(float, seeks)))})
        with _serve(site) as (url, received):
            command = [chromium, "--headless", "--no-sandbox", "--disable-gpu",
                       "--disable-background-networking", "--no-first-run",
                       "--disable-dev-shm-usage", "--mute-audio",
                       f"--user-data-dir={Path(tmp) / 'profile'}", f"{url}/page.html"]
            browser = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                       text=True)
            try:
                answered = received["done"].wait(timeout)
            finally:
                browser.terminate()
                try:
                    _, err = browser.communicate(timeout=30)
                except subprocess.TimeoutExpired:
                    browser.kill()
                    _, err = browser.communicate()
    if not answered:
        raise RuntimeError(f"the page reported nothing in {timeout:g} s (chromium: "
                           f"{err[-1500:]})")
    return json.loads(received["text"])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("videos", nargs="+")
    parser.add_argument("--seek", type=float, action="append",
                        help="a time (s) to seek to and draw (repeatable; default 0)")
    args = parser.parse_args(argv)
    failed = 0
    for path in args.videos:
        result = play(path, args.seek or (0.0,))
        print(json.dumps({"video": str(path), **result}))
        failed += "error" in result
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
