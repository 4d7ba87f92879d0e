"""The picture of docs/viewer.md: ``incandescent view`` of the fire demo in headless Chromium,
turned by a drag, a pixel probed, as the page shows it.

    python scripts/viewer_screenshot.py --out docs       # docs/viewer.png
"""

from __future__ import annotations

import argparse
import io
import tempfile
from pathlib import Path

from PIL import Image

from incandescent import api, viewer
from incandescent.cli.flags import command_line
from incandescent.io.atomic import atomic_write
from incandescent.viewer import browser

#: The demo, its grid, the viewer's image and the browser window (CSS pixels).
DEMO, SIZE, IMAGE, WINDOW = "fire", 96, (400, 460), (780, 1010)


def screenshot(out: Path) -> Path:
    """The viewer of the ``DEMO`` volume after a drag and a probe, as a palette PNG."""
    from selenium.webdriver import ActionChains

    with tempfile.TemporaryDirectory(prefix="viewer-shot-") as folder:
        path = api.save_volume(api.demo_volume(DEMO, SIZE), Path(folder) / "fire.npz")
        base = {"render": {"width": IMAGE[0], "height": IMAGE[1]}}
        server = viewer.serve(str(path), base, command_line=command_line).start()
        driver = browser.headless_chromium(*WINDOW)
        try:
            driver.get(server.url)
            browser.final_after(driver, 0, 120)
            image = driver.find_element("id", "view")
            count = driver.execute_script("return viewer.finals;")
            ActionChains(driver).move_to_element(image).click_and_hold().move_by_offset(-50, 8)\
                .release().perform()  # fmt: skip
            browser.final_after(driver, count, 120)
            driver.execute_script("viewer.probeAt(arguments[0], arguments[1]);",
                                  IMAGE[0] // 2, IMAGE[1] // 2)  # fmt: skip
            browser.wait_for(driver, "viewer.probe", 60)
            shot = Image.open(io.BytesIO(driver.get_screenshot_as_png())).convert("RGB")
        finally:
            driver.quit()
            server.stop()
    small = shot.quantize(colors=128, method=Image.Quantize.MEDIANCUT)
    return atomic_write(out / "viewer.png", lambda tmp: small.save(tmp, "PNG", optimize=True),
                        overwrite=True)  # fmt: skip


def main(argv: list[str] | None = None) -> list[Path]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("docs"))
    written = [screenshot(parser.parse_args(argv).out)]
    for path in written:
        print(f"wrote {path}")
    return written


if __name__ == "__main__":
    main()
