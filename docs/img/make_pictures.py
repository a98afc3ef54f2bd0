"""Make the README pictures in docs/img: acceptance maps and a screenshot of the rerun viewer.

Run from the repository root (a maintainer's tool, not part of the test suite):

    .venv/bin/python docs/img/make_pictures.py            # maps and screenshots
    .venv/bin/python docs/img/make_pictures.py --maps     # maps only (needs nothing else)

The maps need only xface. The screenshots start the rerun viewer that ships in the
rerun-sdk wheel headless (``rerun --headless``, bound to 127.0.0.1) and drive it with
``rerun.experimental.ViewerClient``; the viewer needs a Vulkan driver, on a machine without a
GPU Mesa's software one (Debian: ``apt-get install mesa-vulkan-drivers``). Without one the
script says so and leaves the screenshots out.
"""

from __future__ import annotations

import argparse
import math
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from xface_core.codes import Outcome
from xface_core.geometry import make_face
from xface_core.maps.acceptance import acceptance_map
from xface_core.predict import predict
from xface_core.result import Phase
from xface_core.viz.mapimage import save_map_png
from xface_core.viz.recording import (
    default_blueprint,
    log_acceptance_map,
    log_prediction,
    new_recording,
)

HERE = Path(__file__).resolve().parent

#: The design of the README pictures: low teeth close to the pivots, so the maps show the
#: reach ("distance") condition as well as the shape of the capture region.
H_OVER_D = 0.25
R_P = 0.25
#: The prediction shown in the viewer screenshot (x0 in D, theta0 in rad).
SHOT_X0 = 0.3
SHOT_THETA0 = 0.35
WINDOW = "1600x900"


def make_maps() -> None:
    for kind in "XVS":
        amap = acceptance_map(make_face(kind, H_OVER_D, R_P))
        picture = save_map_png(amap, HERE / f"map_{kind}.png", scale=8)
        print(f"{picture.path.name}: M = {amap.M}, {picture.size[0]} x {picture.size[1]} px")


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _start_viewer(port: int) -> subprocess.Popen[bytes]:
    rerun = Path(sys.executable).with_name("rerun")
    cmd = [str(rerun), "--headless", "--bind", "127.0.0.1", "--port", str(port)]
    proc = subprocess.Popen(
        [*cmd, "--window-size", WINDOW], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    )
    deadline = time.monotonic() + 60.0
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError("the headless viewer exited (no Vulkan driver?)")
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                return proc
        time.sleep(0.2)
    proc.kill()
    raise RuntimeError("the headless viewer did not start listening")


def make_screenshots() -> None:
    from rerun.experimental import ViewerClient

    design = make_face("X", H_OVER_D, R_P)
    prediction = predict(design, SHOT_X0, SHOT_THETA0)
    assert prediction.path is not None
    # Show the middle of the alignment phase, where contacts and normals are visible.
    aligning = np.flatnonzero(prediction.path.phase == int(Phase.ALIGN))
    sample = int(aligning[len(aligning) // 2]) if aligning.size else len(prediction.path) - 1
    at_descent = float(prediction.path.descent[sample])

    with tempfile.TemporaryDirectory() as tmp:
        prediction_rrd = Path(tmp) / "prediction.rrd"
        rec = new_recording(recording_id="readme-prediction", path=prediction_rrd)
        log_prediction(rec, prediction)
        rec.disconnect()
        map_rrd = Path(tmp) / "map.rrd"
        rec = new_recording(
            application_id="xface-map",
            recording_id="readme-map",
            path=map_rrd,
            blueprint=default_blueprint(active="map"),
        )
        log_acceptance_map(rec, acceptance_map(design))
        rec.disconnect()

        port = _free_port()
        viewer = _start_viewer(port)
        try:
            client = ViewerClient.connect(f"rerun+http://127.0.0.1:{port}/proxy")
            client.open(str(prediction_rrd))
            time.sleep(2.0)
            client.set_time("sim_descent", duration=at_descent, play_state="paused")
            time.sleep(1.0)
            client.save_screenshot(str(HERE / "viewer_prediction.png"))
            client.open(str(map_rrd))
            time.sleep(2.0)
            client.save_screenshot(str(HERE / "viewer_map.png"))
        finally:
            viewer.send_signal(signal.SIGINT)
            try:
                viewer.wait(timeout=20)
            except subprocess.TimeoutExpired:
                viewer.kill()
    print(
        f"viewer_prediction.png: X-Face H/D = {H_OVER_D}, r_p = {R_P}, x0 = {SHOT_X0} D, "
        f"theta0 = {math.degrees(SHOT_THETA0):.1f} deg ({prediction.outcome.name}), "
        f"sample {sample} of {len(prediction.path)}; viewer_map.png"
    )
    if prediction.outcome is not Outcome.SEATED:
        print("note: the screenshot's prediction does not seat", file=sys.stderr)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", action="store_true", help="only the PNG maps")
    args = parser.parse_args()
    make_maps()
    if not args.maps:
        try:
            make_screenshots()
        except RuntimeError as exc:
            print(f"no screenshots: {exc}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
