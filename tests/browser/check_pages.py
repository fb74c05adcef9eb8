#!/usr/bin/env python3
"""Open every built page of the book in headless Chromium, offline, and check what a reader sees.

Run after the book build (``.ci/run`` does, as its own phase)::

    python tests/browser/check_pages.py                # _build/html, all pages
    python tests/browser/check_pages.py --screenshots /tmp/shots book/20_gpff.html
    python tests/browser/check_pages.py --widths 400 book/99_scorecard.html

Per page it fails on

``console``   a JavaScript console error, an uncaught exception, or a browser log error
              (e.g. a file the page references that is not in the build);
``network``   any request that would leave ``file://`` (http, https, ws...): it is blocked
              and counted, the book must work offline;
``math``      math left untypeset after MathJax finished (fewer MathJax containers than math
              spans), or a MathJax error box (bad TeX);
``tex``       raw TeX leaking into the text (``$...$`` or ``\\command`` outside math/code);
``image``     an image that did not load (``naturalWidth == 0``);
``table``     a table wider than the text column; a table inside a horizontal scroll box that
              itself fits the column is only reported (``scrolled``), not failed;
``equation``  a display equation wider than its box, scrolling sideways in a box of its own, or
              running into its equation number;
``overflow``  the text column (or the page) scrolls horizontally;
``link``      a link to a page of the book, or to an anchor in one (``page.html#id``), whose
              target does not exist (e.g. a scorecard row whose claim has no anchor).
``wide``      an element wider than the viewport (or sticking out of it) that is not inside a
              box allowed to scroll (:data:`SCROLL_ALLOWED`: equations, cell outputs, code), or
              a box that scrolls sideways but is not allowed to, or shows no visible cue
              (scrollbar or edge shadow) that it scrolls;
``overlap``   text in a table cell running out of its cell (drawn over the next one);
``number``    a number in a table broken over two lines ("0.00 38");
``word``      a word in a table broken over two lines ("systema" / "tic", "inconcl" / "usive"):
              a cell may wrap between words or after a ``_``, ``=`` or ``/`` it offers, never
              inside a run of letters (Chinese text, which wraps between any two characters,
              is not a run of letters);
``figtext``   a figure image whose smallest text, as displayed, is smaller than the body text
              (the computed font-size of the article's paragraphs, measured in the page): on
              screen it is ``min_pt * dpi / 72 * (shown width / natural width)`` CSS px, with
              ``data-dpi`` and ``data-min-pt`` (desktop drawing) or ``data-phone-min-pt`` (the
              phone drawing, when the ``<picture>`` chose it) on the image; an image without
              them (a plain matplotlib PNG) fails as "not made for the width it is read at"
              (see pfrepro.plotting's responsive figures); no tap-to-enlarge exemption;
``rst``       (API pages) raw reStructuredText in the text (``double back-quotes``, ``:class:``
              roles), or a numpydoc "(type)" slot holding a description;
``ellipsis``  table text cut with "…" (typed, pandas' "..." or ``text-overflow: ellipsis``);
``figure``    a numbered figure (with caption) that holds no image, e.g. a table that shared the
              figure's notebook cell and got its caption;
``columns``   a table showing more than :data:`MAX_COLUMNS` columns (claims tables, and any table
              shown as cards at that width, are exempt);
``narrow``    a table cell (or card line) of three or more words wrapped one word per line
              (as many lines as words, counted from the text's line boxes);
``internal``  internal words in the reader's text (code, math and API signatures excluded;
              claims tables may show claim ids): issue numbers ("issue 22", "(#22", "#22"), module aliases
              (``E.x``, ``S.x``, ``F.x``), ``None`` as a value, Python dict/list reprs,
              unrendered glue (``{glue:``, ``glue(``), and ``nan`` / ``NaN`` shown as a table
              value everywhere; ``None`` as a value and snake_case identifiers (claim ids,
              choice and column names) outside the API reference and Sphinx's indexes, which
              document Python. An element with class ``pf-internal-ok`` is exempt (for text
              that is about such words).

Every page is read at each width of :data:`WIDTHS` (a laptop, 1366 px, and a phone, 400 px;
below :data:`PHONE_MAX` wide equations may scroll in a visibly cued box of their own).

Driver: the Chrome DevTools Protocol spoken directly over ``--remote-debugging-pipe``
(JSON messages on file descriptors 3/4), standard library only. No websocket client, no
pip package, no browser download: it drives the Debian ``chromium`` package (or
``$CHROMIUM``). Exit status 1 if any page fails, 2 if the browser or the build is missing.
"""
from __future__ import annotations

import argparse
import base64
import fcntl
import json
import os
import re
import select
import shutil
import subprocess
import sys
import tempfile
import time
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

KINDS = ("console", "network", "math", "tex", "image", "table", "equation", "overflow", "link",
         "wide", "overlap", "number", "word", "figtext", "rst", "ellipsis", "figure",
         "columns", "narrow", "internal")

#: viewports every page is read at: a laptop and a phone (CSS px)
WIDTHS = (1366, 400)
#: below this viewport width the page is read as on a phone: wide equations may scroll in their
#: own (visibly cued) box, figures too small to read may instead link to their full-size image
PHONE_MAX = 800
#: boxes allowed to scroll sideways (each must show a visible cue: a shadow background attached
#: "local" or a visible scrollbar); anything else wider than the viewport fails ``wide``
SCROLL_ALLOWED = ("div.math > mjx-container", "span.math", "div.cell_output div.output",
                  "div.pst-scrollable-table-container", "div.highlight pre")
#: a table may show at most this many columns (claims tables, cards on a phone, are exempt)
MAX_COLUMNS = 8
#: internal-word hits listed per page view (the rest are counted in the summary only)
MAX_INTERNAL_HITS = 500
#: a numpydoc "(type)" slot longer than this holds a description, not a type
MAX_TYPE_CHARS = 60
LOCAL_SCHEMES = ("file:", "data:", "blob:", "about:", "chrome:", "chrome-extension:", "devtools:")


def find_chromium(explicit: str | None = None) -> str | None:
    for cand in (explicit, os.environ.get("CHROMIUM"), "chromium", "chromium-browser",
                 "google-chrome", "/usr/bin/chromium"):
        if cand and (path := shutil.which(cand)):
            return path
    return None


class CDPError(RuntimeError):
    pass


