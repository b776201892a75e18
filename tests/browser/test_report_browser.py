"""report.html in a real browser (issue 23): headless Chromium (Debian's chromium and
chromium-driver, driven by python3-selenium) opens a report of each kind (surface map,
volume map, ball) and the demo's index from file://, waits for the 3D views to draw, and
checks that the views are not blank, that they answer to the mouse and the cut slider, that
the console has no error, and that every number in the metrics table equals report.json.

Run by CTest (tests/browser/CMakeLists.txt via the top-level CMakeLists); skipped with a
message when chromium, chromedriver or selenium is missing (scripts/install-deps installs
them). Environment: SHAPEMAP_BINARY (the tool), SHAPEMAP_BROWSER_KEEP=1 keeps the outputs.
"""
import json
import math
import os
import shutil
import subprocess
import tempfile
import time

import pytest

BINARY = os.environ.get("SHAPEMAP_BINARY", "")
CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"

try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.by import By
    HAVE_SELENIUM = True
except ImportError:  # pragma: no cover
    HAVE_SELENIUM = False


def _missing():
    if not HAVE_SELENIUM:
        return "python3-selenium is not installed (scripts/install-deps)"
    for exe in (CHROMIUM, CHROMEDRIVER):
        if not os.access(exe, os.X_OK):
            return exe + " is not installed (scripts/install-deps: chromium chromium-driver)"
    if not os.access(BINARY, os.X_OK):
        return "SHAPEMAP_BINARY is not set to the shapemap tool"
    return None


pytestmark = pytest.mark.skipif(_missing() is not None, reason=str(_missing()))


def shapemap(*args):
    subprocess.run([BINARY, "-q", "--threads", "1", *args], check=True)


def read_obj(path):
    V, F = [], []
    with open(path) as f:
        for line in f:
            p = line.split()
            if p and p[0] == "v":
                V.append([float(x) for x in p[1:4]])
            elif p and p[0] == "f":
                F.append([int(x.split("/")[0]) - 1 for x in p[1:4]])
    return V, F


def read_map_points(path, V, F):
    pts = []
    with open(path) as f:
        for line in f:
            p = line.split()
            if not p or p[0].startswith("#") or p[0] == "shapemap-map":
                continue
            e, b = int(p[0]), [float(x) for x in p[1:4]]
            pts.append([sum(b[j] * V[F[e][j]][d] for j in range(3)) for d in range(3)])
    return pts


@pytest.fixture(scope="module")
def outputs():
    """Small inputs and one output folder per kind, laid out as the demo's folders."""
    root = tempfile.mkdtemp(prefix="shapemap_browser_")
    P, D = os.path.join(root, "pair"), os.path.join(root, "demo")
    shapemap("generate", "--shape", "pair", "--kind", "near-isometric", "--vertices", "500", "--seed", "2",
             "--tets", "--tet-count", "1000", "-o", P)
    # Landmarks: three vertices of A and their true images on B (as points).
    VA, _ = read_obj(P + "/A.obj")
    VB, FB = read_obj(P + "/B.obj")
    truth = read_map_points(P + "/truth_AB.txt", VB, FB)
    ids = [0, len(VA) // 3, 2 * len(VA) // 3]
    with open(root + "/LA.txt", "w") as f:
        f.write("".join("%d\n" % i for i in ids))
    with open(root + "/LB.txt", "w") as f:
        f.write("".join("%.17g %.17g %.17g\n" % tuple(truth[i]) for i in ids))
    fast_bim = ["--samples", "64", "--candidates", "20", "--features", "6"]
    shapemap("surface-map", P + "/A.obj", P + "/B.obj", "-o", D + "/bim", "--method", "bim", "--symmetric",
             "--landmarks", root + "/LA.txt", root + "/LB.txt", "--truth", P + "/truth_AB.txt", *fast_bim)
    shapemap("volume-map", P + "/A.vtk", P + "/B.vtk", "-o", D + "/volume", "--max-iterations", "2",
             "--surface-map", D + "/bim/map_AB.txt", D + "/bim/map_BA.txt",
             "--surface-map-meshes", P + "/A.obj", P + "/B.obj")
    shapemap("ball", P + "/A.vtk", "-o", D + "/ball", "--max-iterations", "30")
    shapemap("demo", "-o", D, "--index-only")
    yield D
    if not os.environ.get("SHAPEMAP_BROWSER_KEEP"):
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture(scope="module")
def browser():
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    # WebGL without a GPU: ANGLE on SwiftShader (CPU).
    for a in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--use-angle=swiftshader",
              "--enable-unsafe-swiftshader", "--window-size=1400,1000"):
        opts.add_argument(a)
    opts.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    d = webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)
    yield d
    d.quit()


