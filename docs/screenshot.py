"""Make the README's pictures: the viewer during a navigation run and the plot of its recording.

    python docs/screenshot.py [--goal X Y YAW_DEG] [--after SECONDS] [--rtf FACTOR] [--out docs]

Starts `navigation --viewer --record`, sets a 2D Nav Goal by click and drag in a
headless Chromium (as a user would), takes the screenshot once the robot has been
driving for --after seconds, stops the launch and plots the recorded run.
"""

from __future__ import annotations

import argparse
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from playwright.sync_api import sync_playwright

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--goal", nargs=3, type=float, default=(8.0, 4.5, 90.0), metavar=("X", "Y", "YAW_DEG"))
    parser.add_argument("--after", type=float, default=25.0, help="seconds of driving before the screenshot")
    parser.add_argument("--rtf", default="1.0", help="real-time factor (below 1 on a busy machine)")
    parser.add_argument("--port", type=int, default=8765)
    parser.add_argument("--out", default=str(Path(__file__).resolve().parent))
    opts = parser.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("screenshot: no chromium on PATH (apt-get install chromium)", file=sys.stderr)
        return 2
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE="LOCALHOST")
    env.setdefault("ROS_DOMAIN_ID", "100")  # outside the 10..99 the test suites pick, so no other run joins
    out = Path(opts.out)
    recording = Path(tempfile.mkdtemp(prefix="simplebot_screenshot_")) / "run.mcap"
    launch = subprocess.Popen([sys.executable, "-m", "simplebot_navigation.launch", "navigation", "--viewer",
                               "--rtf", opts.rtf, "--record", str(recording)], env=env, start_new_session=True)
    try:
        with sync_playwright() as playwright:
            browser = playwright.chromium.launch(executable_path=chromium, args=CHROMIUM_ARGS)
            page = browser.new_page(viewport={"width": 1400, "height": 860})
            deadline = time.monotonic() + 60
            while True:
                try:
                    page.goto(f"http://127.0.0.1:{opts.port}/")
                    break
                except Exception:  # noqa: BLE001 - the server is not up yet
                    if time.monotonic() > deadline:
                        raise
                    time.sleep(1.0)
            page.wait_for_function("() => window.viewer.state.grids.global_costmap && window.viewer.state.grids"
                                   ".local_costmap && window.viewer.state.frame.robot", timeout=60000)
            x, y, yaw = opts.goal[0], opts.goal[1], math.radians(opts.goal[2])
            page.evaluate(f"() => window.viewer.setView({x / 2}, {y / 2}, 42)")
            start = page.evaluate(f"() => window.viewer.worldToPage({x}, {y})")
            end = page.evaluate(f"() => window.viewer.worldToPage({x + math.cos(yaw)}, {y + math.sin(yaw)})")
            page.click("#goal-tool")
            page.mouse.move(*start)
            page.mouse.down()
            page.mouse.move(*end, steps=5)
            page.mouse.up()
            time.sleep(opts.after)
            page.screenshot(path=str(out / "viewer.png"))
            browser.close()
    finally:
        os.killpg(launch.pid, signal.SIGINT)
        launch.wait(timeout=30)
    subprocess.run([sys.executable, "-m", "simplebot_navigation.launch.record", "--plot", str(recording),
                    str(out / "run.png")], check=True)
    print(f"wrote {out / 'viewer.png'} and {out / 'run.png'} (recording {recording})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
