"""The editor's curve panel with real readings: `nutty serve --hardware-emulator` (the servo stack on bus
emulators) in headless Chromium; picking a joint shows the measured line and the tracking legend."""

from __future__ import annotations

import pytest
from editor_browser import ARTIFACTS, editor_page, wait_until
from server_process import running_server

from tests.emulated_hardware import emulated_hardware_file

pytestmark = [pytest.mark.browser, pytest.mark.server]


def test_the_curve_panel_plots_what_the_servos_measured_beside_what_they_were_sent(tmp_path):
    hardware = emulated_hardware_file(tmp_path)
    with running_server("--hardware-emulator", str(hardware), "--no-previz") as (url, _, client):
        with editor_page(url) as page:
            panel = page.get_by_test_id("curve-panel")
            panel.scroll_into_view_if_needed()
            picker = page.get_by_label("DoF to plot")
            wait_until(
                lambda: "●measured" in " ".join(picker.locator("option").all_inner_texts()),
                20,
                "the series picker to mark the joints read at their motors",
            )
            picker.select_option("joint:head_yaw")
            plot = page.get_by_test_id("curve-plot")
            wait_until(lambda: plot.get_attribute("data-measured") == "joint:head_yaw", 20, "a measured line")
            legend = page.get_by_test_id("curve-measured")
            wait_until(lambda: "head_yaw: tracking" in legend.inner_text(), 10, "the tracking legend")
            text = legend.inner_text()
            peak = float(text.split("tracking ")[1].split(" rad")[0])
            assert 0.0 <= peak < 0.1, text  # emulated servos follow their goals closely
            assert "measured" in page.locator(".curve-head .legend").inner_text()
            ARTIFACTS.mkdir(exist_ok=True)
            panel.screenshot(path=str(ARTIFACTS / "curve-measured-servos.png"))
        assert client.status()["hardware"]["faults"] == []
