#!/usr/bin/python3
"""The control panel in a real browser (issue 24): headless Chromium driven through
chromium-driver by Debian's selenium, against a parallaxd on its own simulated display.

Loads the panel from the URL `parallax ctl panel` gives, moves the observer slider and a scene
parameter's slider, presses identify and pause, and checks each effect where it lands: the
daemon's `status` over the control socket, and the viewer preview's picture changing. Then
follows the footer's link to the latest report in the state folder's reports/ (issue 25): its
picture loads through its relative link (the token travels in the path), its inline style
applies, its script does not run.
Screenshots go to OUT (artifacts); the panel's request round-trip times, measured in the
browser, are printed.

usage: panel_browser_test.py --parallaxd PATH --parallax PATH --out DIR
"""

import argparse
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import struct
import time
import zlib

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys


class Failure(Exception):
    pass


def fail(message):
    raise Failure(message)


def ask(sock_path, request, timeout=30.0):
    """One request line on the control socket, its reply (None when the daemon is not there)."""
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
            s.settimeout(timeout)
            s.connect(sock_path)
            s.sendall((json.dumps(request) + "\n").encode())
            data = b""
            while not data.endswith(b"\n"):
                chunk = s.recv(65536)
                if not chunk:
                    break
                data += chunk
        return json.loads(data)
    except (OSError, ValueError):
        return None


def wait_for(what, predicate, seconds=30.0):
    deadline = time.monotonic() + seconds
    last = None
    while time.monotonic() < deadline:
        last = predicate()
        if last:
            return last
        time.sleep(0.05)
    fail("timed out waiting for " + what)


def preview_digest(driver, with_red=False):
    """SHA-256 of the pixels the preview shows now (read back in the page through a canvas: the
    page's Content-Security-Policy lets nothing fetch its blob URLs); with_red, also the share of
    clearly red pixels (cornell's red wall)."""
    deadline = time.monotonic() + 10.0
    while True:
        result = read_preview(driver)
        if result or time.monotonic() > deadline:
            break
        time.sleep(0.05)  # a newer picture replaced the one being read: read that one
    if not result:
        fail("the preview has no picture")
    if (result["width"], result["height"]) != (640, 360):
        fail(f"the preview is {result['width']}x{result['height']}, not the 640x360 view asked for")
    return result["sha"] if not with_red else (result["sha"], result["red"])


def read_preview(driver):
    return driver.execute_async_script(
        """
        const done = arguments[arguments.length - 1];
        const img = document.getElementById('preview');
        // The panel may be swapping in a newer picture: read the one it is loading, once decoded.
        img.decode().then(() => {
          const canvas = document.createElement('canvas');
          canvas.width = img.naturalWidth;
          canvas.height = img.naturalHeight;
          if (!canvas.width) { done(null); return; }
          const g = canvas.getContext('2d');
          g.drawImage(img, 0, 0);
          const pixels = g.getImageData(0, 0, canvas.width, canvas.height).data;
          // Cornell's red wall: pixels clearly more red than green and blue.
          let red = 0;
          for (let i = 0; i < pixels.length; i += 4)
            if (pixels[i] > pixels[i + 1] + 40 && pixels[i] > pixels[i + 2] + 40) ++red;
          crypto.subtle.digest('SHA-256', pixels).then(d => done({
            sha: Array.from(new Uint8Array(d)).map(b => b.toString(16).padStart(2, '0')).join(''),
            red: red / (canvas.width * canvas.height),
            width: canvas.width, height: canvas.height}));
        }, () => done(null));
        """)


def loads(driver):
    return int(driver.find_element(By.ID, "preview").get_attribute("data-loads"))


def round_trips(driver, script_body, runs):
    """Milliseconds of `runs` sequential fetches in the page (after one warm-up)."""
    return driver.execute_async_script(
        """
        const done = arguments[arguments.length - 1];
        const runs = arguments[0];
        const token = new URLSearchParams(location.search).get('token');
        const one = async () => { %s };
        (async () => {
          await one();
          const ms = [];
          for (let i = 0; i < runs; ++i) {
            const t = performance.now();
            await one();
            ms.push(performance.now() - t);
          }
          done(ms);
        })();
        """ % script_body, runs)


def png(width, height, rgb):
    """A solid-colour PNG, written by hand (no imaging module in the test's Python)."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    rows = b"".join(b"\0" + bytes(rgb) * width for _ in range(height))
    return (b"\x89PNG\r\n\x1a\n" +
            chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def write_report(folder):
    """A report folder as `parallax report --out` leaves one: report.html, a picture beside it."""
    os.makedirs(folder)
    with open(os.path.join(folder, "plot.png"), "wb") as f:
        f.write(png(4, 3, (200, 30, 30)))
    with open(os.path.join(folder, "report.html"), "w") as f:
        f.write("""<!DOCTYPE html>
