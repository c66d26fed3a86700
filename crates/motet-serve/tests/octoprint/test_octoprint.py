"""OctoPrint from PyPI prints a small G-code file on `motet serve --marlin
pty`: it connects over the pseudo-terminal, the file is uploaded and
printed through OctoPrint's REST API, and the machine's path, polled while
it runs, must lie within half a step of the file's path and end where
`motet run` of the same file ends; the temperatures the file set are the
heaters' targets."""

import http.client
import json
import os
import shutil
import socket
import subprocess
import tempfile
import time
import urllib.request
import sys
import uuid

# The motet server, its poller and the reference run are the grbl tests'.
sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
from grbl_common import ROOT, Poller, Server, distance_to_polyline, reference

MACHINE = os.path.join(ROOT, "examples", "printer.toml")
# X and Y: 20-tooth GT2 pulley, 200 steps x 16: 80 steps per mm.
HALF_STEP = 0.5 / 80.0
OCTOPRINT = os.environ.get(
    "OCTOPRINT", os.path.join(ROOT, "target", "pyenv-octoprint", "bin", "octoprint")
)


def job():
    """A square spiral with extrusion, between the temperature commands a
    slicer puts around a print (no heating wait: the test stays short)."""
    pts = [(20.0, 20.0)]
    lines = ["M104 S205", "M140 S55", "G21", "G90", "M82", "G92 E0", "G0 X20 Y20 Z0.2 F6000"]
    e = 0.0
    x, y = 20.0, 20.0
    for k in range(12):
        d = 4.0 + 2.0 * k
        x, y = (x + d, y) if k % 4 == 0 else (x, y + d) if k % 4 == 1 else (x - d, y) if k % 4 == 2 else (x, y - d)
        e += d * 0.03
        lines.append(f"G1 X{x:.3f} Y{y:.3f} E{e:.4f} F4800")
        pts.append((x, y))
    lines += ["G0 X5 Y5", "M104 S0"]
    pts.append((5.0, 5.0))
    return "\n".join(lines) + "\n", pts


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class OctoPrint:
    """`octoprint serve` in a fresh folder, its global API key set, the
    pty offered as a serial port, no wizard, no online checks."""

    def __init__(self, pty):
        self.dir = tempfile.mkdtemp(prefix="motet-octoprint-")
        self.key = uuid.uuid4().hex.upper()
        self.port = free_port()
        with open(os.path.join(self.dir, "config.yaml"), "w") as f:
            json.dump(
                {
                    "api": {"key": self.key},
                    "server": {
                        "firstRun": False,
                        "onlineCheck": {"enabled": False},
                        "pluginBlacklist": {"enabled": False},
                    },
                    "serial": {"additionalPorts": [pty], "autoconnect": False},
                    "plugins": {
                        "tracking": {"enabled": False},
                        "announcements": {"enabled": False},
                        "softwareupdate": {"checks": {}},
                    },
                },
                f,
            )
        self.log = open(os.path.join(self.dir, "stdout.log"), "w")
        self.proc = subprocess.Popen(
            [OCTOPRINT, "serve", "--basedir", self.dir, "--host", "127.0.0.1", "--port", str(self.port)]
            # OctoPrint refuses to start as root unless told (CI containers).
            + (["--iknowwhatimdoing"] if os.geteuid() == 0 else []),
            stdout=self.log,
            stderr=subprocess.STDOUT,
        )
        self.url = f"http://127.0.0.1:{self.port}"
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            try:
                self.get("/api/version")
                return
            except (OSError, http.client.HTTPException):
                # Not listening yet, or answering before its routes are up.
                time.sleep(0.2)
        self.close()
        raise RuntimeError("octoprint did not answer")

    def request(self, method, path, body=None, headers=None):
        req = urllib.request.Request(self.url + path, data=body, method=method)
        req.add_header("X-Api-Key", self.key)
        for k, v in (headers or {}).items():
            req.add_header(k, v)
        with urllib.request.urlopen(req, timeout=10) as r:
            data = r.read()
            return json.loads(data) if data else None

    def get(self, path):
        return self.request("GET", path)

    def post_json(self, path, obj):
        return self.request("POST", path, json.dumps(obj).encode(), {"Content-Type": "application/json"})

    def upload_and_print(self, name, text):
        boundary = uuid.uuid4().hex
        parts = [
            f'--{boundary}\r\nContent-Disposition: form-data; name="file"; filename="{name}"\r\n'
            "Content-Type: application/octet-stream\r\n\r\n" + text + "\r\n",
            f'--{boundary}\r\nContent-Disposition: form-data; name="print"\r\n\r\ntrue\r\n',
            f"--{boundary}--\r\n",
        ]
        return self.request(
            "POST",
            "/api/files/local",
            "".join(parts).encode(),
            {"Content-Type": f"multipart/form-data; boundary={boundary}"},
        )

    def close(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=15)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.log.close()

    def dump_log(self):
        for name in ("stdout.log", os.path.join("logs", "serial.log"), os.path.join("logs", "octoprint.log")):
            p = os.path.join(self.dir, name)
            if os.path.exists(p):
                with open(p) as f:
                    print(f"== {name}\n" + f.read()[-6000:])


