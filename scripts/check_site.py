"""Check the built documentation site in a real browser: headless Chromium through
Selenium (Debian: ``apt-get install chromium chromium-driver python3-selenium``).

    python scripts/check_site.py [_site/html]

Every page is served locally and loaded; the check fails, naming the page, on:

- a console error (a script that fails, a resource that does not load);
- an image that does not load;
- an internal link to a file of the site that does not exist;
- formulas that MathJax did not render (docs/method.md);
- a search for ``add_contact_pair`` that finds nothing;
- a TOML key (docs/toml.html), a flag of the command (docs/cli.html) or of a demo (its
  page) missing from the site, a demo missing from the gallery or a demo page without a
  picture (read from the pages' HTML, against the objects the site is made from).

Prints one line per problem and a summary; exits 1 if there is any. About a minute.
"""

from __future__ import annotations

import argparse
import functools
import html
import http.server
import os
import sys
import threading
import time
import urllib.parse

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(REPO, "docs", "_ext"))

#: The search the site must answer (a method of the API reference).
SEARCH = "add_contact_pair"
#: The page whose formulas must render.
MATH_PAGE = "docs/method.html"

BROKEN_IMAGES = """return Array.from(document.images)
    .filter(i => !i.complete || i.naturalWidth === 0).map(i => i.src);"""
LINKS = "return Array.from(document.querySelectorAll('a[href]')).map(a => a.href);"
SEARCH_RESULTS = """return Array.from(document.querySelectorAll('#search-results li'))
    .map(l => l.innerText);"""
MATH_STATE = """const done = window.MathJax && MathJax.Hub && MathJax.Hub.queue.pending === 0
    && MathJax.Hub.queue.running === 0;
return [Boolean(done), document.querySelectorAll('.MathJax_CHTML').length,
        document.querySelectorAll('.MathJax_Error, merror').length];"""


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


def serve(folder: str) -> tuple[http.server.ThreadingHTTPServer, str]:
    """Serve ``folder`` on a free local port, in a thread; returns the server and its URL."""
    handler = functools.partial(_Quiet, directory=folder)
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    threading.Thread(target=server.serve_forever, daemon=True).start()
    return server, f"http://127.0.0.1:{server.server_address[1]}/"


def browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage"):
        options.add_argument(flag)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)


def pages_of(folder: str) -> list[str]:
    """Every HTML page of the site, relative to its folder (not the sources' copies)."""
    pages = []
    for root, dirs, files in os.walk(folder):
        dirs[:] = [d for d in dirs if d not in ("_static", "_sources", "_images")]
        for name in files:
            if name.endswith(".html"):
                pages.append(os.path.relpath(os.path.join(root, name), folder))
    return sorted(pages)


def wait(condition, seconds: float = 20.0):
    """The first true value of ``condition()`` within ``seconds`` (None after)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        value = condition()
        if value:
            return value
        time.sleep(0.1)
    return None


def check_page(driver, url: str, page: str, folder: str) -> list[str]:
    driver.get(url + page)
    wait(lambda: driver.execute_script("return document.readyState") == "complete")
    problems = [
        f"{page}: console: {entry['message']}"
        for entry in driver.get_log("browser")
        if entry["level"] == "SEVERE"
    ]
    problems += [f"{page}: image not loaded: {src}" for src in driver.execute_script(BROKEN_IMAGES)]
    if driver.execute_script("return typeof MathJax === 'object'"):  # a page with formulas
        problems += math_problems(driver, page)
    for href in driver.execute_script(LINKS):
        if not href.startswith(url):
            continue  # another site: not checked (no network here)
        target = urllib.parse.unquote(urllib.parse.urlsplit(href).path)
        path = os.path.join(folder, target.lstrip("/"))
        if os.path.isdir(path):
            path = os.path.join(path, "index.html")
        if not os.path.exists(path):
            problems.append(f"{page}: broken link: {href[len(url) :]}")
    return problems


def math_problems(driver, page: str) -> list[str]:
    """The formulas of the loaded page: rendered by MathJax, none in error."""
    state = wait(lambda: (lambda s: s if s[0] else None)(driver.execute_script(MATH_STATE)), 60)
    if state is None:
        return [f"{page}: MathJax did not finish"]
    _, rendered, errors = state
    problems = [] if rendered > 0 else [f"{page}: no formula rendered"]
    return problems + ([f"{page}: {errors} formulas in error"] if errors else [])


def check_math(driver, url: str) -> list[str]:
    """The method's page has formulas, and they render."""
    driver.get(url + MATH_PAGE)
    if not driver.execute_script("return typeof MathJax === 'object'"):
        return [f"{MATH_PAGE}: no MathJax on the page"]
    return math_problems(driver, MATH_PAGE)


