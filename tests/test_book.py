"""The web edition (make book) opened in a real browser: headless Chromium.

Each page of the built site is loaded over HTTP from 127.0.0.1 and must show
what a reader needs: the equations typeset by MathJax (its elements present, no
raw ``$$`` left), every image loaded, no plain-text stand-in of a widget, and no
error in the browser's console (MathJax is served by the site itself: a CDN
request would fail here and be logged). Screenshots of the landing page and one
chapter are written to ``book/_build/screenshots`` for a person to look at.

Chromium comes from Debian (``chromium`` and ``chromium-driver``); ``.ci/run``
installs them where missing. Outside CI the test is skipped without them.
"""

from __future__ import annotations

import functools
import http.server
import os
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
CHROMEDRIVER = shutil.which("chromedriver")

if not (CHROMIUM and CHROMEDRIVER):
    if os.environ.get("CI"):
        raise RuntimeError("CI needs Debian's chromium and chromium-driver (.ci/run installs them)")
    pytest.skip("headless Chromium not installed (apt-get install chromium chromium-driver)",
                allow_module_level=True)

webdriver = pytest.importorskip("selenium.webdriver")


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    out = tmp_path_factory.mktemp("book")
    subprocess.run([sys.executable, str(ROOT / "tools" / "build_book.py"), "--out", str(out)],
                   check=True, capture_output=True, timeout=600)
    html = out / "html"
    handler = functools.partial(_QuietHandler, directory=str(html))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield html, f"http://127.0.0.1:{server.server_address[1]}"
    server.shutdown()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):  # keep pytest's output readable
        pass


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    from selenium.webdriver.chrome.service import Service

    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic",
                 "--no-first-run", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--window-size=1280,900",
                 f"--user-data-dir={tmp_path_factory.mktemp('chromium')}"):
        opts.add_argument(flag)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=opts)
    driver.set_page_load_timeout(60)
    driver.set_script_timeout(60)
    yield driver
    driver.quit()


WAIT_FOR_MATHJAX = """
const done = arguments[arguments.length - 1];
if (!(window.MathJax && MathJax.startup && MathJax.startup.promise)) { done('no mathjax'); }
else { MathJax.startup.promise.then(() => done('ok'), (e) => done('error ' + e)); }
"""

INSPECT = """
const imgs = Array.from(document.querySelectorAll('article img, main img'));
return {
  math: document.querySelectorAll('mjx-container').length,
  text: document.body.innerText,
  images: imgs.length,
  broken: imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.src),
};
"""


def _pages(html: Path) -> list[str]:
    chapters = sorted(p.name for p in (html / "chapters").glob("*.html"))
    return ["index.html"] + [f"chapters/{c}" for c in chapters]


def test_every_page_renders_math_images_and_no_widget_repr(site, browser):
    html, base = site
    pages = _pages(html)
    notebooks = sorted((ROOT / "notebooks").glob("*.ipynb"))
    assert len(pages) == 1 + len(notebooks), "a page per chapter"
    shots = ROOT / "book" / "_build" / "screenshots"
    shots.mkdir(parents=True, exist_ok=True)
    problems = []
    for page in pages:
        browser.get(f"{base}/{page}")
        state = browser.execute_async_script(WAIT_FOR_MATHJAX)
        seen = browser.execute_script(INSPECT)
        log = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
        if page != "index.html":
            if state != "ok":
                problems.append(f"{page}: MathJax {state}")
            if seen["math"] == 0:
                problems.append(f"{page}: no typeset equation (mjx-container)")
            if seen["images"] == 0:
                problems.append(f"{page}: no figure")
        if "$$" in seen["text"]:
            problems.append(f"{page}: raw $$ in the text")
        for stand_in in ("interactive(children=", "VBox(children="):
            if stand_in in seen["text"]:
                problems.append(f"{page}: raw widget repr {stand_in!r}")
        problems += [f"{page}: image not loaded {src}" for src in seen["broken"]]
        problems += [f"{page}: console error {e['message']}" for e in log]
        if page in ("index.html", "chapters/03_map_based_ekf.html"):
            browser.save_screenshot(str(shots / (Path(page).stem + ".png")))
    assert not problems, "\n".join(problems)


def test_site_needs_no_network(site):
    html, _ = site
    for page in html.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        for cdn in ("cdn.jsdelivr.net", "cdnjs.cloudflare.com", "unpkg.com"):
            assert cdn not in text, f"{page.relative_to(html)} loads from {cdn}"


def test_answers_are_folded(site):
    html, _ = site
    page = (html / "chapters" / "08_camera_delay.html").read_text(encoding="utf-8")
    assert "<details>" in page and "Answers (open after trying)" in page
