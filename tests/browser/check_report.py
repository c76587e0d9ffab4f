"""Open fpkbench's report.html pages in headless Chromium and check that they render.

Usage: check_report.py SCREENSHOT_DIR PAGE.html [PAGE.html ...]

For every page: no console error and no page error; every inline figure (<svg>) has a
laid-out size and at least one drawn path; every <table> has a header and at least one
row (folded sections opened first); every figure caption links its PNG and PDF and those
files exist beside the page; the contents link to headings that exist. At a phone's
420 px the page does not scroll sideways (wide tables scroll in their own box). Full-page
screenshots at 1400 and 420 px are kept in SCREENSHOT_DIR. Chromium is Debian's
(/usr/bin/chromium, or $CHROMIUM), driven by Playwright's Python client.
"""

import os
import pathlib
import sys

from playwright.sync_api import sync_playwright

CHROMIUM = os.environ.get("CHROMIUM", "/usr/bin/chromium")
# Chromium's background connections are refused on a closed network; keep it quiet.
ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def check(browser, page_path: pathlib.Path, shots: pathlib.Path) -> list[str]:
    problems = []
    page = browser.new_page(viewport={"width": 1400, "height": 900})
    page.on("console", lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error" else None)
    page.on("pageerror", lambda e: problems.append(f"page error: {e}"))
    page.on("requestfailed", lambda r: problems.append(f"request failed: {r.url}"))
    page.goto(page_path.resolve().as_uri(), wait_until="load")
    shot = shots / (page_path.parent.name + "-" + page_path.stem + "-1400.png")
    page.screenshot(path=str(shot), full_page=True)
    page.evaluate("() => document.querySelectorAll('details').forEach(d => d.open = true)")
    missing = page.evaluate(
        """() => Array.from(document.querySelectorAll('nav.toc a'))
            .map(a => a.getAttribute('href').slice(1)).filter(id => !document.getElementById(id))"""
    )
    for id in missing:
        problems.append(f"the contents link to #{id}, which the page does not have")
    figures = page.evaluate(
        """() => Array.from(document.querySelectorAll('figure')).map(f => {
            const svg = f.querySelector('svg');
            const box = svg ? svg.getBoundingClientRect() : {width: 0, height: 0};
            return {
                caption: (f.querySelector('figcaption') || {}).textContent || '',
                width: box.width, height: box.height,
                paths: svg ? svg.querySelectorAll('path').length : 0,
                texts: svg ? svg.querySelectorAll('text').length : 0,
                links: Array.from(f.querySelectorAll('figcaption .files a')).map(a => a.getAttribute('href')),
            };
        })"""
    )
    tables = page.evaluate(
        """() => Array.from(document.querySelectorAll('table')).map(t => ({
            head: t.querySelectorAll('thead th').length,
            rows: t.querySelectorAll('tbody tr').length,
            height: t.getBoundingClientRect().height,
        }))"""
    )
    if not figures:
        problems.append("no figure on the page")
    for k, f in enumerate(figures):
        name = f"figure {k + 1} ({f['caption'][:60]!r})"
        if f["width"] < 100 or f["height"] < 100:
            problems.append(f"{name}: not laid out ({f['width']:.0f}×{f['height']:.0f} px)")
        if f["paths"] < 1 or f["texts"] < 1:
            problems.append(f"{name}: nothing drawn ({f['paths']} paths, {f['texts']} texts)")
        for href in f["links"]:
            if not (page_path.parent / href).is_file():
                problems.append(f"{name}: links {href}, which is not beside the page")
    if not tables:
        problems.append("no table on the page")
    for k, t in enumerate(tables):
        if t["head"] < 1 or t["rows"] < 1 or t["height"] < 10:
            problems.append(f"table {k + 1}: {t['head']} header cells, {t['rows']} rows, {t['height']:.0f} px tall")
    page.set_viewport_size({"width": 420, "height": 900})
    wide = page.evaluate("() => document.documentElement.scrollWidth")
    if wide > 421:
        problems.append(f"at 420 px the page is {wide} px wide: it scrolls sideways")
    phone = shots / (page_path.parent.name + "-" + page_path.stem + "-420.png")
    page.screenshot(path=str(phone), full_page=True)
    print(f"{page_path}: {len(figures)} figures, {len(tables)} tables, {wide} px wide at 420, screenshots {shot}, {phone}")
    page.close()
    return problems


def main() -> int:
    shots = pathlib.Path(sys.argv[1])
    shots.mkdir(parents=True, exist_ok=True)
    failed = False
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=ARGS)
        for arg in sys.argv[2:]:
            problems = check(browser, pathlib.Path(arg), shots)
            for msg in problems:
                print(f"  {arg}: {msg}")
            failed |= bool(problems)
        browser.close()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
