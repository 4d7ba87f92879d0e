"""``incandescent view`` in a real headless Chromium (Debian's, driven by Selenium through the
system chromedriver): the page shows our render, orbits, exposes, scrubs time and probes, and
every image it shows is the one ``incandescent render`` writes for the view it reports."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _viewer_fixtures import (
    HEIGHT,
    WIDTH,
    blob,
    camera_flags,
    decode_png,
    render_png,
    run_render,
    serve,
)

from incandescent.io.images import read_exr
from incandescent.viewer import browser

pytestmark = pytest.mark.skipif(browser.missing() is not None, reason=str(browser.missing()))
#: The longest a page waits for a frame, s (the first render compiles the kernels).
WAIT_S = 60.0


@pytest.fixture(scope="module")
def chromium():
    driver = browser.headless_chromium()
    yield driver
    driver.quit()


@pytest.fixture(scope="module")
def inputs(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("viewer")
    blob(folder / "blob.npz")
    for i, peak in enumerate((1400.0, 1800.0, 2300.0)):
        blob(folder / f"fire_{i:04d}.npz", peak, squash=0.6 + 0.3 * i)
    return folder


@pytest.fixture(scope="module")
def server(inputs):
    served = serve(inputs / "blob.npz")
    yield served
    served.stop()


def wait_for(driver, script: str):
    return browser.wait_for(driver, script, WAIT_S)


def final_after(driver, count: int) -> dict:
    return browser.final_after(driver, count, WAIT_S)


def shown(driver) -> np.ndarray:
    """The pixels of the image the page shows."""
    return decode_png(driver.execute_script("return document.getElementById('view').src;"))


def changed(a: np.ndarray, b: np.ndarray) -> float:
    """The fraction of pixels whose value changed by more than 20 of 255."""
    return float((np.abs(a.astype(int) - b).max(axis=2) > 20).mean())


def finals(driver) -> int:
    return driver.execute_script("return viewer.finals;")


def set_control(driver, element_id: str, value) -> None:
    """Set a control as a user does (input while moving, change when let go)."""
    driver.execute_script(
        "const el = document.getElementById(arguments[0]); el.value = arguments[1];"
        "el.dispatchEvent(new Event('input')); el.dispatchEvent(new Event('change'));",
        element_id, value,
    )  # fmt: skip


@pytest.fixture(scope="module")
def page(chromium, server):
    chromium.get(server.url)
    final_after(chromium, 0)
    return chromium


def test_the_page_shows_our_render_of_the_volume(page, inputs, tmp_path):
    frame = page.execute_script("return viewer.lastFinal;")
    pixels = shown(page)
    assert pixels.shape == (HEIGHT, WIDTH, 3) and (frame["width"], frame["height"]) == (
        WIDTH,
        HEIGHT,
    )
    assert pixels.max() > 150 and (pixels.sum(axis=2) > 30).mean() > 0.05  # non-black, a fire
    reference = render_png(inputs / "blob.npz", tmp_path / "ref.png")
    np.testing.assert_array_equal(pixels, reference)


def test_dragging_orbits_and_shows_render_of_the_reported_camera(page, inputs, tmp_path):
    from selenium.webdriver import ActionChains

    before, count = shown(page), finals(page)
    eye_before = page.execute_script("return viewer.lastFinal.camera.eye;")
    image = page.find_element("id", "view")
    ActionChains(page).move_to_element(image).click_and_hold().move_by_offset(60, 0)\
        .move_by_offset(60, 10).release().perform()  # fmt: skip
    frame = final_after(page, count)
    after = shown(page)
    assert changed(after, before) > 0.02  # the view turned
    camera = frame["camera"]
    assert camera["eye"] != eye_before and camera["target"] == [0.0, 0.0, 0.0]
    reference = render_png(inputs / "blob.npz", tmp_path / "orbit.png", *camera_flags(camera))
    assert np.abs(after.astype(int) - reference).max() <= 1  # within rounding


def srgb_to_linear(pixels: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1's inverse OETF of 8-bit code values."""
    v = pixels.astype(np.float64) / 255.0
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def test_the_exposure_slider_scales_brightness_by_two_per_stop(page):
    set_control(page, "tonemap", "clip")
    final_after(page, finals(page) - 1)
    count = finals(page)
    dim = srgb_to_linear(shown(page))
    set_control(page, "exposure", "1")
    final_after(page, count)
    bright = srgb_to_linear(shown(page))
    usable = (dim > 0.02) & (bright < 0.9)  # lit and not clipped at either exposure
    assert usable.sum() > 100
    ratio = bright[usable].sum() / dim[usable].sum()
    assert ratio == pytest.approx(2.0, rel=0.02)  # +1 EV: twice the linear value
    set_control(page, "exposure", "0")
    set_control(page, "tonemap", "filmic")
    final_after(page, count + 1)


def test_the_probe_reports_the_render_s_pixel(page, tmp_path):
    frame = page.execute_script("return viewer.lastFinal;")
    column, row = WIDTH // 2, HEIGHT // 2
    page.execute_script("viewer.probe = null; viewer.probeAt(arguments[0], arguments[1]);",
                        column, row)  # fmt: skip
    probe = wait_for(page, "viewer.probe")
    exr = run_render(frame["command"], tmp_path / "probe.exr")
    rgb, _, extra = read_exr(exr)
    assert probe["rgb"] == pytest.approx(rgb[row, column].tolist(), rel=1e-6)
    assert probe["transmittance"] == pytest.approx(1.0 - extra["A"][row, column], abs=1e-6)
    assert probe["luminance_cd_m2"] > 0 and 0.0 < probe["transmittance"] < 1.0
    assert "luminance" in page.find_element("id", "probe").text


def test_copy_command_reproduces_the_view_bit_for_bit(page, tmp_path):
    command = page.find_element("id", "command").get_attribute("value")
    assert command.startswith("incandescent render ") and "--eye" in command
    out = run_render(command, tmp_path / "copied.png")
    np.testing.assert_array_equal(decode_png(out.read_bytes()), shown(page))


def test_a_page_without_the_token_is_refused(chromium, server):
    chromium.get(server.url.split("?")[0])
    assert "a token is required" in chromium.find_element("tag name", "body").text
    chromium.get(server.url.replace("token=", "token=x"))
    assert "a token is required" in chromium.find_element("tag name", "body").text


def test_the_time_slider_shows_the_chosen_frame(chromium, inputs, tmp_path):
    browser = chromium
    served = serve(inputs / "fire_####.npz")
    try:
        browser.get(served.url)
        final_after(browser, 0)
        first = shown(browser)
        assert browser.find_element("id", "time").is_displayed()
        count = finals(browser)
        set_control(browser, "frame", "2")
        frame = final_after(browser, count)
        assert frame["frame"] == 2
        assert browser.find_element("id", "frame-name").text == "fire_0002.npz"
        last = shown(browser)
        assert "fire_0002.npz" in frame["command"]
        reference = render_png(inputs / "fire_0002.npz", tmp_path / "f2.png")
        np.testing.assert_array_equal(last, reference)
        assert changed(last, first) > 0.02  # another frame than the first
    finally:
        served.stop()
