"""The Pre-Viz follows the editor's theme: PUT /api/previz/theme turns viser's background (seen in a real
browser, through the Pre-Viz process `nutty serve` runs) dark or light."""

from __future__ import annotations

import io

import pytest
from editor_browser import ARGS, ARTIFACTS, BROWSER, CHROMIUM, wait_until
from server_process import free_port

from backend.graph.builder import ProgramBuilder
from backend.previz import THEME_BACKGROUNDS
from backend.session import EngineSession

pytestmark = BROWSER


@pytest.fixture()
def served(desk):
    from fastapi.testclient import TestClient

    from backend.api import create_app
    from backend.previz_process import PreVizProcess

    b = ProgramBuilder("still")
    b.chain(b.node("rest_pose", "rest"), b.output())
    session = EngineSession.create(desk, rate=100, program=b.build())
    pv = PreVizProcess(session, port=free_port())
    pv.wait_ready()
    with TestClient(create_app(session, previz=pv, frontend_dir=None)) as client:
        yield pv, client
    pv.stop()
    session.engine.close()


def _corner(page) -> tuple[int, int, int]:
    from PIL import Image

    shot = Image.open(io.BytesIO(page.screenshot())).convert("RGB")
    return shot.getpixel((8, shot.height - 8))  # a corner: background, not the robot or the grid


def test_the_background_follows_the_editors_theme(served):
    from playwright.sync_api import sync_playwright

    pv, client = served
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        try:
            page = browser.new_page(viewport={"width": 640, "height": 480})
            page.goto(pv.url("127.0.0.1") + "/")
            page.locator("canvas").first.wait_for()
            for theme in ("dark", "light", "dark"):
                r = client.put("/api/previz/theme", json={"theme": theme})
                assert r.status_code == 200 and r.json() == {"theme": theme}
                want = THEME_BACKGROUNDS[theme]
                wait_until(
                    lambda want=want: all(abs(a - b) <= 6 for a, b in zip(_corner(page), want, strict=True)),
                    timeout=30,
                    what=f"the {theme} background",
                )
            page.screenshot(path=str(ARTIFACTS / "previz-dark.png"))
        finally:
            browser.close()
    assert client.put("/api/previz/theme", json={"theme": "pink"}).status_code == 422
