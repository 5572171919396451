"""The web edition (make book) opened in a real browser: headless Chromium.

Each page of the built site is loaded over HTTP from 127.0.0.1 and must show
what a reader needs: the equations typeset by MathJax (its elements present, no
raw ``$$`` left), every image loaded, no plain-text stand-in of a widget, and no
error in the browser's console (MathJax is served by the site itself: a CDN
request would fail here and be logged). On a phone (390 px) and a desktop (1400
px): the sidebar and page-contents buttons open their panels when clicked, no
printed output, equation or figure is wider than the column (a wide table or
equation scrolls inside its own box), one search box. Solutions, answers and
evidence are folded with their outputs behind a button that says so; each
chapter offers its committed notebook for download; code has copy buttons.
Screenshots are written to ``book/_build/screenshots`` for a person to look at.

Chromium comes from Debian (``chromium`` and ``chromium-driver``); ``.ci/run``
installs them where missing. Outside CI the test is skipped without them.
"""

from __future__ import annotations

import functools
import http.server
import os
import re
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


def _shots() -> Path:
    shots = ROOT / "book" / "_build" / "screenshots"
    shots.mkdir(parents=True, exist_ok=True)
    return shots


def _pages(html: Path) -> list[str]:
    chapters = sorted(p.name for p in (html / "chapters").glob("*.html"))
    return ["index.html"] + [f"chapters/{c}" for c in chapters]


def test_every_page_renders_math_images_and_no_widget_repr(site, browser):
    html, base = site
    pages = _pages(html)
    notebooks = sorted((ROOT / "notebooks").glob("*.ipynb"))
    assert len(pages) == 1 + len(notebooks), "a page per chapter"
    shots = _shots()
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
        if page in ("index.html", CHAPTER):
            browser.save_screenshot(str(shots / (Path(page).stem + ".png")))
    assert not problems, "\n".join(problems)


def test_site_needs_no_network(site):
    html, _ = site
    for page in html.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        for cdn in ("cdn.jsdelivr.net", "cdnjs.cloudflare.com", "unpkg.com"):
            assert cdn not in text, f"{page.relative_to(html)} loads from {cdn}"


PANELS = """
const vis = e => !!e && e.getBoundingClientRect().width > 0
  && getComputedStyle(e).visibility !== 'hidden' && !e.closest('.pst-sidebar-hidden');
return {
  chapters: Array.from(document.querySelectorAll('.bd-docs-nav a')).filter(vis).length,
  contents: Array.from(document.querySelectorAll(
      '.bd-sidebar-secondary .page-toc a, .bd-sidebar-secondary nav a')).filter(vis).length,
  search: Array.from(document.querySelectorAll('.search-button, .search-button-field, '
                                               + 'input[type=search]')).filter(vis).length,
};
"""


def _click_visible(browser, selector: str) -> bool:
    buttons = [b for b in browser.find_elements("css selector", selector) if b.is_displayed()]
    if not buttons:
        return False
    buttons[0].click()
    browser.execute_script("return new Promise(r => setTimeout(r, 400))")
    return True


CHAPTER = "chapters/03_map_based_ekf.html"


@pytest.mark.parametrize("width", [390, 1100, 1400])
def test_sidebar_and_contents_buttons_open_their_panels(site, browser, width):
    _, base = site
    browser.set_window_size(width, 900)
    try:
        browser.get(f"{base}/{CHAPTER}")
        start = browser.execute_script(PANELS)
        assert start["search"] == 1, f"{width} px: {start['search']} search boxes, one expected"
        assert _click_visible(browser, ".primary-toggle"), f"{width} px: no sidebar button"
        after = browser.execute_script(PANELS)
        if width >= 992:   # the sidebar is open: the button closes it, a second click opens it
            assert start["chapters"] > 10 and after["chapters"] == 0, (width, start, after)
            _click_visible(browser, ".primary-toggle")
            after = browser.execute_script(PANELS)
        assert after["chapters"] > 10, f"{width} px: the sidebar did not open {after}"
        browser.save_screenshot(str(_shots() / f"sidebar_{width}.png"))
        browser.get(f"{base}/{CHAPTER}")
        if width >= 1200:  # the page's contents are always shown, without a button
            assert start["contents"] > 5, start
            return
        assert start["contents"] == 0, start
        assert _click_visible(browser, ".secondary-toggle"), f"{width} px: no contents button"
        after = browser.execute_script(PANELS)
        assert after["contents"] > 5, f"{width} px: the page's contents did not open {after}"
        browser.save_screenshot(str(_shots() / f"contents_{width}.png"))
    finally:
        browser.set_window_size(1280, 900)


