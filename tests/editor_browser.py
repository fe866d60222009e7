"""What the editor's browser tests share: headless Chromium on a page of a real `nutty serve`, a
scratch copy of the bundled robot (saves never touch the repository), waiting, and mouse drags."""

from __future__ import annotations

import re
import shutil
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DIST = ROOT / "frontend" / "dist" / "index.html"
CHROMIUM = "/usr/bin/chromium"
ARTIFACTS = ROOT / "test-artifacts"
ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--enable-unsafe-swiftshader",
]
VALID = re.compile(r"^valid ·")

#: The marks of every browser test module (`pytestmark = BROWSER`).
BROWSER = [
    pytest.mark.browser,
    pytest.mark.skipif(not DIST.exists(), reason="frontend/dist is not built (make test builds it)"),
    pytest.mark.skipif(not Path(CHROMIUM).exists(), reason="/usr/bin/chromium is not installed"),
]


def scratch_robot(tmp_path_factory, keep: tuple[str, ...] | None = None) -> Path:
    """A copy of the bundled robot in a temporary folder; with `keep`, only those programs stay."""
    robot = tmp_path_factory.mktemp("robot") / "nutty_desk"
    shutil.copytree(ROOT / "robots" / "nutty_desk", robot)
    if keep is not None:
        for p in (robot / "programs").glob("*.json"):
            if p.stem not in keep:
                p.unlink()
    return robot


@contextmanager
def editor_page(url: str, timeout_ms: int = 25000, on_dialog: Callable | None = None) -> Iterator:
    """A 1600×1000 page of the editor at `url`, once its status says the program is valid."""
    from playwright.sync_api import sync_playwright

    ARTIFACTS.mkdir(exist_ok=True)
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.set_default_timeout(timeout_ms)
            if on_dialog is not None:
                page.on("dialog", on_dialog)
            page.goto(url + "/")
            page.get_by_test_id("status").filter(has_text=VALID).wait_for()
            yield page
        finally:
            browser.close()


@contextmanager
def editor_server(
    tmp_path_factory, files: dict[str, object] | None = None, program: str | None = None
) -> Iterator[dict]:
    """`nutty serve` (without viser) on a scratch copy of the bundled robot holding only its interactive
    program, plus `files` (a path in the robot's folder -> its JSON); `program` is one of those files to
    run instead. Yields {"url", "client", "robot"}."""
    import json

    from server_process import running_server

    robot = scratch_robot(tmp_path_factory, keep=("interactive",))
    for rel, doc in (files or {}).items():
        (robot / rel).parent.mkdir(parents=True, exist_ok=True)
        (robot / rel).write_text(json.dumps(doc))
    extra = ("--program", str(robot / program)) if program else ()
    with running_server("--robot", str(robot), *extra, "--no-previz") as (url, _, client):
        yield {"url": url, "client": client, "robot": robot}


def running_program(server: dict) -> dict:
    """The program the server runs now (GET /api/program)."""
    return server["client"].program()["program"]


def wait_until(fn, timeout: float = 10.0, what: str = "condition") -> None:
    """Poll `fn` until it is true; the timeout only bounds a hang."""
    end = time.time() + timeout
    while time.time() < end:
        if fn():
            return
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


def centre(box) -> tuple[float, float]:
    return box["x"] + box["width"] / 2, box["y"] + box["height"] / 2


def settled_box(locator, timeout: float = 3.0) -> dict:
    """`locator`'s bounding box once it stopped moving (two reads 50 ms apart agree): right after a
    load the canvas still frames the program, and a drag aimed at a moving block misses it."""
    box, end = locator.bounding_box(), time.time() + timeout
    while time.time() < end:
        time.sleep(0.05)
        again = locator.bounding_box()
        if again == box:
            break
        box = again
    return box


def drag_to_point(page, src, x: float, y: float) -> None:
    """Press on `src`, move to (x, y) in steps, release (a wire dragged by hand)."""
    sx, sy = centre(settled_box(src))
    page.mouse.move(sx, sy)
    page.mouse.down()
    page.mouse.move(sx + 20, sy + 5)  # React Flow drops the first move of a drag
    page.mouse.move(x, y, steps=8)
    page.mouse.up()


def drag(page, src, dst) -> None:
    drag_to_point(page, src, *centre(settled_box(dst)))


def handle(page, node: str, port: str, kind: str):
    """The port `port` of block `node`; `kind` is "source" (an output) or "target" (an input)."""
    return page.locator(f"[data-testid=node-{node}] .react-flow__handle.{kind}[data-handleid='{port}']")


def edges(server: dict) -> set[tuple[str, str, str, str]]:
    """The running program's wires as (from node, port, to node, port)."""
    return {
        (e["from"]["node"], e["from"]["port"], e["to"]["node"], e["to"]["port"])
        for e in running_program(server)["edges"]
    }


def show_program(page, server: dict, prog: dict, settle: Callable | None = None) -> None:
    """Run `prog` on the server and reload the page until it shows it; then `settle(page)`, or a short
    pause for the opening frame (set once React Flow has measured the blocks)."""
    server["client"].load_program(prog)
    page.reload()
    page.get_by_test_id("status").filter(has_text=VALID).wait_for()
    page.get_by_test_id(f"node-{prog['nodes'][0]['id']}").wait_for()
    if settle is not None:
        settle(page)
    else:
        time.sleep(0.3)


def zoom(page) -> float:
    """The canvas's zoom (React Flow's viewport scale)."""
    return page.evaluate("""() => {
        const t = getComputedStyle(document.querySelector('.react-flow__viewport')).transform;
        return new DOMMatrixReadOnly(t).a;
    }""")


def canvas_point(page, fx: float, fy: float) -> tuple[float, float]:
    """A point of the canvas at fractions of its width and height."""
    box = page.locator(".react-flow__pane").bounding_box()
    return box["x"] + box["width"] * fx, box["y"] + box["height"] * fy


def empty_canvas_point(page) -> tuple[float, float]:
    """A point of the canvas with nothing on it (no block, wire or control), near its lower left."""
    for fy in (0.9, 0.8, 0.7, 0.6):
        for fx in (0.1, 0.2, 0.3, 0.45, 0.6):
            x, y = canvas_point(page, fx, fy)
            if page.evaluate(
                "([x, y]) => document.elementFromPoint(x, y)?.classList.contains('react-flow__pane')", [x, y]
            ):
                return x, y
    raise AssertionError("no empty point on the canvas")
