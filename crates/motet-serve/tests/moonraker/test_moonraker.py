"""Moonraker from PyPI connects to `motet serve --klipper-api`, reports the
printer ready, prints an uploaded file (`printer.print.start`) and reports
its progress over its websocket; the machine's path, polled from motet's
own HTTP API while it prints, must lie within half a step of the file's
path, and it must end where `motet run` of the same file ends."""

import asyncio
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
import uuid

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "python"))
from grbl_common import MOTET, ROOT, Poller, distance_to_polyline, reference  # noqa: E402

from tornado.websocket import websocket_connect  # Moonraker's own dependency

MACHINE = os.path.join(ROOT, "examples", "printer.toml")
# The printer's X and Y: 80 steps per mm. Half a step:
HALF_STEP = 0.5 / 80.0


def job():
    """Straight moves with extrusion: a few layers of a small square wave."""
    pts = [(20.0, 20.0)]
    lines = ["G21 G90 M83", "G0 X20 Y20 Z0.3 F6000", "G1 F3000"]
    for k in range(24):
        x = 20.0 + 2.5 * (k + 1)
        y = 20.0 + (12.0 if k % 2 else 0.0) + 0.4 * k
        lines.append(f"G1 X{x:.3f} Y{y:.3f} E0.12")
        pts.append((x, y))
    lines.append("G0 X10 Y10")
    pts.append((10.0, 10.0))
    return "\n".join(lines) + "\n", pts


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Motet:
    """`motet serve MACHINE --klipper-api SOCK`, stopped on exit."""

    def __init__(self, tmp, gcodes):
        self.sock = os.path.join(tmp, "klippy.sock")
        self.proc = subprocess.Popen(
            [MOTET, "serve", MACHINE, "--listen", "127.0.0.1:0", "--dir", os.path.join(tmp, "serve"),
             "--klipper-api", self.sock, "--klipper-gcodes", gcodes],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.url = None
        deadline = time.monotonic() + 30
        while self.url is None and time.monotonic() < deadline:
            line = self.proc.stdout.readline()
            if not line:
                break
            if " at http://" in line:
                self.url = line.split(" at ", 1)[1].strip().rstrip("/")
        assert self.url, "motet serve printed no address"
        while self.get("/api/status")["connecting"] and time.monotonic() < deadline:
            time.sleep(0.05)

    def get(self, path):
        with urllib.request.urlopen(self.url + path, timeout=5) as r:
            return json.loads(r.read())

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()


class Moonraker:
    """Moonraker on a free port, its data under `data`, talking to `sock`."""

    def __init__(self, tmp, data, sock):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        conf = os.path.join(tmp, "moonraker.conf")
        with open(conf, "w") as f:
            f.write(f"""[server]
host: 127.0.0.1
port: {self.port}
klippy_uds_address: {sock}

[machine]
provider: none
validate_service: False

[authorization]
trusted_clients:
    127.0.0.0/8

[file_manager]
""")
        self.log = open(os.path.join(tmp, "moonraker.log"), "w")
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "moonraker", "-d", data, "-c", conf, "-n"],
            stdout=self.log, stderr=subprocess.STDOUT)

    def get(self, path):
        with urllib.request.urlopen(self.url + path, timeout=5) as r:
            return json.loads(r.read())["result"]

    def post(self, path, body=b"", headers=None):
        req = urllib.request.Request(self.url + path, data=body, method="POST", headers=headers or {})
        with urllib.request.urlopen(req, timeout=10) as r:
            body = json.loads(r.read())
            # An upload's answer is the file's record itself.
            return body.get("result", body)

    def wait_ready(self, timeout=60):
        deadline = time.monotonic() + timeout
        info = None
        while time.monotonic() < deadline:
            try:
                info = self.get("/server/info")
                if info.get("klippy_state") == "ready":
                    return info
            except OSError:
                pass
            time.sleep(0.1)
        raise AssertionError(f"Moonraker never reported klippy ready: {info}")

    def upload(self, name, text):
        b = uuid.uuid4().hex
        body = (f"--{b}\r\nContent-Disposition: form-data; name=\"file\"; filename=\"{name}\"\r\n"
                f"Content-Type: application/octet-stream\r\n\r\n{text}\r\n--{b}--\r\n").encode()
        return self.post("/server/files/upload", body, {"Content-Type": f"multipart/form-data; boundary={b}"})

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.log.close()


