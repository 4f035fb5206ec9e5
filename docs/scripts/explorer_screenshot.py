"""Screenshot of a chart explorer page (docs/figures/explorer-vakharia2015.png).

Opens the page from disk in headless Chromium (as tests/reports/test_explore.py does), clicks the
point nearest to the given coordinates and saves the window as PNG::

    python docs/scripts/explorer_screenshot.py chart.html --x 5000 --y 6 \
        -o docs/figures/explorer-vakharia2015.png
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from tests.browser import start_chromium  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("page", type=Path)
    parser.add_argument("--x", type=float, required=True, help="x coordinate of the point")
    parser.add_argument("--y", type=float, required=True, help="y coordinate of the point")
    parser.add_argument("-o", "--output", type=Path, required=True)
    args = parser.parse_args()
    browser_session = start_chromium()
    browser = next(browser_session)
    try:
        browser.set_window_size(1400, 1000)
        browser.get(args.page.resolve().as_uri())
        ix, iy = browser.execute_script(
            "const p = D.points.reduce((a, b) => Math.hypot(b.x - arguments[0], b.y - "
            "arguments[1]) < Math.hypot(a.x - arguments[0], a.y - arguments[1]) ? b : a);"
            "return [p.ix, p.iy];", args.x, args.y)
        browser.find_element("css selector", f'rect[data-ix="{ix}"][data-iy="{iy}"]').click()
        browser.save_screenshot(str(args.output))
    finally:
        browser_session.close()
    print(f"wrote {args.output}: point ({ix}, {iy}) selected")


if __name__ == "__main__":
    main()