def wait_for(what, pred, seconds):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        v = pred()
        if v:
            return v
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


def test_octoprint_prints_a_file_along_the_path_of_motet_run():
    text, pts = job()
    path = os.path.join(tempfile.mkdtemp(), "spiral.gcode")
    with open(path, "w") as f:
        f.write(text)
    ref = reference(MACHINE, path)
    t0 = time.monotonic()
    with Server(MACHINE, device="marlin") as srv:
        octo = OctoPrint(srv.pty)
        try:
            octo.post_json("/api/connection", {"command": "connect", "port": srv.pty, "baudrate": 115200})
            wait_for(
                "OctoPrint operational",
                lambda: octo.get("/api/connection")["current"]["state"] == "Operational",
                30,
            )
            connected = time.monotonic()
            with Poller(srv) as poll:
                octo.upload_and_print("spiral.gcode", text)
                wait_for("the print to start", lambda: octo.get("/api/job")["state"] != "Operational", 10)
                wait_for("the print to end", lambda: octo.get("/api/job")["state"] == "Operational", 60)
                wait_for("the machine at rest", lambda: srv.get("/api/status")["state"] == "idle", 10)
            printed = time.monotonic()
            job_info = octo.get("/api/job")
            temps = wait_for(
                "the temperatures reported",
                # The file's last line switches the hot end off; auto reports
                # (M155) bring it to OctoPrint within a couple of seconds.
                lambda: (lambda t: t if t["tool0"]["target"] == 0 and t["bed"]["target"] == 55 else None)(
                    octo.get("/api/printer").get("temperature", {})
                ),
                10,
            )
            status = srv.get("/api/status")
        except BaseException:
            octo.dump_log()
            raise
        finally:
            octo.close()
    assert job_info["progress"]["completion"] == 100.0, job_info
    assert status["state"] == "idle", status
    # The file's last move and temperatures: as motet run ends, to the step.
    steps = {a["name"]: a for a in ref["actuators"]}
    for i, motor in enumerate(("x_motor", "y_motor", "z_motor", "e_motor")):
        got = round(status["position"][i] * abs(steps[motor]["steps_per_unit"]))
        want = abs(steps[motor]["position"])
        assert got == want, (motor, got, want)
    # The bed heats toward its target; the hot end, off again, cools.
    assert 25.0 < temps["bed"]["actual"] < 55.0, temps
    moving = [p for s, p, _ in poll.samples if s == "running"]
    assert len(moving) > 50, "the poll saw the machine move"
    start = [(0.0, 0.0)] + pts
    worst = max(distance_to_polyline(p[:2], start) for p in moving)
    assert worst <= HALF_STEP, f"{worst} mm off the file's path"
    print(
        f"OctoPrint connect {connected - t0:.1f} s, print {printed - connected:.1f} s; "
        f"samples {len(moving)}; worst distance {worst:.6f} mm"
    )
