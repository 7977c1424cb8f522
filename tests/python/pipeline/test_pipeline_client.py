"""A Python eclipse-zenoh client runs a mission through the cellsar services.

Starts the real services (`cellsar planner`, `cellsar echo`, `cellsar process`: the same code
as `cellsar-planner serve`, `cellsar-radar-sim echo`, `cellsar-radar-sim process-service`),
each a Zenoh peer connected to this client (free loopback port, no multicast, isolated
iceoryx2 root). Then, with nothing but `eclipse-zenoh` and JSON:

- waits for their liveliness tokens `cellsar/alive/<role>/<instance>`;
- asks `cellsar/plan` for a plan with a JSON request (a mission as in a mission file) and
  reads the JSON reply; a refused request gets a typed error reply, the JSON envelope of a
  `bridge.refusal` (kind 0x1002) whose body says why (`bad_request` naming the field,
  `infeasible` naming the slot, or `internal`);
- reads the plan summary `cellsar/<mission>/plan/summary`, every aperture's detections
  `cellsar/<mission>/detections` and the services' status `cellsar/<mission>/status/<role>`
  as JSON, once it has asked `cellsar/<mission>/results` for them (a JSON result request:
  the processor takes on only the missions a client asks results of);
- runs the Python example of pipeline/README.md ("The services on their own") as a script
  against the same services: it plans, prints the detections and exits (a session left
  open with a callback subscriber would keep the interpreter from exiting: zenoh-python
  issue #434, so every session here is closed, the example's by its `with` block).

Run:  cargo build -p pipeline && python3 -m pytest pipeline/tests/python
      (CELLSAR_BIN overrides target/debug/cellsar). Needs: pip install eclipse-zenoh==1.10.2
"""

import json
import os
import pathlib
import re
import socket
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import zenoh

REPO = pathlib.Path(__file__).resolve().parents[3]
CELLSAR = os.environ.get("CELLSAR_BIN", str(REPO / "target" / "debug" / "cellsar"))
SCENE = str(REPO / "tests" / "data" / "small-scene.toml")
TIMEOUT_S = 120.0

MISSION = {
    "name": "python client",
    "params": {"horizon_s": 20.0},
    "landmarks": {
        "points": [
            {"x_m": 0.0, "y_m": 0.0, "from_s": 0.0, "to_s": 10.0},
            {"x_m": 0.0, "y_m": 30.0, "from_s": 10.0, "to_s": 20.0},
        ]
    },
}


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def wait_for(cond, what, timeout_s=TIMEOUT_S):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        v = cond()
        if v:
            return v
        time.sleep(0.05)
    raise AssertionError("timed out waiting for " + what)


# each message kind's schema version (protocol's SCHEMA_VERSION): a plan request is at 2
SCHEMA_VERSIONS = {0x0101: 2}


def envelope(kind, body):
    return json.dumps({"kind": kind, "schema_version": SCHEMA_VERSIONS.get(kind, 1),
                       "mission_id": "0000000000000000", "seq": 0, "time_unix_ns": 0,
                       "body": body})