def check_search(driver, url: str) -> list[str]:
    driver.get(f"{url}search.html?q={SEARCH}")
    found = wait(lambda: driver.execute_script(SEARCH_RESULTS), 30) or []
    if not any(SEARCH in text for text in found):
        return [f"search.html: searching {SEARCH} found nothing"]
    return []


def _text(folder: str, page: str) -> str:
    path = os.path.join(folder, page)
    if not os.path.exists(path):
        return ""
    with open(path) as f:
        return f.read()


def _literal(name: str) -> str:
    """How the site writes ``name`` as code: in spans of class "pre", one per word."""
    return "".join(f'<span class="pre">{html.escape(word)}</span>' for word in name.split())


def option_strings(parser) -> list[str]:
    """Every option of ``parser`` and of its subcommands (but -h, --help: sphinx-argparse
    leaves them out of the command's page)."""
    options = []
    for action in parser._actions:
        if not isinstance(action, argparse._HelpAction):
            options += action.option_strings
        if isinstance(action, argparse._SubParsersAction):
            for subcommand in action.choices.values():
                options += option_strings(subcommand)
    return options


def check_contents(folder: str) -> list[str]:
    """Every TOML key, flag and demo where the site promises them (static: the HTML)."""
    import generated

    from nitsche_dolfinx.cli import command as cli
    from nitsche_dolfinx.config import schema

    problems = []
    toml = _text(folder, "docs/toml.html")
    for registry in (schema.SCHEMA, schema.FACET_SELECTORS):
        for name, table in registry.items():
            shown = table.header(name) if registry is schema.SCHEMA else name
            missing = [key for key in [shown, *table.keys] if _literal(key) not in toml]
            problems += [f"docs/toml.html: no TOML key {name}.{key}" for key in missing]
    for name, obstacle in schema.OBSTACLES.items():
        missing = [key for key in [name, *obstacle.keys] if _literal(key) not in toml]
        problems += [f"docs/toml.html: no obstacle key {name}.{key}" for key in missing]
    for name in schema.MESH_GENERATORS:
        if _literal(name) not in toml:
            problems.append(f"docs/toml.html: no mesh generator {name}")
    text = _text(folder, "docs/cli.html")
    for option in option_strings(cli.argument_parser()):
        if not generated.has_flag(text, option):
            problems.append(f"docs/cli.html: no flag {option}")
    gallery = _text(folder, "docs/gallery.html")
    for demo in generated.demo_names():
        page = _text(folder, f"demos/{demo}.html")
        for option in option_strings(generated.demo_parser(demo)):
            if not generated.has_flag(page, option):
                problems.append(f"demos/{demo}.html: no flag {option}")
        if "<img" not in page:
            problems.append(f"demos/{demo}.html: no picture")
        if f'href="../demos/{demo}.html"' not in gallery:
            problems.append(f"docs/gallery.html: no demo {demo}")
    return problems


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("site", nargs="?", default="_site/html", help="the built site")
    args = parser.parse_args(argv)
    folder = os.path.abspath(args.site)
    if not os.path.exists(os.path.join(folder, "search.html")):
        print(f"site={args.site}: no built site there (make docs)", file=sys.stderr)
        return 1
    start = time.monotonic()
    server, url = serve(folder)
    driver = browser()
    try:
        pages = pages_of(folder)
        problems = check_contents(folder)
        for page in pages:
            problems += check_page(driver, url, page, folder)
        problems += check_math(driver, url) + check_search(driver, url)
    finally:
        driver.quit()
        server.shutdown()
    for problem in problems:
        print(problem)
    seconds = time.monotonic() - start
    print(f"{len(pages)} pages checked in {seconds:.0f} s: {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
