"""Open an HTML page in a real browser (headless Chromium) at a given width and report what a
reader would meet: horizontal overflow of the page body, images that do not load, console
errors.

Headless Chromium keeps its window at least 500 px wide, so the page is opened inside an
``<iframe>`` of the asked width (390 px: a phone) on a small wrapper page: the framed page's
viewport is then exactly that wide, and its media queries apply as on the phone. The wrapper and
an instrumented copy of the page are written beside the page (so its relative links resolve) and
removed afterwards. The copy differs from the page only by a first ``<script>`` in ``<head>``
that records every error event (failed resource loads included, in the capture phase) and every
``console.error`` / ``console.warn``, and by loading its lazy images at once.

Used by ``tests/test_campaign_page.py``; the test is skipped when no Chromium is installed
(Debian package ``chromium``) unless ``AFTC_REQUIRE_BROWSER=1`` (CI) turns the skip into a
failure.
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
import tempfile
import uuid
from dataclasses import dataclass
from pathlib import Path

_NAMES = ("chromium", "chromium-browser", "google-chrome", "chrome")

_HOOK = """<script>window.__errors=[];
addEventListener('error',function(e){var t=e.target;window.__errors.push(
t&&t!==window&&(t.src||t.href)?'failed to load '+(t.src||t.href).slice(0,120):
String(e.message))},true);
addEventListener('unhandledrejection',function(e){window.__errors.push(String(e.reason))});
['error','warn'].forEach(function(k){var f=console[k];console[k]=function(){
window.__errors.push('console.'+k+': '+Array.prototype.join.call(arguments,' '));
return f.apply(console,arguments)}});</script>"""

_WRAPPER = """<!DOCTYPE html><html><head><meta charset="utf-8"><style>
html,body{{margin:0;padding:0}}iframe{{border:0;display:block}}</style></head><body>
<iframe id="f" src="{src}" style="width:{w}px;height:{h}px"></iframe><pre id="probe"></pre>
<script>
var f=document.getElementById('f');
f.addEventListener('load',function(){{
 var w=f.contentWindow,d=f.contentDocument,imgs=Array.prototype.slice.call(d.images);
 Promise.all(imgs.map(function(i){{return i.complete?0:new Promise(function(r){{
   i.addEventListener('load',r);i.addEventListener('error',r)}})}})).then(function(){{
  var res={{width:w.innerWidth,scroll_width:d.documentElement.scrollWidth,
   body_scroll_width:d.body.scrollWidth,
   images:imgs.map(function(i){{return [(i.alt||i.src).slice(0,80),i.naturalWidth]}}),
   errors:w.__errors||['the page hook did not run']}};
  document.getElementById('probe').textContent='PROBE'+JSON.stringify(res)+'EBORP';}});
}});
</script></body></html>"""


def find_chromium() -> str | None:
    """Path of a Chromium-like browser, or None."""
    for name in _NAMES:
        path = shutil.which(name)
        if path:
            return path
    return None


@dataclass(frozen=True)
class PageCheck:
    """What the browser saw on one page at one width."""

    page: Path
    width: int
    viewport: int
    scroll_width: int
    images: tuple[tuple[str, int], ...]
    errors: tuple[str, ...]

    def problems(self) -> list[str]:
        """Every problem, one line each (empty: the page is fine at this width)."""
        out = []
        if self.viewport != self.width:
            out.append(f"viewport is {self.viewport} px, not the {self.width} px asked for")
        if self.scroll_width > self.viewport:
            out.append(
                f"horizontal overflow: the page is {self.scroll_width} px wide in a "
                f"{self.viewport} px window"
            )
        out += [f"image {alt!r} did not load" for alt, w in self.images if w <= 0]
        out += [f"console: {e}" for e in self.errors]
        return [f"{self.page.name} at {self.width} px: {p}" for p in out]


def check_page(page: Path, width: int, *, height: int = 900, timeout: float = 60.0) -> PageCheck:
    """Open ``page`` at ``width`` CSS px in headless Chromium and measure it."""
    browser = find_chromium()
    if browser is None:
        raise FileNotFoundError("no chromium on PATH (Debian: apt-get install chromium)")
    page = Path(page).resolve()
    tag = uuid.uuid4().hex[:8]
    copy = page.with_name(f".pagecheck-{tag}-{page.name}")
    wrapper = page.with_name(f".pagecheck-{tag}-wrapper.html")
    text = page.read_text(encoding="utf-8")
    text = re.sub(r"<head>", "<head>" + _HOOK, text, count=1)
    text = text.replace(' loading="lazy"', "")
    try:
        copy.write_text(text, encoding="utf-8")
        wrapper.write_text(_WRAPPER.format(src=copy.name, w=width, h=height), encoding="utf-8")
        cmd = [
            browser,
            "--headless",
            "--no-sandbox",  # CI containers run as root
            "--disable-gpu",
            "--disable-dev-shm-usage",  # containers with a small /dev/shm
            "--hide-scrollbars",
            "--allow-file-access-from-files",  # the wrapper reads the framed page
            f"--window-size={max(width, 500) + 40},{height + 100}",
            "--virtual-time-budget=20000",
            "--enable-logging=stderr",
            "--v=0",
            "--dump-dom",
            wrapper.as_uri(),
        ]
        with tempfile.TemporaryDirectory(prefix="pagecheck-") as profile:
            cmd.insert(1, f"--user-data-dir={profile}")  # a fresh profile, removed afterwards
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    finally:
        copy.unlink(missing_ok=True)
        wrapper.unlink(missing_ok=True)
    hit = re.search(r"PROBE(.*?)EBORP", proc.stdout, re.S)
    if hit is None:
        raise RuntimeError(
            f"chromium returned no measurement for {page.name} (exit {proc.returncode}): "
            f"{proc.stderr[-2000:]}"
        )
    res = json.loads(html.unescape(hit.group(1)))
    # console messages of the pages that the hook could not see (logged by Chromium itself)
    console = [ln.split("] ", 1)[-1] for ln in proc.stderr.splitlines() if ":CONSOLE" in ln]
    return PageCheck(
        page=page,
        width=width,
        viewport=int(res["width"]),
        scroll_width=int(res["scroll_width"]),
        images=tuple((str(a), int(w)) for a, w in res["images"]),
        errors=tuple(res["errors"]) + tuple(console),
    )