OVERFLOW = """
document.querySelectorAll('details').forEach(d => { d.open = true; });
const main = document.querySelector('article.bd-article');
const right = main.getBoundingClientRect().right;
const bad = [];
const scrolls = el => ['auto', 'scroll'].includes(getComputedStyle(el).overflowX);
const name = el => el.tagName.toLowerCase() + '.' + el.className.toString().slice(0, 30) + ' "'
                   + (el.textContent || '').trim().slice(0, 40) + '"';
for (const el of main.querySelectorAll('div.cell_output *, div.math, mjx-container, pre, table, '
                                       + 'img, p, li, code')) {
  const r = el.getBoundingClientRect();
  if (r.width === 0 || r.right <= right + 1) continue;
  let p = el.parentElement, inBox = false;
  while (p && p !== main) {
    if (scrolls(p) && p.getBoundingClientRect().right <= right + 1) { inBox = true; break; }
    p = p.parentElement;
  }
  if (!inBox) bad.push('wider than the column by ' + Math.round(r.right - right) + ' px: '
                       + name(el));
}
for (const el of main.querySelectorAll('div.cell_output div, div.cell_output pre, div.math, '
                                       + 'span.math, mjx-container')) {
  const o = getComputedStyle(el).overflowX;
  if (el.scrollWidth > el.clientWidth + 1 && ['hidden', 'clip'].includes(o)) {
    bad.push('cut: ' + name(el));
  }
}
for (const el of main.querySelectorAll('span.math')) {   // a scroll bar only where it is needed:
  const column = el.parentElement.closest('p, li, td, th, dd, dt, div, blockquote, section');
  if (scrolls(el) && el.scrollWidth > el.clientWidth + 1 && el.scrollWidth <= column.clientWidth) {
    bad.push('a scroll bar on an inline formula narrower than its column: ' + name(el));
  }   // (a formula narrower than its paragraph fits on a line of its own)
}
if (document.documentElement.scrollWidth > window.innerWidth + 1) {
  bad.push('the page scrolls sideways');
}
return bad;
"""


@pytest.mark.parametrize("width", [390, 1400])
def test_outputs_and_equations_fit_the_column(site, browser, width):
    html, base = site
    browser.set_window_size(width, 900)
    problems = []
    try:
        for page in _pages(html)[1:]:
            browser.get(f"{base}/{page}")
            browser.execute_async_script(WAIT_FOR_MATHJAX)
            problems += [f"{page} at {width} px: {p}" for p in browser.execute_script(OVERFLOW)]
    finally:
        browser.set_window_size(1280, 900)
    assert not problems, "\n".join(problems[:40])


def test_long_printed_lines_wrap_and_tables_keep_their_columns():
    sys.path.insert(0, str(ROOT / "tools"))
    from build_book import text_blocks, text_html

    table = ["name      mean   median", "slam      4.0    3.3", "fej       3.9    3.4"]
    text = "a long sentence " * 20 + "\n" + "\n".join(table) + "\n  indented note\n"
    assert [k for k, _ in text_blocks(text)] == ["prose", "table", "prose"]
    out = text_html(text)
    assert '<div class="course-table"' in out and "\n".join(table) in out
    assert out.count('class="course-line"') == 2 and "padding-left:min(4ch,40%)" in out
    assert "&lt;b&gt;" in text_html("<b>")   # printed text is escaped, never markup