class Browser:
    """Headless Chromium driven over the DevTools pipe (fd 3: commands in, fd 4: replies out)."""

    def __init__(self, executable: str, width: int = 1280, height: int = 900):
        self.width, self.height = width, height
        self._profile = tempfile.mkdtemp(prefix="check_pages_")
        to_chrome_r, self._w = os.pipe()
        self._r, from_chrome_w = os.pipe()
        # move both child ends above the 0-4 range first, so dup2 into 3/4 cannot clobber them;
        # close_fds=False below because Popen would close 3/4 after preexec_fn (our fds are
        # non-inheritable by default, so nothing else leaks into the browser)
        c_in = fcntl.fcntl(to_chrome_r, fcntl.F_DUPFD, 10)
        c_out = fcntl.fcntl(from_chrome_w, fcntl.F_DUPFD, 10)
        os.close(to_chrome_r)
        os.close(from_chrome_w)

        def _child_fds():
            os.dup2(c_in, 3)
            os.dup2(c_out, 4)

        args = [
            executable, "--headless=new", "--remote-debugging-pipe", "--no-sandbox",
            "--disable-gpu", "--disable-dev-shm-usage", "--no-first-run", "--no-default-browser-check",
            "--disable-extensions", "--disable-background-networking", "--disable-sync",
            "--disable-component-update", "--disable-default-apps", "--mute-audio",
            "--hide-scrollbars", "--force-device-scale-factor=1",
            # belt and braces beside the Fetch-domain block below: no route out of the machine
            "--proxy-server=http://127.0.0.1:9", "--proxy-bypass-list=<-loopback>",
            "--allow-file-access-from-files",
            f"--user-data-dir={self._profile}", f"--window-size={width},{height}", "about:blank",
        ]
        self.proc = subprocess.Popen(args, close_fds=False, preexec_fn=_child_fds,
                                     stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL if not os.environ.get("CHECK_PAGES_DEBUG") else None)
        os.close(c_in)
        os.close(c_out)
        self._buf = b""
        self._id = 0
        self._replies: dict[int, dict] = {}
        self.events: list[dict] = []
        self.version = self.call("Browser.getVersion")["product"]

    # -- transport -------------------------------------------------------------------------
    def _read_message(self, timeout: float) -> dict | None:
        deadline = time.monotonic() + timeout
        while b"\0" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([self._r], [], [], left)
            if not ready:
                return None
            chunk = os.read(self._r, 1 << 20)
            if not chunk:
                raise CDPError("chromium closed the DevTools pipe (did it crash?)")
            self._buf += chunk
        raw, self._buf = self._buf.split(b"\0", 1)
        return json.loads(raw)

    def _send(self, method: str, params: dict | None = None, session: str | None = None) -> int:
        self._id += 1
        msg = {"id": self._id, "method": method, "params": params or {}}
        if session:
            msg["sessionId"] = session
        os.write(self._w, json.dumps(msg).encode() + b"\0")
        return self._id

    def _dispatch(self, msg: dict) -> None:
        if "id" in msg:
            self._replies[msg["id"]] = msg
        elif "method" in msg:
            self._on_event(msg)

    def call(self, method: str, params: dict | None = None, session: str | None = None,
             timeout: float = 60.0) -> dict:
        mid = self._send(method, params, session)
        deadline = time.monotonic() + timeout
        while mid not in self._replies:
            msg = self._read_message(max(0.0, deadline - time.monotonic()))
            if msg is None:
                raise CDPError(f"{method}: no reply within {timeout:.0f} s")
            self._dispatch(msg)
        reply = self._replies.pop(mid)
        if "error" in reply:
            raise CDPError(f"{method}: {reply['error']}")
        return reply.get("result", {})

    def _on_event(self, ev: dict) -> None:
        # a paused request must be answered at once, or the page stalls
        if ev["method"] == "Fetch.requestPaused":
            p = ev["params"]
            url = p["request"]["url"]
            if url.startswith(LOCAL_SCHEMES):
                self._send("Fetch.continueRequest", {"requestId": p["requestId"]}, ev.get("sessionId"))
            else:
                self._send("Fetch.failRequest", {"requestId": p["requestId"],
                                                "errorReason": "BlockedByClient"}, ev.get("sessionId"))
        self.events.append(ev)

    def pump(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            msg = self._read_message(left)
            if msg is not None:
                self._dispatch(msg)

    def wait_event(self, method: str, session: str, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while (left := end - time.monotonic()) > 0:
            if any(e["method"] == method and e.get("sessionId") == session for e in self.events):
                return True
            msg = self._read_message(left)
            if msg is not None:
                self._dispatch(msg)
        return any(e["method"] == method and e.get("sessionId") == session for e in self.events)

    def close(self) -> None:
        try:
            self.call("Browser.close", timeout=5)
        except Exception:
            pass
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for fd in (self._r, self._w):
            try:
                os.close(fd)
            except OSError:
                pass
        shutil.rmtree(self._profile, ignore_errors=True)

    # -- one page --------------------------------------------------------------------------
    def open(self, url: str, timeout: float = 60.0) -> tuple[str, str]:
        target = self.call("Target.createTarget", {"url": "about:blank"})["targetId"]
        session = self.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
        self.events.clear()
        for domain in ("Runtime", "Log", "Network", "Page"):
            self.call(f"{domain}.enable", session=session)
        # every non-local request is paused and failed (see _on_event); file:// never reaches Fetch
        self.call("Fetch.enable", {"patterns": [{"urlPattern": "http*"}, {"urlPattern": "ws*"},
                                                {"urlPattern": "ftp*"}]}, session)
        self.call("Emulation.setDeviceMetricsOverride",
                  {"width": self.width, "height": self.height, "deviceScaleFactor": 1,
                   "mobile": False}, session)
        self.call("Page.navigate", {"url": url}, session)
        if not self.wait_event("Page.loadEventFired", session, timeout):
            raise CDPError(f"{url}: no load event within {timeout:.0f} s")
        return target, session

    def evaluate(self, session: str, expression: str, timeout: float = 60.0):
        res = self.call("Runtime.evaluate", {"expression": expression, "awaitPromise": True,
                                             "returnByValue": True}, session, timeout=timeout)
        if "exceptionDetails" in res:
            raise CDPError(f"page script failed: {res['exceptionDetails']}")
        return res["result"].get("value")

    def screenshot(self, session: str, path: Path, clip: dict | None = None,
                   max_height: int = 12000) -> None:
        # grow the window to the whole page (captureBeyondViewport alone re-lays out some
        # themes), shoot, and restore the reader's window
        h = min(max_height, int(self.evaluate(session, "document.documentElement.scrollHeight")))
        metrics = {"width": self.width, "deviceScaleFactor": 1, "mobile": False}
        self.call("Emulation.setDeviceMetricsOverride", {**metrics, "height": h}, session)
        self.evaluate(session, "new Promise(r => requestAnimationFrame(() => setTimeout(r, 200)))")
        if clip is None:
            clip = {"x": 0, "y": 0, "width": self.width, "height": h}
        clip = {**clip, "scale": 1}
        try:
            data = self.call("Page.captureScreenshot", {"format": "png", "clip": clip}, session)["data"]
        finally:
            self.call("Emulation.setDeviceMetricsOverride", {**metrics, "height": self.height}, session)
        path.write_bytes(base64.b64decode(data))


# Runs in the page after the load event. Waits for MathJax (if the page loads it) to finish its
# first typeset and for every image to settle, then measures. Returns a JSON-able report.
PAGE_JS = r"""
(async () => {
  const OPT = window.__pfopt || {phone: false, api: false, apiIndex: false, scrollAllowed: [], maxTypeChars: 1e9,
                                 maxColumns: 1e9, maxInternal: 0};
  const sleep = ms => new Promise(r => setTimeout(r, ms));
  const t0 = performance.now();
  // MathJax 3 is loaded with `defer`/`async`: wait for its startup promise, if the page has one
  const wantsMathJax = !!document.querySelector('script[src*="mathjax"], script[src*="MathJax"]');
  let mathjax = 'none';
  if (wantsMathJax) {
    while (!(window.MathJax && MathJax.startup && MathJax.startup.promise) && performance.now() - t0 < 30000)
      await sleep(50);
    if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
      try { await MathJax.startup.promise; mathjax = 'done'; } catch (e) { mathjax = 'failed: ' + e; }
    } else mathjax = 'never started';
  }
  const imgs = [...document.images];
  imgs.forEach(i => { i.loading = 'eager'; });
  await Promise.all(imgs.map(i => i.complete ? null : new Promise(r => {
    i.addEventListener('load', r, {once: true}); i.addEventListener('error', r, {once: true});
    setTimeout(r, 10000); })));
  if (document.fonts) await document.fonts.ready;
  await sleep(100);

  const fails = [];
  const notes = [];
  const label = el => {
    const id = el.id || (el.closest('[id]') || {}).id || '';
    return el.tagName.toLowerCase() + (id ? '#' + id : '');
  };
  const box = el => { const r = el.getBoundingClientRect();
    return {x: r.left + scrollX, y: r.top + scrollY, width: r.width, height: r.height}; };
  // the nearest ancestor (or el itself) that scrolls sideways
  const scrollerOf = el => {
    for (let a = el; a && a !== document.body; a = a.parentElement) {
      const ox = getComputedStyle(a).overflowX;
      if ((ox === 'auto' || ox === 'scroll') && a.scrollWidth > a.clientWidth + tol) return a;
    }
    return null;
  };
  // does a scrolling box show the reader that it scrolls? a visible scrollbar, or a shadow cue
  // (background layers attached to the scrolled content, see book/_static/pfrepro.css)
  const cued = el => {
    const st = getComputedStyle(el);
    return el.offsetHeight - el.clientHeight > 2 ||
           (/gradient/.test(st.backgroundImage) && /local/.test(st.backgroundAttachment));
  };
  const allowedScroller = el => OPT.scrollAllowed.some(sel => el.matches(sel));
  const visible = el => { const st = getComputedStyle(el);
    return st.visibility !== 'hidden' && st.display !== 'none' && parseFloat(st.opacity || '1') > 0; };

  // the text column
  const col = document.querySelector('article.bd-article') || document.querySelector('main') || document.body;
  const cs = getComputedStyle(col);
  const cr = col.getBoundingClientRect();
  const colLeft = cr.left + parseFloat(cs.paddingLeft), colRight = cr.right - parseFloat(cs.paddingRight);
  const colWidth = colRight - colLeft;
  const tol = 1.5;

  // page / column overflow
  const de = document.documentElement;
  if (de.scrollWidth > de.clientWidth + tol)
    fails.push({kind: 'overflow', what: 'page', detail: `page scrolls sideways: ${de.scrollWidth}px > ${de.clientWidth}px`});
  if (col.scrollWidth > col.clientWidth + tol)
    fails.push({kind: 'overflow', what: label(col), detail: `text column scrolls sideways: ${col.scrollWidth}px > ${col.clientWidth}px`, box: box(col)});

  // math: every .math span/div must hold a MathJax container; no MathJax error boxes
  const mathEls = [...document.querySelectorAll('span.math, div.math')];
  const containers = document.querySelectorAll('mjx-container').length;
  const untypeset = mathEls.filter(el => !el.querySelector('mjx-container'));
  if (mathEls.length && containers < mathEls.length)
    fails.push({kind: 'math', what: 'page', detail: `${containers} MathJax containers for ${mathEls.length} math spans`});
  untypeset.slice(0, 5).forEach(el => fails.push({kind: 'math', what: label(el),
      detail: 'untypeset: ' + el.textContent.trim().slice(0, 80), box: box(el)}));
  document.querySelectorAll('mjx-merror').forEach(el => fails.push({kind: 'math', what: label(el),
      detail: 'MathJax error: ' + (el.getAttribute('data-mjx-error') || el.textContent).slice(0, 100), box: box(el)}));

  // raw TeX in text nodes outside math, code and scripts
  const skip = 'script, style, pre, code, kbd, samp, textarea, mjx-container, .math, .highlight, .cell_input, .output, .cell_output';
  const walker = document.createTreeWalker(col, NodeFilter.SHOW_TEXT);
  const texRe = /\$[^$\n]{0,80}[\\^_{}][^$\n]{0,80}\$|\\(?:dot|hat|mathrm|mathbf|frac|infty|alpha|sigma|lambda|sqrt|left|right|text|operatorname|tfrac|big)\b/;
  let texHits = 0;
  for (let n = walker.nextNode(); n; n = walker.nextNode()) {
    if (!n.parentElement || n.parentElement.closest(skip)) continue;
    const m = n.textContent.match(texRe);
    if (m && texHits++ < 5)
      fails.push({kind: 'tex', what: label(n.parentElement), detail: 'raw TeX: ' + JSON.stringify(m[0]), box: box(n.parentElement)});
  }

  // images
  imgs.forEach(i => { if (!i.complete || i.naturalWidth === 0)
    fails.push({kind: 'image', what: label(i), detail: 'image did not load: ' + (i.getAttribute('src') || '').slice(0, 100)}); });
  notes.push(`${imgs.length} images`);

  // tables
  let nTables = 0, nScrolled = 0;
  document.querySelectorAll('table').forEach(t => {
    if (!col.contains(t) || t.closest('mjx-container')) return;
    nTables++;
    const r = t.getBoundingClientRect();
    if (r.width <= colWidth + tol && r.left >= colLeft - tol && r.right <= colRight + tol) return;
    // inside a horizontal scroll box that itself fits the column?
    let scroller = null;
    for (let a = t.parentElement; a && a !== col; a = a.parentElement) {
      const ox = getComputedStyle(a).overflowX;
      if (ox === 'auto' || ox === 'scroll') { scroller = a; break; }
    }
    const sr = scroller && scroller.getBoundingClientRect();
    const what = label(t) + ' ' + [...t.querySelectorAll('th')].slice(0, 4).map(h => h.textContent.trim()).join('|').slice(0, 60);
    if (sr && sr.left >= colLeft - tol && sr.right <= colRight + tol) {
      nScrolled++;
      notes.push(`scrolled table ${what}: ${Math.round(r.width)}px in a ${Math.round(colWidth)}px column`);
    } else fails.push({kind: 'table', what, detail: `table ${Math.round(r.width)}px wide, text column ${Math.round(colWidth)}px`, box: box(t)});
  });
  notes.push(`${nTables} tables` + (nScrolled ? ` (${nScrolled} scrolled)` : ''));

  // display equations: content within its box and clear of the equation number
  let nEq = 0;
  document.querySelectorAll('div.math').forEach(d => {
    const m = d.querySelector('mjx-container mjx-math');
    if (!m) return;
    nEq++;
    const dr = d.getBoundingClientRect(), mr = m.getBoundingClientRect();
    const why = [];
    const eqScroller = scrollerOf(m);
    const eqScrollOk = OPT.phone && eqScroller && (eqScroller === d || d.contains(eqScroller)) && cued(eqScroller);
    if (!eqScrollOk && (mr.width > dr.width + tol || mr.left < dr.left - tol || mr.right > dr.right + tol))
      why.push(`content ${Math.round(mr.width)}px, box ${Math.round(dr.width)}px`);
    if (dr.right > colRight + tol) why.push(`box ends ${Math.round(dr.right - colRight)}px past the column`);
    // MathJax or the theme may give the equation a horizontal scroll box of its own: then the
    // box fits but the reader has to scroll to see the equation's end. On a laptop that fails;
    // on a phone it is allowed if the box shows that it scrolls (cue)
    for (const el of [d, ...d.querySelectorAll('mjx-container')]) {
      if (el.scrollWidth > el.clientWidth + tol && el.clientWidth > 0) {
        if (!(OPT.phone && cued(el)))
          why.push(`scrolls sideways: ${el.scrollWidth}px of content in ${el.clientWidth}px` + (OPT.phone ? ' with no visible cue' : ''));
        break;
      }
    }
    const eq = d.querySelector('.eqno');
    if (eq) {
      const er = eq.getBoundingClientRect();
      const vert = er.top < mr.bottom && er.bottom > mr.top;
      if (vert && er.left < mr.right - tol && er.right > mr.left + tol)
        why.push(`runs into its number ${eq.textContent.trim().replace(/[#¶]/g, '')}`);
    }
    if (why.length) fails.push({kind: 'equation', what: label(d) + ' ' + (eq ? eq.textContent.trim().replace(/[#¶]/g, '') : ''),
                                detail: why.join('; '), box: box(d)});
  });
  notes.push(`${nEq} display equations, ${mathEls.length} math spans, column ${Math.round(colWidth)}px`);

  // ---- wide: nothing wider than the viewport, except inside an allowed, visibly cued scroll box
  const vw = de.clientWidth;
  const offenders = [];
  for (const el of document.body.querySelectorAll('*')) {
    if (offenders.length > 400) break;
    if (el.closest('.bd-sidebar-primary, .bd-sidebar-secondary, dialog, script, style, head, svg, mjx-assistive-mml')) continue;
    const r = el.getBoundingClientRect();
    if (r.width === 0 || r.height === 0) continue;
    const sc = el.parentElement && scrollerOf(el.parentElement);
    const st = getComputedStyle(el);
    const ox = st.overflowX;
    // an element that scrolls sideways itself (not by name, or with no cue)
    const scrolls = (ox === 'auto' || ox === 'scroll') && el.scrollWidth > el.clientWidth + tol && el.clientWidth > 0;
    // its box, or the text it holds (a long word in a heading), past the viewport's edges
    const contentRight = ox === 'visible' ? r.left + el.scrollWidth : r.right;
    const out = Math.max(r.right, contentRight) > vw + tol || r.left < -tol;
    let why = null;
    if (scrolls && !allowedScroller(el)) why = `scrolls sideways (${el.scrollWidth}px in ${el.clientWidth}px) but is not a box allowed to scroll`;
    else if (scrolls && !cued(el)) why = `scrolls sideways (${el.scrollWidth}px in ${el.clientWidth}px) with no visible cue`;
    else if (out && !sc && visible(el)) why = `${Math.round(Math.max(r.width, contentRight - r.left))}px wide, spans ${Math.round(r.left)}..${Math.round(Math.max(r.right, contentRight))}px of a ${vw}px viewport`;
    if (why) offenders.push({el, why});
  }
  // the contents panel on the right (visible on a laptop): entries clipped at its edge
  const toc = document.querySelector('.bd-sidebar-secondary');
  if (toc && visible(toc) && toc.getBoundingClientRect().width > 0) {
    const edge = toc.getBoundingClientRect().left + toc.clientLeft + toc.clientWidth;
    const tw = document.createTreeWalker(toc, NodeFilter.SHOW_TEXT);
    for (let n = tw.nextNode(); n; n = tw.nextNode()) {
      if (!n.textContent.trim() || !visible(n.parentElement)) continue;
      const rg = document.createRange();
      rg.selectNodeContents(n);
      const right = Math.max(0, ...[...rg.getClientRects()].map(q => q.right));
      if (right > edge + tol) offenders.push({el: n.parentElement, why: `cut at the edge of the contents panel (${Math.round(right - edge)}px hidden)`});
    }
  }
  // report the innermost offenders (a section is wide because its heading is)
  const inner = offenders.filter(o => !offenders.some(p => p !== o && o.el.contains(p.el)));
  inner.slice(0, 5).forEach(({el, why}) => fails.push({kind: 'wide',
      what: label(el) + (el.className && typeof el.className === 'string' ? '.' + el.className.trim().split(/\s+/).slice(0, 2).join('.') : ''),
      detail: why + ` "${(el.textContent || '').trim().slice(0, 40)}"`, box: box(el)}));

  // ---- tables: text inside its cell (else it is drawn over the next one), numbers on one line,
  // no text cut short with an ellipsis
  // a number on its own (not the "-1" of "k-1", nor digits inside a name such as "x2")
  const numRe = /(?<![\w.])[-+−]?\d+(?:[.,]\d+)*(?:[eE][-+−]?\d+)?%?/g;
  // a word: a run of letters (a break after "_", "=" or "/" is not inside one)
  // a run of letters; Han characters are not part of one (Chinese wraps between any two of them)
  const wordRe = /(?:(?!\p{Script=Han})\p{L}){4,}/gu;
  let nOverlap = 0, nNumber = 0, nWord = 0, nEllipsis = 0;
  document.querySelectorAll('td, th').forEach(cell => {
    if (!col.contains(cell) || cell.closest('mjx-container') || !visible(cell)) return;
    const cr = cell.getBoundingClientRect();
    if (cr.width === 0) return;
    const st = getComputedStyle(cell);
    const w = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    let over = null;
    for (let n = w.nextNode(); n; n = w.nextNode()) {
      if (!n.textContent.trim() || n.parentElement.closest('mjx-container, .math')) continue;
      const rg = document.createRange();
      rg.selectNodeContents(n);
      for (const q of rg.getClientRects()) {
        if (q.width > 0 && (q.right > cr.right + tol || q.left < cr.left - tol)) { over = q; break; }
      }
      if (over) break;
      // numbers broken across lines
      for (const m of n.textContent.matchAll(numRe)) {
        if (m[0].length < 2) continue;
        const r2 = document.createRange();
        r2.setStart(n, m.index); r2.setEnd(n, m.index + m[0].length);
        const tops = new Set([...r2.getClientRects()].filter(q => q.width > 0).map(q => Math.round(q.top)));
        if (tops.size > 1 && nNumber++ < 5)
          fails.push({kind: 'number', what: label(cell), detail: `number ${JSON.stringify(m[0])} broken over ${tops.size} lines`, box: box(cell)});
      }
      // words broken across lines (overflow-wrap splitting a word too long for its column)
      for (const m of n.textContent.matchAll(wordRe)) {
        const r2 = document.createRange();
        r2.setStart(n, m.index); r2.setEnd(n, m.index + m[0].length);
        const tops = new Set([...r2.getClientRects()].filter(q => q.width > 0).map(q => Math.round(q.top)));
        if (tops.size > 1 && nWord++ < 5)
          fails.push({kind: 'word', what: label(cell), detail: `word ${JSON.stringify(m[0])} broken over ${tops.size} lines`, box: box(cell)});
      }
    }
    // typed "…", or pandas' "..." at the end of a cell cut to display.max_colwidth (the cell's
    // whole text: "2 ... 64" inside a sentence is not a cut)
    const whole = cell.textContent.trim();
    if (/(…|\.\.\.)$/.test(whole) && !cell.querySelector('mjx-container') && nEllipsis++ < 5)
      fails.push({kind: 'ellipsis', what: label(cell), detail: 'text cut with "…": ' + JSON.stringify(whole.slice(-60)), box: box(cell)});
    if (over && nOverlap++ < 5)
      fails.push({kind: 'overlap', what: label(cell) + ' ' + cell.textContent.trim().slice(0, 30),
                  detail: `text runs ${Math.round(Math.max(over.right - cr.right, cr.left - over.left))}px out of its cell` + (st.overflow !== 'visible' ? ' (and is clipped)' : ' over the next one'), box: box(cell)});
  });
  // CSS ellipsis (text-overflow) on table cells cuts text too
  document.querySelectorAll('td, th').forEach(cell => {
    if (!col.contains(cell)) return;
    const st = getComputedStyle(cell);
    if (st.textOverflow === 'ellipsis' && cell.scrollWidth > cell.clientWidth + tol && nEllipsis++ < 5)
      fails.push({kind: 'ellipsis', what: label(cell), detail: 'text cut by text-overflow: ellipsis', box: box(cell)});
  });

  // ---- body text: the computed font-size of the article's paragraphs (the most text wins), the
  // yardstick of the figure-text rule
  const bodyPx = (() => {
    const tally = new Map();
    col.querySelectorAll('p').forEach(p => {
      if (p.closest('table, figure, figcaption, .cell_output, .admonition, aside, nav, footer, dl.field-list, .sig')) return;
      const n = p.textContent.trim().length;
      if (!n || !visible(p)) return;
      const fs = parseFloat(getComputedStyle(p).fontSize);
      tally.set(fs, (tally.get(fs) || 0) + n);
    });
    let best = parseFloat(getComputedStyle(col).fontSize), most = -1;
    for (const [fs, n] of tally) if (n > most) { best = fs; most = n; }
    return best;
  })();
  notes.push(`body text ${bodyPx}px`);

  // ---- figure text: every figure image in the article is made for the width it is read at
  // (the responsive-figure contract: data-dpi, data-min-pt, data-phone-min-pt), and its smallest
  // text, as displayed, is at least the body text: min_pt * dpi / 72 * (shown width / natural width)
  let nSmall = 0;
  imgs.forEach(i => {
    // (Sphinx's own interface icons, the module index's +/- togglers, are no figures)
    if (!col.contains(i) || !i.naturalWidth || !visible(i) || i.matches('img.toggler')) return;
    const r = i.getBoundingClientRect();
    if (r.width < 2) return;
    const name = label(i) + ' ' + ((i.getAttribute('alt') || (i.getAttribute('src') || '').split('/').pop()).slice(0, 50));
    const dpi = parseFloat(i.dataset.dpi), minPt = parseFloat(i.dataset.minPt), phonePt = parseFloat(i.dataset.phoneMinPt);
    if (!(dpi > 0) || !(minPt > 0) || !(phonePt > 0)) {
      if (nSmall++ < 50)
        fails.push({kind: 'figtext', what: name, detail: `figure not made for the width it is read at (no data-dpi / data-min-pt / data-phone-min-pt); shown ${Math.round(r.width)}px of ${i.naturalWidth}px`, box: box(i)});
      return;
    }
    // the <picture> shows the phone drawing when its <source> matched
    const phoneSrc = !!i.currentSrc && i.currentSrc !== i.src;
    const pt = phoneSrc ? phonePt : minPt;
    const px = pt * dpi / 72 * (r.width / i.naturalWidth);
    if (px + 0.05 >= bodyPx) return;
    if (nSmall++ < 50)
      fails.push({kind: 'figtext', what: name,
                  detail: `figure text ${px.toFixed(1)}px on screen < body text ${bodyPx}px (${phoneSrc ? 'phone' : 'desktop'} drawing, ${pt}pt at ${dpi} dpi shown ${Math.round(r.width)}px of ${i.naturalWidth}px)`, box: box(i)});
  });

  // ---- columns per table: at most maxColumns shown (claims tables, cards on a phone, are exempt)
  const tableName = t => {
    const cap = t.querySelector('caption');
    if (cap && cap.textContent.trim()) return 'caption ' + JSON.stringify(cap.textContent.trim().slice(0, 60));
    const fig = t.closest('figure');
    const fc = fig && fig.querySelector('figcaption');
    if (fc && fc.textContent.trim()) return 'caption ' + JSON.stringify(fc.textContent.trim().slice(0, 60));
    const hs = [...t.querySelectorAll('th')].map(h => h.textContent.trim()).filter(Boolean);
    if (hs.length) return 'headers ' + JSON.stringify(hs.slice(0, 3).join(' | ').slice(0, 60));
    return 'first cell ' + JSON.stringify((t.querySelector('td') || t).textContent.trim().slice(0, 60));
  };
  const isCards = t => t.classList.contains('pf-claims') ||
    [...t.querySelectorAll('td')].slice(0, 3).some(c => getComputedStyle(c).display === 'block');
  col.querySelectorAll('table').forEach(t => {
    if (t.closest('mjx-container') || !visible(t) || isCards(t)) return;
    let most = 0;
    for (const row of t.rows) {
      let n = 0;
      for (const c of row.cells) if (visible(c) && c.getBoundingClientRect().width > 0) n += c.colSpan || 1;
      most = Math.max(most, n);
    }
    if (most > OPT.maxColumns)
      fails.push({kind: 'columns', what: label(t) + ' ' + tableName(t),
                  detail: `table shows ${most} columns (at most ${OPT.maxColumns})`, box: box(t)});
  });

  // ---- one word per line: a cell (or card line) of >= 3 words wrapped to as many lines as words
  const linesOf = rects => {
    const lines = [];
    [...rects].filter(q => q.width > 0 && q.height > 0).sort((a, b) => a.top - b.top).forEach(q => {
      const mid = (q.top + q.bottom) / 2;
      const l = lines.find(l => mid >= l.top && mid <= l.bottom);
      if (l) { l.top = Math.min(l.top, q.top); l.bottom = Math.max(l.bottom, q.bottom); }
      else lines.push({top: q.top, bottom: q.bottom});
    });
    return lines.length;
  };
  let nNarrow = 0;
  col.querySelectorAll('td, th').forEach(cell => {
    if (cell.closest('mjx-container') || !visible(cell) || cell.getBoundingClientRect().width === 0) return;
    const w3 = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
    const rects = [];
    let text = '';
    for (let n = w3.nextNode(); n; n = w3.nextNode()) {
      if (!n.textContent.trim() || n.parentElement.closest('mjx-container, .math, script, style')) continue;
      // text nodes joined as the reader sees them: a token split by <wbr> (a claim id that may wrap
      // after its '_') is one word, not several
      text += (n.previousSibling && n.previousSibling.nodeName === 'WBR' ? '' : ' ') + n.textContent;
      const rg = document.createRange();
      rg.selectNodeContents(n);
      rects.push(...rg.getClientRects());
    }
    const words = text.split(/\s+/).filter(w => /[\p{L}\p{N}]/u.test(w)).length;
    if (words < 3) return;
    const lines = linesOf(rects);
    if (lines >= words && nNarrow++ < 400)
      fails.push({kind: 'narrow', what: label(cell) + (cell.dataset.label ? ` [${cell.dataset.label}]` : ''),
                  detail: `${words} words on ${lines} lines (one word per line): ` + JSON.stringify(text.trim().replace(/\s+/g, ' ').slice(0, 60)), box: box(cell)});
  });

  // ---- figures: every captioned figure shows an image (a table in a figure cell gets the caption too)
  col.querySelectorAll('figure').forEach(f => {
    if (!f.querySelector('img, svg, canvas, video') && f.querySelector('figcaption'))
      fails.push({kind: 'figure', what: label(f), detail: 'captioned figure without an image: ' +
                  JSON.stringify(f.querySelector('figcaption').textContent.trim().slice(0, 60)), box: box(f)});
  });

  // ---- raw reStructuredText in the API reference (roles and literals the docstrings failed to render)
  if (OPT.api) {
    const rstRe = /``[^`]+``|:(?:class|meth|func|attr|mod|data|math|obj|exc|ref):`|`[^`\s][^`]*`_/;
    const w2 = document.createTreeWalker(col, NodeFilter.SHOW_TEXT);
    let nRst = 0;
    for (let n = w2.nextNode(); n; n = w2.nextNode()) {
      if (!n.parentElement || n.parentElement.closest('script, style, pre, .highlight, mjx-container')) continue;
      const m = n.textContent.match(rstRe);
      if (m && nRst++ < 5)
        fails.push({kind: 'rst', what: label(n.parentElement), detail: 'raw reST: ' + JSON.stringify(m[0].slice(0, 60)), box: box(n.parentElement)});
    }
    // a parameter description rendered in the italic "(type)" slot: too long for a type
    document.querySelectorAll('dl.field-list dd em, dl.field-list dd span.classifier').forEach(em => {
      const t = em.textContent.trim();
      const li = em.closest('li, p');
      const prev = em.previousSibling && em.previousSibling.textContent || '';
      if (/\($/.test(prev.trim()) && t.length > OPT.maxTypeChars && nRst++ < 10)
        fails.push({kind: 'rst', what: label(em), detail: `"(type)" slot holds ${t.length} characters: ` + JSON.stringify(t.slice(0, 60)), box: box(li || em)});
    });
  }
  // ---- internal words in the reader's text: issue numbers, module aliases, None, dict/list
  // reprs, unrendered glue, claim ids outside the claims tables, and nan shown as a table value.
  // Code, math, the API pages' signatures and the claims tables/cards are not reader prose here.
  // Collapsed dropdowns are read too (the reader opens them); hidden elements are not.
  const internalSkip = 'script, style, pre, code, kbd, samp, textarea, mjx-container, mjx-assistive-mml, .math, ' +
    '.highlight, .cell_input, .headerlink, .sig, dt.sig, .sig-name, .sig-prename, ' +
    '.bd-sidebar-primary, .bd-sidebar-secondary, .prev-next-area, .pf-internal-ok';
  const shown = el => {
    for (let a = el; a && a !== document.documentElement; a = a.parentElement) {
      if (a.tagName === 'DETAILS' && !a.open) continue;  // content of a closed dropdown counts
      const st = getComputedStyle(a);
      if (st.display === 'none' && !(a.parentElement && a.parentElement.tagName === 'DETAILS')) return false;
      if (st.visibility === 'hidden') return false;
    }
    return true;
  };
  const blockOf = el => { for (let a = el; a; a = a.parentElement)
    if (!/^(inline|contents)/.test(getComputedStyle(a).display)) return a; return el; };
  // one string of the page's reader text; a block boundary reads as a line break
  let flat = '';
  const spans = [];  // [start, end, element] for labels
  let lastBlock = null;
  const w4 = document.createTreeWalker(col, NodeFilter.SHOW_TEXT);
  for (let n = w4.nextNode(); n; n = w4.nextNode()) {
    const pe = n.parentElement;
    if (!pe || !n.textContent.trim() || pe.closest(internalSkip) || !shown(pe)) continue;
    const b = blockOf(pe);
    if (b !== lastBlock) { flat += '\n'; lastBlock = b; }
    // claims tables (cards on a phone) may show claim ids and reading names; the rest applies there too
    spans.push([flat.length, flat.length + n.textContent.length, pe, !!pe.closest('table.pf-claims')]);
    flat += n.textContent;
  }
  const internalRules = [
    ['issue number', /\bissues?\s+#?\d+|\(#\d+|(?<![\w&#/])#\d+\b/gi],
    ['module alias', /(?<![\w.])[ESF]\.(?!g\.|e\.)[A-Za-z_][A-Za-z_0-9]*/g],
    ['dict/list repr', /\{'|\['|'\s*:\s|',\s*'/g],
    ['unrendered glue', /\{glue:|\bglue\(/g],
  ];
  // the API reference documents Python: None is a value there and snake_case names are the
  // names of parameters and functions, so these two apply to the reader's chapters only
  if (!OPT.api && !OPT.apiIndex) internalRules.push(
    // None as a value (the English "None of them" goes on with a lower-case word), "d = none"
    // ("cap=none", a reading's name, is an id like "integrator=euler": claims tables show them)
    ['None', /(?<![\w`])None(?![\w`])(?!\s+[a-z])|\s=\s*[Nn]one\b/g],
    // a snake_case identifier (a claim id, a choice or column name); x86_64 is a word
    ['claim id', /(?<![\w./:@-])(?!x86_64\b)[a-z][a-z0-9]*(?:_[a-z0-9]+)+(?![\w/@]|\.\w|\(|-\w)/g]);
  let nInternal = 0;
  for (const [what, re] of internalRules) {
    for (const m of flat.matchAll(re)) {
      const sp = spans.find(s => m.index >= s[0] && m.index < s[1]);
      if (what === 'claim id' && sp && sp[3]) continue;
      const ctxStart = Math.max(0, m.index - 30);
      const ctx = flat.slice(ctxStart, ctxStart + 60).replace(/\s+/g, ' ').trim();
      // "x_k", "w_0", "sigma_v": plain-text maths rather than an id (it fails all the same: the
      // reader should see x with a subscript k)
      const kind = what === 'claim id' && /^(?:[a-z]{1,3}|sigma|sum|max|min)_[a-z0-9]{1,2}$/.test(m[0]) ? 'ASCII subscript' : what;
      if (nInternal++ < OPT.maxInternal)
        fails.push({kind: 'internal', what: (sp ? label(sp[2]) : 'text') + ' ' + kind,
                    detail: `${JSON.stringify(m[0])} in "${ctx}"`, box: sp ? box(sp[2]) : undefined});
    }
  }
  // nan shown as a table value (any table, claims tables included)
  col.querySelectorAll('td, th').forEach(cell => {
    if (!shown(cell)) return;
    const t = cell.textContent.trim();
    // a value cell ("nan", "0.5 ± nan"), not a sentence that names NaN ("runs stopped (NaN from ...)")
    const nanRe = /(?<![\w.])(?:nan|NaN|<NA>|NaT)(?![\w])/g;
    const m = t.match(nanRe);
    if (m && !/\p{L}/u.test(t.replace(nanRe, '')) && nInternal++ < OPT.maxInternal)
      fails.push({kind: 'internal', what: label(cell) + ' nan in a table',
                  detail: `${JSON.stringify(m[0])} as a value in "${t.replace(/\s+/g, ' ').slice(0, 60)}"`, box: box(cell)});
  });

  return {mathjax, fails, notes, column: Math.round(colWidth), title: document.title};
})()
"""


_REFRESH = re.compile(r'<meta[^>]+http-equiv=["\']refresh["\'][^>]+content=["\'][^"\']*url=([^"\'>]+)', re.I)


def console_failures(events: list[dict]) -> list[dict]:
    out = []
    for ev in events:
        m, p = ev["method"], ev.get("params", {})
        if m == "Runtime.consoleAPICalled" and p.get("type") in ("error", "assert"):
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in p.get("args", []))
            out.append({"kind": "console", "what": "console." + p["type"], "detail": text[:300]})
        elif m == "Runtime.exceptionThrown":
            d = p.get("exceptionDetails", {})
            text = d.get("exception", {}).get("description") or d.get("text", "")
            out.append({"kind": "console", "what": "exception", "detail": f"{text[:300]} ({d.get('url', '')}:{d.get('lineNumber', '')})"})
        elif m == "Log.entryAdded" and p.get("entry", {}).get("level") == "error":
            e = p["entry"]
            out.append({"kind": "console", "what": "log." + e.get("source", ""), "detail": f"{e.get('text', '')[:200]} {e.get('url', '')}"})
        elif m == "Network.requestWillBeSent":
            url = p.get("request", {}).get("url", "")
            if not url.startswith(LOCAL_SCHEMES):
                out.append({"kind": "network", "what": "request", "detail": "blocked: " + url[:200]})
        elif m == "Network.webSocketCreated":
            out.append({"kind": "network", "what": "websocket", "detail": "blocked: " + p.get("url", "")[:200]})
    return out


class _IdsAndLinks(HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids: set[str] = set()
        self.links: list[str] = []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        if tag == "a" and a.get("name"):
            self.ids.add(a["name"])
        if tag == "a" and a.get("href"):
            self.links.append(a["href"])


def broken_links(root: Path, page: Path, _cache: dict = {}) -> list[dict]:
    """Links from ``page`` to pages of the book (and anchors in them) that do not exist."""
    def parse(p: Path) -> _IdsAndLinks:
        key = p.resolve()
        if key not in _cache:
            parser = _IdsAndLinks()
            parser.feed(p.read_text(encoding="utf-8", errors="replace"))
            _cache[key] = parser
        return _cache[key]

    out = []
    for href in parse(page).links:
        parts = urlsplit(href)
        if parts.scheme or parts.netloc or href.startswith(("mailto:", "javascript:")):
            continue
        target = (page.parent / unquote(parts.path)).resolve() if parts.path else page.resolve()
        if parts.path and not parts.path.endswith(".html"):
            if not target.exists():
                out.append({"kind": "link", "what": href[:100], "detail": "file not in the build"})
            continue
        try:
            target.relative_to(root.resolve())
        except ValueError:
            out.append({"kind": "link", "what": href[:100], "detail": "points outside the build"})
            continue
        if not target.is_file():
            out.append({"kind": "link", "what": href[:100], "detail": "page not in the build"})
        elif parts.fragment and unquote(parts.fragment) not in parse(target).ids:
            out.append({"kind": "link", "what": href[:100], "detail": f"no anchor #{parts.fragment} in {target.name}"})
    return out


def is_api_index(rel: str) -> bool:
    """Sphinx's generated indexes (names of functions and modules, not prose): no claim-id scan."""
    return rel.split("/")[-1] in ("genindex.html", "py-modindex.html", "search.html")


def is_api_page(rel: str) -> bool:
    """Pages of the API reference (generated from docstrings): checked for raw reST too."""
    return "/api/" in f"/{rel}"


def pages_under(root: Path) -> list[Path]:
    skip = {"_static", "_sources", "_images", "_downloads"}
    return sorted(p for p in root.rglob("*.html") if not skip & set(p.relative_to(root).parts[:-1]))


def check(root: Path, pages: list[Path], chromium: str, width: int, height: int,
          shots: Path | None, verbose: bool, browser: Browser | None = None) -> dict:
    """Check ``pages`` at one viewport; ``browser``: an open :class:`Browser` to reuse (kept open)."""
    own = browser is None
    if own:
        browser = Browser(chromium, width, height)
    browser.width, browser.height = width, height
    print(f"browser: {browser.version} ({chromium}), window {width}x{height}, offline")
    results = {}
    try:
        for page in pages:
            rel = page.relative_to(root).as_posix()
            t0 = time.monotonic()
            redirect = _REFRESH.search(page.read_text(encoding="utf-8", errors="replace")[:4000])
            if redirect:  # index.html: a meta-refresh stub; the page it points to is checked itself
                dest = (page.parent / unquote(urlsplit(redirect.group(1)).path))
                fails = [] if dest.is_file() else [{"kind": "link", "what": redirect.group(1), "detail": "redirect target missing"}]
                results[rel] = {"fails": fails, "notes": [f"redirect to {redirect.group(1)}"], "seconds": 0.0}
                print(f"{'ok  ' if not fails else 'FAIL'} {rel:<32} {'redirect to ' + redirect.group(1)}")
                continue
            try:
                target, session = browser.open(page.resolve().as_uri())
                opt = {"phone": width < PHONE_MAX, "api": is_api_page(rel),
                       "apiIndex": is_api_index(rel), "scrollAllowed": list(SCROLL_ALLOWED),
                       "maxTypeChars": MAX_TYPE_CHARS, "maxColumns": MAX_COLUMNS,
                       "maxInternal": MAX_INTERNAL_HITS}
                browser.evaluate(session, f"window.__pfopt = {json.dumps(opt)}; true")
                report = browser.evaluate(session, PAGE_JS, timeout=90)
                browser.pump(0.3)  # late console messages
                fails = console_failures(browser.events) + report["fails"] + broken_links(root, page)
                if report["mathjax"] not in ("done", "none"):
                    fails.append({"kind": "math", "what": "MathJax", "detail": report["mathjax"]})
                if shots is not None:
                    stem = rel.replace("/", "_").removesuffix(".html") + f"_{width}"
                    browser.screenshot(session, shots / f"{stem}.png")
                    for i, f in enumerate(x for x in fails if x.get("box")):
                        b = f["box"]
                        clip = {"x": max(0, b["x"] - 20), "y": max(0, b["y"] - 20),
                                "width": min(width, b["width"] + 40) or 1, "height": min(1500, b["height"] + 40) or 1}
                        browser.screenshot(session, shots / f"{stem}__{i:02d}_{f['kind']}.png", clip)
                browser.call("Target.closeTarget", {"targetId": target})
                notes = report["notes"]
            except CDPError as exc:
                fails, notes = [{"kind": "console", "what": "driver", "detail": str(exc)}], []
            results[rel] = {"fails": fails, "notes": notes, "seconds": time.monotonic() - t0}
            counts = {k: sum(f["kind"] == k for f in fails) for k in KINDS}
            status = "ok  " if not fails else "FAIL"
            summary = ", ".join(f"{k} {n}" for k, n in counts.items() if n) or "clean"
            print(f"{status} {rel:<32} {summary:<40} [{'; '.join(n for n in notes if not n.startswith('scrolled'))}] "
                  f"{results[rel]['seconds']:.1f}s")
            for f in fails:
                print(f"       {f['kind']:<9} {f['what']}: {f['detail']}")
            if verbose:
                for n in notes:
                    if n.startswith("scrolled"):
                        print(f"       note      {n}")
    finally:
        if own:
            browser.close()
    return results


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("pages", nargs="*", help="pages relative to --root (default: every page)")
    ap.add_argument("--root", default="_build/html", type=Path, help="built HTML (default _build/html)")
    ap.add_argument("--chromium", help="browser executable (default: $CHROMIUM or chromium)")
    ap.add_argument("--widths", default=",".join(map(str, WIDTHS)),
                    help=f"comma-separated viewport widths in CSS px (default {','.join(map(str, WIDTHS))})")
    ap.add_argument("--height", type=int, default=900)
    ap.add_argument("--screenshots", type=Path, help="save a full-page PNG per page (and a clip per failure) here")
    ap.add_argument("--json", type=Path, help="write the per-page results here")
    ap.add_argument("-v", "--verbose", action="store_true", help="also list horizontally scrolled tables")
    args = ap.parse_args(argv)

    root = args.root
    if not (root / "index.html").is_file():
        print(f"ERROR: no built book at {root} (run the book build first)", file=sys.stderr)
        return 2
    chromium = find_chromium(args.chromium)
    if chromium is None:
        print("ERROR: no chromium found (apt-get install -y chromium, or set $CHROMIUM)", file=sys.stderr)
        return 2
    pages = [root / p for p in args.pages] if args.pages else pages_under(root)
    if args.screenshots:
        args.screenshots.mkdir(parents=True, exist_ok=True)
    t0 = time.monotonic()
    results = {}
    for width in (int(w) for w in args.widths.split(",") if w.strip()):
        print(f"\n=== viewport {width} px ({'phone' if width < PHONE_MAX else 'laptop'}) ===")
        for rel, r in check(root, pages, chromium, width, args.height, args.screenshots, args.verbose).items():
            results[f"{rel} @{width}"] = r
    totals = {k: sum(f["kind"] == k for r in results.values() for f in r["fails"]) for k in KINDS}
    bad = [p for p, r in results.items() if r["fails"]]
    print(f"\n{len(results)} page views, {len(bad)} failing, {time.monotonic() - t0:.0f}s; failures by kind: "
          + ", ".join(f"{k} {n}" for k, n in totals.items()))
    if args.json:
        args.json.write_text(json.dumps({"totals": totals, "pages": results}, indent=1))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