<html xmlns="http://www.w3.org/1999/xhtml"><head><meta charset="utf-8"/>
<title>Parallax: error against run time</title><style>body{background:rgb(1,2,3)}</style></head>
<body><img id="plot" src="plot.png" alt="plot"/>
<script>document.title = "a script ran";</script></body></html>
""")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--parallaxd", required=True)
    parser.add_argument("--parallax", required=True)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()

    out = os.path.abspath(args.out)
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    work = os.path.join(out, "daemon")
    os.makedirs(os.path.join(work, "run"))
    config = os.path.join(work, "parallax.toml")
    with open(config, "w") as f:
        f.write(f"""[display]
preset = "demo"
modules = 8
resolution = [160, 120]
[hardware]
kind = "sim"
[calibration]
auto = false
file = "{work}/state/calibration.json"
[scene]
script = "cornell"
[daemon]
cache_dir = "{work}/cache"
[panel]
port = 0
""")
    write_report(os.path.join(work, "state", "reports", "2026-12-03-quick"))
    env = dict(os.environ, XDG_RUNTIME_DIR=os.path.join(work, "run"))
    sock = os.path.join(work, "run", "parallax", "parallaxd.sock")
    log = open(os.path.join(out, "parallaxd.log"), "w")
    daemon = subprocess.Popen([args.parallaxd, "--config", config], env=env, stderr=log)
    driver = None
    failed = False
    try:
        status = wait_for("the daemon to play",
                          lambda: (lambda s: s if s and s.get("state") == "playing" else None)(
                              ask(sock, {"request": "status"})), 60)
        # The URL as an installer gets it.
        url = subprocess.run([args.parallax, "ctl", "--socket", sock, "panel"], env=env,
                             capture_output=True, text=True, check=True).stdout.strip()
        if not url.startswith("http://127.0.0.1:") or "token=" not in url:
            fail("parallax ctl panel printed " + repr(url))
        token_file = os.path.join(work, "state", "panel.token")
        if oct(os.stat(token_file).st_mode & 0o777) != "0o600":
            fail("the token file is not 0600")
        with open(token_file) as f:
            if f.read().strip() != url.split("token=")[1]:
                fail("the URL's token is not the state folder's")

        options = webdriver.ChromeOptions()
        for flag in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                     "--window-size=1280,1400", "--user-data-dir=" + os.path.join(work, "chrome")):
            options.add_argument(flag)
        options.binary_location = "/usr/bin/chromium"
        driver = webdriver.Chrome(service=Service("/usr/bin/chromedriver"), options=options)
        driver.set_script_timeout(60)
        driver.get(url)
        wait_for("the panel to show the state",
                 lambda: driver.find_element(By.ID, "state").text.startswith("playing"))
        wait_for("the first preview", lambda: loads(driver) >= 1)
        wait_for("the parameter slider", lambda: driver.find_elements(By.ID, "param-depth"))
        wait_for("the charts' first line", lambda: driver.find_element(By.ID, "v-fps").text)
        driver.save_screenshot(os.path.join(out, "1_panel_playing.png"))
        first = preview_digest(driver)

        # The observer slider: 30 steps of 0.01 m to the right; the preview follows.
        slider = driver.find_element(By.ID, "observer")
        before = loads(driver)
        slider.send_keys(*([Keys.ARROW_RIGHT] * 30))
        x = float(slider.get_attribute("value"))
        if abs(x - 0.30) > 1e-9:
            fail(f"the observer slider is at {x}, not 0.30")
        wait_for("the preview at x = 0.30", lambda: loads(driver) > before and
                 abs(float(driver.find_element(By.ID, "preview").get_attribute("data-x")) - x) < 1e-9)
        moved = preview_digest(driver)
        if moved == first:
            fail("the preview did not change when the viewer moved")
        driver.save_screenshot(os.path.join(out, "2_viewer_moved.png"))

        # A parameter slider (cornell's depth): each step is a `set`, seen in the daemon's status.
        depth = driver.find_element(By.ID, "param-depth")
        start = status["scene"]["parameters"]["depth"]
        depth.send_keys(*([Keys.ARROW_LEFT] * 10))
        wanted = float(depth.get_attribute("value"))
        if not wanted < start - 0.05:
            fail(f"the depth slider did not move ({start} -> {wanted})")
        wait_for("depth in the daemon's status",
                 lambda: abs(ask(sock, {"request": "status"})["scene"]["parameters"]["depth"] -
                             wanted) < 1e-9)
        # The scene changed: once it is rendered again, the preview shows it.
        wait_for("the preview of the new depth",
                          lambda: (lambda d: d if d != moved else None)(preview_digest(driver)))

        # Identify: every module shows its number (status says so), and the viewer sees it.
        if preview_digest(driver, with_red=True)[1] < 0.01:
            fail("the preview shows no red wall before identify")
        driver.find_element(By.ID, "btn-identify").click()
        wait_for("identify in status",
                 lambda: ask(sock, {"request": "status"}).get("showing") == "identify")
        # White numbers on black: cornell's red wall is gone from what the viewer sees.
        wait_for("the preview of the modules' numbers",
                 lambda: preview_digest(driver, with_red=True)[1] == 0.0)
        wait_for("the panel to show identify",
                 lambda: "identify" in driver.find_element(By.ID, "state").text)
        time.sleep(1.0)  # the thumbnails refresh after the action
        driver.save_screenshot(os.path.join(out, "3_identify.png"))

        # Pause.
        driver.find_element(By.ID, "btn-pause").click()
        wait_for("paused in status",
                 lambda: ask(sock, {"request": "status"}).get("state") == "paused")
        wait_for("the panel to show paused",
                 lambda: driver.find_element(By.ID, "state").text.startswith("paused"))
        driver.save_screenshot(os.path.join(out, "4_paused.png"))

        # Round trips from the page, as the panel makes them.
        status_ms = round_trips(driver, """
            const r = await fetch('api/request', {method: 'POST', headers: {
              'Content-Type': 'application/json', 'X-Parallax-Token': token},
              body: JSON.stringify({request: 'status'})});
            await r.json();""", 50)
        view_ms = round_trips(driver, """
            const r = await fetch('api/view.png?x=0.1&width=640&height=360',
                                  {headers: {'X-Parallax-Token': token}});
            await r.blob();""", 10)
        socket_ms = []
        for _ in range(50):
            t = time.perf_counter()
            ask(sock, {"request": "status"})
            socket_ms.append((time.perf_counter() - t) * 1000)
        timing = {
            "status_via_panel_ms": {"median": statistics.median(status_ms), "max": max(status_ms)},
            "view_640x360_via_panel_ms": {"median": statistics.median(view_ms), "max": max(view_ms)},
            "status_via_socket_ms": {"median": statistics.median(socket_ms), "max": max(socket_ms)},
            "load_average": os.getloadavg(),
        }
        with open(os.path.join(out, "round_trips.json"), "w") as f:
            json.dump(timing, f, indent=2)
        print("round trips:", json.dumps(timing))
        browser_log = driver.get_log("browser")
        errors = [e for e in browser_log if e.get("level") == "SEVERE"]
        if errors:
            fail("the page logged errors: " + json.dumps(errors))

        # The latest report, from the footer's link, as a reader opens it.
        wait_for("the footer's report link", lambda: driver.find_elements(By.ID, "report-link"))
        link = driver.find_element(By.ID, "report-link")
        if not link.text.startswith("2026-12-03-quick ("):
            fail("the report link reads " + repr(link.text))
        driver.get(link.get_attribute("href"))
        wait_for("the report's picture",
                 lambda: driver.execute_script(
                     "const i = document.getElementById('plot');"
                     "return i && i.complete && i.naturalWidth === 4;"), 10)
        if driver.title != "Parallax: error against run time":
            fail("a script in the report ran (title " + repr(driver.title) + ")")
        if driver.execute_script(
                "return getComputedStyle(document.body).backgroundColor") != "rgb(1, 2, 3)":
            fail("the report's inline style did not apply")
        driver.save_screenshot(os.path.join(out, "5_report.png"))
        driver.get_log("browser")  # the refused script's CSP message, expected
        print("screenshots in", out)
    except Failure as e:
        print("FAILED: " + str(e), file=sys.stderr)
        if driver is not None:
            # What the page showed and said, for the failure's artifacts.
            driver.save_screenshot(os.path.join(out, "failure.png"))
            print("page log:", json.dumps(driver.get_log("browser"), indent=1), file=sys.stderr)
            print("preview:", driver.find_element(By.ID, "preview-time").text, file=sys.stderr)
            print("reply:", driver.find_element(By.ID, "reply").text, file=sys.stderr)
        failed = True
    finally:
        if driver is not None:
            driver.quit()
        ask(sock, {"request": "shutdown"})
        try:
            daemon.wait(20)
        except subprocess.TimeoutExpired:
            daemon.kill()
            daemon.wait()
        log.close()
    if failed:
        sys.exit(1)
    print("panel browser test: passed")


if __name__ == "__main__":
    main()
