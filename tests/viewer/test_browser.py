"""The viewer page in a real headless Chromium: costmap and scans drawn, a 2D Nav Goal by click and drag."""

import math
import shutil
from pathlib import Path

import pytest

from simplebot_navigation.ros.conversions import yaw_of
from tests.viewer.conftest import BACK_WALL_X, FRONT_WALL_X, INSCRIBED_BLOCK, LETHAL_BLOCK, UNKNOWN_BLOCK

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARTIFACTS = Path(__file__).resolve().parents[2] / "artifacts" / "viewer"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]
SCALE = 60.0  # pixels per metre in the checked view
# Colours the page gives each layer (viewer.js), as canvas RGBA.
LETHAL = (160, 0, 200, 255)
INSCRIBED = (0, 255, 255, 255)
UNKNOWN = (112, 128, 144, 90)
FRONT_SCAN = (224, 0, 0, 255)
BACK_SCAN = (240, 112, 0, 255)

sync_api = pytest.importorskip("playwright.sync_api", reason="Playwright for Python is not installed")
if CHROMIUM is None:
    pytest.skip("no system Chromium (apt-get install chromium) for the browser test", allow_module_level=True)


@pytest.fixture(scope="module")
def page(scenario):
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        page.goto(scenario.viewer.url)
        page.wait_for_function("() => window.viewer && window.viewer.state.grids.global_costmap"
                               " && window.viewer.state.layers.front_scan && window.viewer.state.layers.back_scan"
                               " && window.viewer.state.body && window.viewer.state.frame.robot", timeout=20000)
        yield page
        browser.close()


def show(page, x=0.0, y=0.0):
    page.evaluate(f"() => window.viewer.setView({x}, {y}, {SCALE})")


def pixel(page, x, y):
    """Canvas RGBA at the world point (x, y) of the fixed frame."""
    return tuple(page.evaluate("""([x, y]) => {
        const canvas = document.getElementById('canvas');
        const [px, py] = window.viewer.worldToPage(x, y);
        const r = canvas.getBoundingClientRect(), k = canvas.width / r.width;
        return Array.from(canvas.getContext('2d').getImageData(
            Math.floor((px - r.left) * k), Math.floor((py - r.top) * k), 1, 1).data);
    }""", [x, y]))


def centre(block):
    x0, y0, x1, y1 = block
    return (x0 + x1) / 2, (y0 + y1) / 2


def nearest_point(page, layer, x, y):
    data = page.evaluate(f"() => Array.from(window.viewer.state.layers.{layer}.data)")
    points = list(zip(data[::2], data[1::2]))
    return min(points, key=lambda p: math.hypot(p[0] - x, p[1] - y))


def toggle(page, layer, on):
    box = page.locator(f"input[data-layer={layer}]")
    if box.is_checked() != on:
        box.click()


def test_costmap_cells_in_cost_colours_and_layer_toggle(page):
    show(page)
    assert pixel(page, *centre(LETHAL_BLOCK)) == LETHAL
    assert pixel(page, *centre(INSCRIBED_BLOCK)) == INSCRIBED
    # Translucent colours go through the canvas's premultiplied alpha: equal within rounding.
    assert pixel(page, *centre(UNKNOWN_BLOCK)) == pytest.approx(UNKNOWN, abs=2)
    assert pixel(page, -3.5, -3.5)[3] == 0  # free space stays clear
    toggle(page, "global_costmap", False)
    page.evaluate("() => window.viewer.render()")
    assert pixel(page, *centre(LETHAL_BLOCK))[3] == 0
    toggle(page, "global_costmap", True)
    page.evaluate("() => window.viewer.render()")
    assert pixel(page, *centre(LETHAL_BLOCK)) == LETHAL


def test_both_scans_drawn_on_their_walls(page):
    show(page)
    front = nearest_point(page, "front_scan", FRONT_WALL_X, 1.0)
    back = nearest_point(page, "back_scan", BACK_WALL_X, 1.0)
    # The points are in odom, on the walls the lidars see (robot at the origin).
    assert front[0] == pytest.approx(FRONT_WALL_X, abs=0.02) and front[1] == pytest.approx(1.0, abs=0.05)
    assert back[0] == pytest.approx(BACK_WALL_X, abs=0.02) and back[1] == pytest.approx(1.0, abs=0.05)
    assert pixel(page, *front) == pytest.approx(FRONT_SCAN, abs=2)
    assert pixel(page, *back) == pytest.approx(BACK_SCAN, abs=2)


@pytest.mark.parametrize("tool", ["goal-tool", "pose-tool"])
def test_2d_nav_goal_and_pose_estimate_click_and_drag(page, scenario, tool):
    """The two tools of RViz: a goal on /move_base_simple/goal, a pose for the localizer on /initialpose."""
    show(page)
    x, y, heading = 1.2, -1.8, math.radians(135.0)
    start = page.evaluate(f"() => window.viewer.worldToPage({x}, {y})")
    end = page.evaluate(f"() => window.viewer.worldToPage({x + math.cos(heading)}, {y + math.sin(heading)})")
    received = scenario.move_base.goals if tool == "goal-tool" else scenario.move_base.initial_poses
    page.click(f"#{tool}")
    before = len(received)
    page.mouse.move(*start)
    page.mouse.down()
    page.mouse.move(*end, steps=5)
    page.mouse.up()
    scenario.wait_for(lambda: len(received) > before, what=f"the pose of the {tool}")
    message = received[-1]
    pose = message.pose if tool == "goal-tool" else message.pose.pose
    assert message.header.frame_id == "odom"
    pixel_m = 1.0 / SCALE
    assert pose.position.x == pytest.approx(x, abs=pixel_m)
    assert pose.position.y == pytest.approx(y, abs=pixel_m)
    assert yaw_of(pose.orientation) == pytest.approx(heading, abs=2 * pixel_m)
    assert page.locator(f"#{tool}.on").count() == 0  # one pose per click of the tool, as RViz


def test_status_panel_and_screenshot(page, tmp_path):
    show(page, 0.0, -0.5)
    page.wait_for_function("() => document.getElementById('mb-state').textContent.startsWith('ACTIVE')")
    assert page.locator("#link").text_content() == "live"
    assert page.locator("#mb-goal").text_content().startswith("1.50, -1.50")
    ARTIFACTS.mkdir(parents=True, exist_ok=True)
    for path in (tmp_path / "viewer.png", ARTIFACTS / "browser_test.png"):
        page.screenshot(path=str(path))
    assert (tmp_path / "viewer.png").stat().st_size > 10_000