def wait_drawn(d, timeout=30):
    t0 = time.time()
    while time.time() - t0 < timeout:
        s = d.execute_script("return window.SHAPEMAP_VIEWER_STATUS || ''")
        if s:
            assert s == "drawn", s
            return
        time.sleep(0.05)
    raise AssertionError("the 3D views did not draw within %d s" % timeout)


# Per view (left, right half of the canvas): the share of pixels that differ from the white
# background and the number of distinct colours. Needs preserveDrawingBuffer (the viewer
# sets it) to read the WebGL canvas after it was drawn.
PIXELS_JS = """
const c = document.getElementById('viewer-canvas');
const t = document.createElement('canvas'); t.width = c.width; t.height = c.height;
const x = t.getContext('2d'); x.drawImage(c, 0, 0);
const d = x.getImageData(0, 0, c.width, c.height).data;
const out = [];
for (const [a, b] of [[0, c.width >> 1], [c.width >> 1, c.width]]) {
  let ink = 0, n = 0; const colours = new Set();
  for (let y = 0; y < c.height; y += 2) for (let i = a; i < b; i += 2) {
    const k = 4 * (y * c.width + i); ++n;
    if (d[k] < 245 || d[k + 1] < 245 || d[k + 2] < 245) { ++ink; colours.add(d[k] >> 3 << 10 | d[k + 1] >> 3 << 5 | d[k + 2] >> 3); }
  }
  out.push([ink / n, colours.size]);
}
return out;
"""


def views_drawn(d):
    halves = d.execute_script(PIXELS_JS)
    for ink, colours in halves:
        assert ink > 0.02, halves  # a shape covers a part of each view
        assert colours > 20, halves  # shaded and coloured, not a flat fill
    return halves


def canvas_signature(d):
    return d.execute_script("return document.getElementById('viewer-canvas').toDataURL().length")


def console_errors(d):
    return [e for e in d.get_log("browser") if e["level"] == "SEVERE"]


def check_table(d, report):
    """Every cell with data-ptr shows the value at that JSON pointer of report.json."""
    cells = d.execute_script(
        "return Array.from(document.querySelectorAll('td[data-ptr]')).map(e => [e.dataset.ptr, e.textContent])")
    assert len(cells) > 10
    for ptr, text in cells:
        v = report
        for tok in ptr.split("/")[1:]:
            tok = tok.replace("~1", "/").replace("~0", "~")
            v = v[int(tok)] if isinstance(v, list) else v[tok]
        if isinstance(v, bool):
            assert text == ("true" if v else "false"), ptr
        elif isinstance(v, (int, float)):
            shown = float(text)
            assert math.isclose(shown, v, rel_tol=1e-5, abs_tol=1e-300), (ptr, text, v)
        elif isinstance(v, str):
            assert text == v, ptr
        elif v is None:
            assert text == "null", ptr
        else:
            assert isinstance(v, list), ptr
    return dict(cells)


def open_report(d, folder):
    d.get_log("browser")  # drop earlier messages
    d.get("file://" + folder + "/report.html")
    wait_drawn(d)
    with open(folder + "/report.json") as f:
        return json.load(f)