async def watch_print(mr, name, timeout=60):
    """Subscribes over the websocket, starts the print, and collects the
    print_stats / virtual_sdcard updates until the print is complete."""
    ws = await websocket_connect(f"ws://127.0.0.1:{mr.port}/websocket")
    seen = {"states": [], "progress": []}

    async def call(method, params, rid):
        await ws.write_message(json.dumps({"jsonrpc": "2.0", "method": method, "params": params, "id": rid}))
        while True:
            m = json.loads(await ws.read_message())
            if m.get("id") == rid:
                assert "result" in m, m
                return m["result"]
            note(m)

    def note(m):
        if m.get("method") != "notify_status_update":
            return
        st = m["params"][0]
        if "state" in st.get("print_stats", {}):
            seen["states"].append(st["print_stats"]["state"])
        if "progress" in st.get("virtual_sdcard", {}):
            seen["progress"].append(st["virtual_sdcard"]["progress"])

    first = await call("printer.objects.subscribe",
                       {"objects": {"print_stats": ["state", "filename"], "virtual_sdcard": ["progress"]}}, 1)
    assert first["status"]["print_stats"]["state"] == "standby", first
    await call("printer.print.start", {"filename": name}, 2)
    deadline = time.monotonic() + timeout
    while "complete" not in seen["states"]:
        left = deadline - time.monotonic()
        assert left > 0, f"no complete state over the websocket: {seen}"
        note(json.loads(await asyncio.wait_for(ws.read_message(), left)))
    ws.close()
    return seen


def test_moonraker_prints_a_file_on_the_path_of_motet_run():
    text, pts = job()
    tmp = tempfile.mkdtemp(prefix="motet-moonraker-")
    data = os.path.join(tmp, "data")
    gcodes = os.path.join(data, "gcodes")
    os.makedirs(gcodes)
    ref_file = os.path.join(tmp, "square.gcode")
    with open(ref_file, "w") as f:
        f.write(text)
    ref = reference(MACHINE, ref_file)
    srv = Motet(tmp, gcodes)
    t0 = time.monotonic()
    mr = Moonraker(tmp, data, srv.sock)
    try:
        info = mr.wait_ready()
        ready_s = time.monotonic() - t0
        assert info["klippy_connected"] is True
        mr.upload("square.gcode", text)
        assert os.path.exists(os.path.join(gcodes, "square.gcode"))
        with Poller(srv) as poll:
            seen = asyncio.run(watch_print(mr, "square.gcode"))
            # The machine rests once the print is complete.
            status = srv.get("/api/status")
        hist = mr.get("/server/history/list?limit=1")
    finally:
        mr.stop()
        srv.stop()
    assert "printing" in seen["states"] and seen["states"][-1] == "complete", seen
    assert seen["progress"] and seen["progress"][-1] == 1.0, seen
    assert seen["progress"] == sorted(seen["progress"]), "progress never goes back"
    assert hist["jobs"][0]["filename"] == "square.gcode" and hist["jobs"][0]["status"] == "completed", hist
    assert status["state"] == "idle"
    # Where motet run ends, to the step, on every motor (E included).
    for a in ref["actuators"]:
        i = ["x_motor", "y_motor", "z_motor", "e_motor"].index(a["name"])
        # The report counts steps along the axis: an inverted motor (E)
        # has a negative steps_per_unit and a positive position.
        got = round(status["position"][i] * abs(a["steps_per_unit"]))
        assert got == a["position"], (a["name"], got, a["position"])
    moving = [p for s, p, _ in poll.samples if s == "running"]
    assert len(moving) > 20, "the poll saw the machine move"
    path = [(0.0, 0.0)] + pts  # from the machine's start, then the file
    worst = max(distance_to_polyline(p, path) for p in moving)
    assert worst <= HALF_STEP, f"{worst} mm off the file's path"
    print(f"Moonraker ready {ready_s:.1f} s after start; updates: {len(seen['progress'])} progress, "
          f"states {seen['states']}; samples {len(moving)}; worst distance {worst:.6f} mm")
