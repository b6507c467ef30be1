"""A built docs site checked in headless Chromium: each page served from a local HTTP server and
loaded by the browser, which runs its scripts and fetches its images, styles and fonts.

What counts as broken: a console error the browser logs (a script error, a resource that failed),
a request the server answers with an error status (a missing image or script), and a link in a
page's DOM to a file of the site that is not there (the strict build checks the Markdown links;
this also covers links written as HTML and those the theme adds)."""

from __future__ import annotations

import functools
import re
import shutil
import subprocess
import threading
from dataclasses import dataclass, field
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import unquote, urljoin, urlparse

CHROMIUM = next((found for name in ("chromium", "chromium-browser", "google-chrome")
                 if (found := shutil.which(name))), None)
PAGE_SECONDS = 600  # a hang guard: a page loads in seconds, a busy host makes it slower, never this slow
# Chromium logs page console messages to stderr as [...:INFO:CONSOLE:line] "message", source: url
# (older releases: CONSOLE(line))
_CONSOLE = re.compile(r':(?:INFO|WARNING|ERROR):CONSOLE[:(]\d+\)?\] "(.*)", source: (\S*)')
_ERROR_WORDS = ("error", "failed", "uncaught", "refused")
_HREF = re.compile(r'<(?:a|link)\b[^>]*\bhref="([^"]+)"')
_SRC = re.compile(r'<(?:img|script|source)\b[^>]*\bsrc="([^"]+)"')


@dataclass
class SiteReport:
    """What browsing the site found (empty lists: nothing broken)."""

    pages: int = 0
    console_errors: list[str] = field(default_factory=list)
    failed_requests: list[str] = field(default_factory=list)
    broken_links: list[str] = field(default_factory=list)


class _Logged(SimpleHTTPRequestHandler):
    """Serves the site and records every request's path and status."""

    def __init__(self, *args, requests: list, **kwargs):
        self._requests = requests
        super().__init__(*args, **kwargs)

    def log_request(self, code="-", size="-") -> None:
        self._requests.append((self.path, int(code) if str(code).isdigit() else 0))

    def log_message(self, format, *args) -> None:  # quiet: the test reads the list
        pass


def browse_site(site: Path) -> SiteReport:
    """Load every ``index.html`` of the built ``site`` in headless Chromium (one process per
    page) and report what was broken."""
    requests: list[tuple[str, int]] = []
    handler = functools.partial(_Logged, directory=str(site), requests=requests)
    server = ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    base = f"http://127.0.0.1:{server.server_address[1]}/"
    report = SiteReport()
    try:
        for page in sorted(site.rglob("index.html")):
            rel = page.parent.relative_to(site).as_posix()
            url = base + ("" if rel == "." else rel + "/")
            dom, errors = _load(url)
            report.pages += 1
            report.console_errors += [f"{url}: {e}" for e in errors]
            report.broken_links += [f"{url}: {target}" for target in _missing_targets(dom, url, base, site)]
    finally:
        server.shutdown()
        server.server_close()
    report.failed_requests = sorted({f"{status} {path}" for path, status in requests if status >= 400})
    return report


def _load(url: str) -> tuple[str, list[str]]:
    """The page's DOM after its scripts ran, and the console messages that are errors."""
    cmd = [CHROMIUM, "--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
           "--disable-extensions", "--enable-logging=stderr", "--v=0", "--virtual-time-budget=5000",
           "--dump-dom", url]
    try:
        done = subprocess.run(cmd, capture_output=True, text=True, timeout=PAGE_SECONDS)
    except subprocess.TimeoutExpired:
        return "", [f"the page did not finish loading in {PAGE_SECONDS} s"]
    errors = [f"{m.group(1)} ({m.group(2)})" for m in _CONSOLE.finditer(done.stderr)
              if any(w in m.group(1).lower() for w in _ERROR_WORDS)]
    if done.returncode != 0 or not done.stdout.strip():
        errors.append(f"chromium exited {done.returncode}: {done.stderr.strip()[-300:]}")
    return done.stdout, errors


def _missing_targets(dom: str, url: str, base: str, site: Path) -> list[str]:
    """Links and sources in ``dom`` that point into the site at a file it does not have."""
    missing = []
    for target in _HREF.findall(dom) + _SRC.findall(dom):
        full = urljoin(url, target)
        if not full.startswith(base):
            continue  # another site: not ours to check offline
        path = unquote(urlparse(full).path)[len(urlparse(base).path):]
        found = site / path
        if path == "" or path.endswith("/"):
            found = found / "index.html"
        if not found.exists():
            missing.append(target)
    return missing