def drag(d, dx):
    c = d.find_element(By.ID, "viewer-canvas")
    before = canvas_signature(d)
    frames = d.execute_script("return window.SHAPEMAP_VIEWER_FRAMES")
    ActionChains(d).move_to_element(c).click_and_hold().move_by_offset(dx, 10).release().perform()
    t0 = time.time()
    while d.execute_script("return window.SHAPEMAP_VIEWER_FRAMES") == frames and time.time() - t0 < 5:
        time.sleep(0.05)
    assert canvas_signature(d) != before  # both views turned: the picture changed


def test_surface_map_report(browser, outputs):
    r = open_report(browser, outputs + "/bim")
    views_drawn(browser)
    cells = check_table(browser, r)
    assert "/metrics/AB/conformal_distortion_mean" in cells
    assert "/timings/total" in cells
    # Landmarks are numbered on both views (titles + 2 x 3 numbers).
    labels = browser.execute_script(
        "return Array.from(document.querySelectorAll('#views div')).filter(e => /^[0-9]+$/.test(e.textContent)"
        " && e.style.display !== 'none').length")
    assert labels == 6
    drag(browser, 120)
    # A coloured by its error against the ground truth (--truth).
    browser.execute_script("const s = document.querySelectorAll('#views select')[1]; s.value = 'e';"
                           "s.dispatchEvent(new Event('change'));")
    time.sleep(0.3)
    views_drawn(browser)
    assert "geodesic error" in browser.find_element(By.ID, "views").text
    # The other direction (map_BA) draws as well.
    browser.execute_script("const s = document.querySelector('#views select'); s.value = 'BA';"
                           "s.dispatchEvent(new Event('change'));")
    time.sleep(0.3)
    views_drawn(browser)
    assert console_errors(browser) == []


def test_volume_map_report(browser, outputs):
    r = open_report(browser, outputs + "/volume")
    views_drawn(browser)
    cells = check_table(browser, r)
    assert "/metrics/AB/n_inv" in cells
    # Moving the cutting plane redraws both views with other tets.
    before = canvas_signature(browser)
    browser.execute_script("const s = document.getElementById('viewer-cut'); s.value = 250;"
                           "s.dispatchEvent(new Event('input'));")
    time.sleep(0.3)
    views_drawn(browser)
    assert canvas_signature(browser) != before
    drag(browser, -100)
    assert console_errors(browser) == []


def test_ball_report(browser, outputs):
    r = open_report(browser, outputs + "/ball")
    views_drawn(browser)
    cells = check_table(browser, r)
    assert "/metrics/D_V/mean" in cells
    assert console_errors(browser) == []


def test_demo_index_shows_every_stage(browser, outputs):
    browser.get_log("browser")
    browser.get("file://" + outputs + "/index.html")
    frames = browser.find_elements(By.TAG_NAME, "iframe")
    assert len(frames) == 3  # bim, volume, ball (the stages this test ran)
    for fr in frames:
        browser.execute_script("arguments[0].scrollIntoView()", fr)
        browser.switch_to.frame(fr)
        try:
            wait_drawn(browser)
            views_drawn(browser)
            assert len(browser.find_elements(By.CSS_SELECTOR, "td[data-ptr]")) > 10
        finally:
            browser.switch_to.default_content()
    assert "ball" in browser.find_element(By.ID, "summary").text
    assert console_errors(browser) == []


def test_missing_three_js_is_said_not_thrown(browser, outputs, tmp_path):
    """Without three.min.js (libjs-three absent) the page says why, and the PNGs stay."""
    dst = tmp_path / "ball"
    shutil.copytree(outputs + "/ball", dst)
    (dst / "three.min.js").unlink()
    browser.get_log("browser")
    browser.get("file://" + str(dst) + "/report.html")
    wait = time.time()
    while not browser.execute_script("return window.SHAPEMAP_VIEWER_STATUS") and time.time() - wait < 10:
        time.sleep(0.05)
    assert "three.min.js is missing" in browser.execute_script("return window.SHAPEMAP_VIEWER_STATUS")
    assert browser.find_elements(By.CSS_SELECTOR, "img[src^='data:image/png']")