class PipelineClientTest(unittest.TestCase):
    def setUp(self):
        self.assertTrue(os.path.exists(CELLSAR), "build it first: cargo build -p pipeline (%s)" % CELLSAR)
        self.tmp = tempfile.TemporaryDirectory()
        self.port = free_port()
        self.prefix = "cpp%d_" % os.getpid()
        hub = "tcp/127.0.0.1:%d" % self.port
        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("listen/endpoints", json.dumps([hub]))
        conf.insert_json5("scouting/multicast/enabled", "false")
        self.session = zenoh.open(conf)
        # closed however the test ends (setUp failing after this line included): an open
        # session with callback subscribers keeps the interpreter from exiting (issue #434)
        self.addCleanup(self.session.close)
        common = ["--no-multicast-scouting", "-l", "tcp/127.0.0.1:0", "-e", hub]
        iox = ["--iox-root", os.path.join(self.tmp.name, "iox"), "--iox-prefix", self.prefix]
        self.procs = []
        for role, args in [
            ("planner", ["planner"]),
            ("echo", ["echo", "--scene", SCENE] + iox),
            ("processor", ["process", "--scene", SCENE, "--resend-after-s", "2"] + iox),
        ]:
            log = open(os.path.join(self.tmp.name, role + ".log"), "w")
            self.procs.append((role, log, subprocess.Popen([CELLSAR] + args + common,
                                                           stdout=log, stderr=log)))

    def tearDown(self):
        for _, log, p in self.procs:
            if p.poll() is None:
                p.terminate()
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
            log.close()
        for f in os.listdir("/dev/shm"):
            if f.startswith(self.prefix):
                os.remove(os.path.join("/dev/shm", f))
        self.tmp.cleanup()

    def alive(self):
        rs = self.session.liveliness().get("cellsar/alive/**", timeout=1.0)
        return {str(r.ok.key_expr) for r in rs if r.ok is not None}

    def test_mission_over_json(self):
        for key in ("cellsar/alive/planner/planner", "cellsar/alive/echo/echo",
                    "cellsar/alive/processor/processor"):
            wait_for(lambda: key in self.alive(), key)

        lock = threading.Lock()
        detections, summaries, statuses = {}, [], {}

        def on_detections(sample):
            self.assertTrue(str(sample.encoding).startswith("application/json"))
            msg = json.loads(sample.payload.to_bytes())
            with lock:
                detections[msg["body"]["aperture"]] = msg

        def on_summary(sample):
            with lock:
                summaries.append(json.loads(sample.payload.to_bytes()))

        def on_status(sample):
            msg = json.loads(sample.payload.to_bytes())
            with lock:
                statuses[msg["body"]["role"]] = msg["body"]

        subs = [self.session.declare_subscriber("cellsar/*/detections", on_detections),
                self.session.declare_subscriber("cellsar/*/plan/summary", on_summary),
                self.session.declare_subscriber("cellsar/*/status/*", on_status)]

        # a bad mission, and one that cannot be flown: typed refusals (JSON bridge.refusal)
        bad = dict(MISSION, params={"horizon_s": 20.0, "altitude_m": -1.0})
        far = {"name": "unreachable", "params": {"horizon_s": 20.0, "start_m": [-1000.0, 0.0]},
               "landmarks": {"points": [
                   {"x_m": 0.0, "y_m": 0.0, "from_s": 0.0, "to_s": 10.0},
                   {"x_m": 50000.0, "y_m": 0.0, "from_s": 10.0, "to_s": 20.0}]}}
        for mission, kind, needle in ((bad, "bad_request", "altitude_m"), (far, "infeasible", "slot")):
            replies = list(self.session.get("cellsar/plan", payload=envelope(0x0101, {"mission": mission}),
                                            encoding="application/json;cellsar/planner.plan_request/v2",
                                            timeout=60.0))
            self.assertEqual(len(replies), 1)
            self.assertIsNone(replies[0].ok)
            err = replies[0].err
            self.assertTrue(str(err.encoding).startswith("application/json"), str(err.encoding))
            refusal = json.loads(err.payload.to_bytes())
            self.assertEqual(refusal["kind"], 0x1002)
            self.assertEqual(refusal["kind_name"], "bridge.refusal")
            self.assertEqual(refusal["schema_version"], 1)
            self.assertEqual(refusal["body"]["kind"], kind, refusal)
            self.assertIn(needle, refusal["body"]["message"])

        # the plan, as JSON
        replies = list(self.session.get("cellsar/plan", payload=envelope(0x0101, {"mission": MISSION}),
                                        encoding="application/json;cellsar/planner.plan_request/v2",
                                        timeout=TIMEOUT_S))
        self.assertEqual(len(replies), 1)
        sample = replies[0].ok
        self.assertIsNotNone(sample, replies[0].err and replies[0].err.payload.to_string())
        self.assertTrue(str(sample.encoding).startswith("application/json"), str(sample.encoding))
        plan = json.loads(sample.payload.to_bytes())
        self.assertEqual(plan["kind_name"], "planner.plan")
        body = plan["body"]
        mission_id = body["mission_id"]
        self.assertEqual(len(mission_id), 16)
        self.assertEqual(body["mission"]["name"], "python client")
        self.assertEqual(len(body["result"]["trajectory"]["pos_m"]), 40)  # 20 s of 0.5-s slots
        self.assertTrue(body["summary"]["feasible"])

        # the results, asked for: the processor takes the mission on (its plan looked up)
        ask = envelope(0x0307, {"mission_id": mission_id, "apertures": [], "metrics": False})
        acks = list(self.session.get("cellsar/%s/results" % mission_id, payload=ask,
                                     encoding="application/json;cellsar/radar.result_request/v1",
                                     timeout=30.0))
        self.assertEqual(len(acks), 1)
        self.assertIsNotNone(acks[0].ok, acks[0].err and acks[0].err.payload.to_string())
        wait_for(lambda: len(detections) == 2, "the detections of both apertures")
        with lock:
            for ap, msg in detections.items():
                self.assertEqual(msg["kind_name"], "radar.aperture_detections")
                self.assertEqual(msg["body"]["mission_id"], mission_id)
                self.assertEqual(msg["body"]["apertures"], 2)
            # each landmark is detected at its place
            for ap, y in ((0, 0.0), (1, 30.0)):
                d = detections[ap]["body"]
                self.assertTrue(d["landmark_detected"])
                best = max(d["detections"], key=lambda r: r["snr_db"])
                self.assertLess(abs(best["x_m"]) + abs(best["y_m"] - y), 1.0, best)
            self.assertEqual(summaries[0]["body"]["mission_id"], mission_id)
        wait_for(lambda: statuses.get("processor", {}).get("state") == "done", "the processor's status 'done'")
        with lock:
            self.assertEqual(statuses["processor"]["done"], 2)
            # a healthy run decodes everything it receives (frames lost in transport,
            # "transport_lost", are allowed: a loaded machine's full iceoryx2 buffer, asked
            # for again)
            c = statuses["processor"]["counters"]
            self.assertEqual(c["malformed"], 0, c)
        # the echo service publishes its status periodically (not on each frame): wait for one
        # that counts every frame of the 20-s mission, rather than read whichever came last
        wait_for(lambda: statuses.get("echo", {}).get("counters", {}).get("frames", 0) >= 20,
                 "the echo service's status counting >= 20 frames")
        with lock:
            self.assertEqual(statuses["echo"]["counters"]["malformed"], 0)
        for s in subs:
            s.undeclare()

    def test_readme_example_runs_and_exits(self):
        readme = (REPO / "pipeline" / "README.md").read_text()
        blocks = re.findall(r"```python\n(.*?)```", readme, re.S)
        self.assertEqual(len(blocks), 1, "one Python example in pipeline/README.md")
        code = blocks[0]
        # the example's session, connected to this test's services instead of scouting
        conf = {"mode": "peer", "connect": {"endpoints": ["tcp/127.0.0.1:%d" % self.port]},
                "listen": {"endpoints": ["tcp/127.0.0.1:0"]},
                "scouting": {"multicast": {"enabled": False}}}
        default = "zenoh.open(zenoh.Config())"
        self.assertEqual(code.count(default), 1, code)
        code = code.replace(default, "zenoh.open(zenoh.Config.from_json5(%r))" % json.dumps(conf))
        for key in ("cellsar/alive/planner/planner", "cellsar/alive/echo/echo",
                    "cellsar/alive/processor/processor"):
            wait_for(lambda: key in self.alive(), key)
        try:
            run = subprocess.run([sys.executable, "-u", "-c", code], capture_output=True, text=True,
                                 timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired as e:
            self.fail("the README example did not exit within %.0f s; stdout:\n%s" % (TIMEOUT_S, e.stdout))
        self.assertEqual(run.returncode, 0, run.stderr)
        self.assertIn("aperture 0 landmark detected: True", run.stdout, run.stderr)


if __name__ == "__main__":
    unittest.main()