FOLDED = """
return Array.from(document.querySelectorAll('div.cell.tag_solution, div.cell.tag_answer, '
                                            + 'div.cell.tag_evidence')).map(c => {
  const d = c.querySelector('details.hide');
  return {tag: c.className, folded: !!d && !d.open,
          summary: d ? d.querySelector('summary').innerText.trim() : '',
          holdsOutput: !!d && Array.from(c.querySelectorAll('.cell_output'))
                                   .every(o => d.contains(o)),
          visibleText: Array.from(c.querySelectorAll('.cell_output, .cell_input'))
                            .some(e => e.checkVisibility())};
});
"""


def test_solutions_are_folded_with_their_outputs_and_labelled(site, browser):
    import nbformat

    html, base = site
    expected = 0
    for p in sorted((ROOT / "notebooks").glob("*.ipynb")):
        nb = nbformat.read(p, as_version=4)
        expected += sum(1 for c in nb.cells if c.cell_type == "code"
                        and {"solution", "answer", "evidence"} & set(c.metadata.get("tags", [])))
    found, problems = 0, []
    for page in _pages(html)[1:]:
        browser.get(f"{base}/{page}")
        for cell in browser.execute_script(FOLDED):
            found += 1
            kind = next(k for k in ("solution", "answer", "evidence") if f"tag_{k}" in cell["tag"])
            if not (cell["folded"] and cell["holdsOutput"] and not cell["visibleText"]):
                problems.append(f"{page}: a {kind} cell is not folded with its output: {cell}")
            if cell["summary"] != f"Show {kind}":
                problems.append(f"{page}: the fold of a {kind} says {cell['summary']!r}")
    assert found == expected > 20, (found, expected)
    assert not problems, "\n".join(problems)
    page = (html / "chapters" / "08_camera_delay.html").read_text(encoding="utf-8")
    assert '<details class="course-answer">' in page and "Show answer" in page


def test_library_source_is_highlighted_in_a_fold(site):
    html, _ = site
    page = (html / "chapters" / "01_dead_reckoning.html").read_text(encoding="utf-8")
    assert page.count('<details class="course-source">') >= 2
    fold = page[page.index('<details class="course-source">'):]
    fold = fold[:fold.index("</details>")]
    assert "motion_model" in fold and '<span class="k">def</span>' in fold


def test_each_chapter_offers_its_notebook_and_copy_buttons(site, browser):
    html, base = site
    for p in sorted((ROOT / "notebooks").glob("*.ipynb")):
        page = f"chapters/{p.stem}.html"
        browser.get(f"{base}/{page}")
        link = browser.execute_script(
            "const a = document.querySelector('a.btn-download-source-button');"
            "return a ? a.href : null;")
        assert link and link.endswith(f"/_sources/chapters/{p.name}"), (page, link)
        served = html / "_sources" / "chapters" / p.name
        assert served.read_bytes() == p.read_bytes(), f"{page}: the download is not the notebook"
    browser.get(f"{base}/{CHAPTER}")
    assert _click_visible(browser, ".dropdown-download-buttons button"), "no download button"
    assert [a for a in browser.find_elements("css selector", "a.btn-download-source-button")
            if a.is_displayed()], "the download menu does not show the notebook"
    copy = browser.execute_script("return document.querySelectorAll('button.copybtn').length")
    assert copy > 10, f"{copy} copy buttons on {CHAPTER}"


def test_landing_page_has_no_placeholder(site, browser):
    _, base = site
    browser.get(f"{base}/index.html")
    text = browser.execute_script("return document.querySelector('article').innerText")
    assert "<this repository>" not in text and "<it>" not in text
    assert not re.search(r"<[a-z][a-z ]*>", text), re.search(r"<[a-z][a-z ]*>", text)
    assert "make lab" in text and "00 · Frames" in text
