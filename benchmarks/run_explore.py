"""How quickly `haptex explore` answers a control change, per algorithm, on the paper's
sinusoid (2-D, default resolution: arrows 23 x 19, maps 121 x 121, q at default
resolution) and on the egg-crate at A = 0.2 mm, l = 2 mm (3-D):

- server: the recompute alone (model.build + model.views), best of 3;
- browser: from selecting the algorithm in Chromium (Playwright) to the new q shown in the
  page, which includes the websocket round trip and BokehJS redrawing five views; median
  of 3 round trips (needs Debian's chromium).

Also a drawn loop's energy (the Fig. 3 loop) and a 1 s scan on the pantograph.
"""

from __future__ import annotations

import shutil
import socket
import statistics
import subprocess
import sys
import time
import urllib.request

from haptex.explore import model

LETTERS = "WABCDEFG"


def _server_side() -> None:
    print("| algorithm | 2-D recompute (s) | 3-D recompute (s) | Fig. 3 loop (s) |")
    print("| --- | ---: | ---: | ---: |")
    model.views(model.build(model.Settings()))  # warm the compiled kernels
    for letter in LETTERS:
        s2 = model.Settings(algorithm=letter)
        s3 = model.Settings(algorithm=letter, texture="egg-crate", amplitude="0.2 mm", period="2 mm",
                            device="point-mass")
        t2 = min(_time(lambda: model.views(model.build(s2))) for _ in range(3))
        t3 = _time(lambda: model.views(model.build(s3)))
        scene = model.build(s2)
        try:
            tl = f"{_time(lambda: model.fig3(scene)):.3f}"
        except Exception:  # W's loop is the eq. 29 path (defined); all others are defined too
            tl = "-"
        print(f"| {letter} | {t2:.3f} | {t3:.3f} | {tl} |")
    scene = model.build(model.Settings())
    print(f"\n1 s scan of A on the pantograph (10^4 samples): {_time(lambda: model.scan(scene)):.3f} s")


def _time(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def _browser_side() -> None:
    chromium = shutil.which("chromium")
    if chromium is None:
        print("\n(browser round trips skipped: no chromium)")
        return
    from playwright.sync_api import sync_playwright

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "haptex", "explore", "--port", str(port), "--no-browser"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}/"
    try:
        for _ in range(200):
            try:
                urllib.request.urlopen(url, timeout=2).read(10)
                break
            except OSError:
                time.sleep(0.2)
        labels = dict(model.ALGORITHM_LABELS)
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=chromium, args=["--no-sandbox", "--disable-gpu"])
            page = browser.new_page(viewport={"width": 1500, "height": 1350})
            t = time.perf_counter()
            page.goto(url)
            page.wait_for_selector("#q-value")
            print(f"\npage load to q shown: {time.perf_counter() - t:.2f} s")
            print("\n| algorithm | browser: select to new q shown (s, median of 3) |")
            print("| --- | ---: |")
            shown = {k: _q_text(k) for k in LETTERS}
            for letter in LETTERS:
                base = "A" if letter != "A" else "W"
                times = []
                for _ in range(3):
                    page.locator("#algorithm select").select_option(label=labels[base])
                    _wait_q(page, shown[base])
                    t = time.perf_counter()
                    page.locator("#algorithm select").select_option(label=labels[letter])
                    _wait_q(page, shown[letter])
                    times.append(time.perf_counter() - t)
                print(f"| {letter} | {statistics.median(times):.2f} |")
            browser.close()
    finally:
        proc.terminate()
        proc.wait(10)


def _q_text(letter: str) -> str:
    q = model.views(model.build(model.Settings(algorithm=letter))).q
    return "unbounded" if q.unbounded else f"{q.value:.4g}"


_FIND = """(want) => {
  const find = (root) => {
    const hit = root.querySelector('#q-value');
    if (hit) return hit;
    for (const e of root.querySelectorAll('*')) if (e.shadowRoot) { const f = find(e.shadowRoot); if (f) return f; }
    return null;
  };
  const el = find(document);
  return el !== null && el.textContent === want;
}"""


def _wait_q(page, text: str) -> None:
    """Wait until the page shows q = text (polled every 5 ms in the page)."""
    page.wait_for_function(_FIND, arg=text, polling=5, timeout=60000)


def main() -> None:
    _server_side()
    _browser_side()


if __name__ == "__main__":
    main()
