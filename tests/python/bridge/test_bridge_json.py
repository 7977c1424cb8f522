"""A Python eclipse-zenoh client reads cellsar's JSON control messages.

Starts a real `cellsar-bridge` (peer on a free loopback port, no multicast, isolated
iceoryx2 root) and, with the Python `eclipse-zenoh` package of the same version as the Rust
crate (1.10.2):

- subscribes to the bridge's JSON stats message `cellsar/bridge/<instance>/stats`;
- queries the same key;
- finds the bridge's liveliness token `cellsar/alive/bridge/<instance>` and sees it go
  away when the bridge stops on SIGTERM.

Run:  CELLSAR_BRIDGE_BIN=target/debug/cellsar-bridge python -m pytest bridge/tests/python
 (or python -m unittest discover bridge/tests/python). Needs: pip install eclipse-zenoh==1.10.2
"""

import json
import os
import pathlib
import signal
import socket
import subprocess
import tempfile
import threading
import time
import unittest

import zenoh

REPO = pathlib.Path(__file__).resolve().parents[3]
BRIDGE = os.environ.get("CELLSAR_BRIDGE_BIN", str(REPO / "target" / "debug" / "cellsar-bridge"))
INSTANCE = "py%d" % os.getpid()
TIMEOUT_S = 15.0


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


def check_envelope(test, msg):
    test.assertEqual(msg["kind"], 0x1001)
    test.assertEqual(msg["kind_name"], "bridge.stats")
    test.assertEqual(msg["schema_version"], 1)
    test.assertEqual(len(msg["mission_id"]), 16)
    test.assertIsInstance(msg["seq"], int)
    test.assertGreater(msg["time_unix_ns"], 1_600_000_000 * 10**9)
    body = msg["body"]
    test.assertEqual(body["instance"], INSTANCE)
    test.assertEqual(len(body["routes"]), 1)
    route = body["routes"][0]
    test.assertEqual(route["service"], "cellsar/test/python")
    test.assertEqual(route["key"], "cellsar/test/python")
    for side in ("to_zenoh", "from_zenoh"):
        test.assertEqual(route[side]["malformed"], 0)


class BridgeJsonTest(unittest.TestCase):
    def setUp(self):
        self.assertTrue(os.path.exists(BRIDGE), "build it first: cargo build -p bridge (%s)" % BRIDGE)
        self.tmp = tempfile.TemporaryDirectory()
        self.port = free_port()
        self.prefix = "cpy%d_" % os.getpid()
        self.stderr = open(os.path.join(self.tmp.name, "bridge.err"), "w")
        self.bridge = subprocess.Popen(
            [BRIDGE, "--instance", INSTANCE, "--service", "cellsar/test/python",
             "--max-frame-bytes", "65536", "--stats-interval-s", "0.3",
             "--iox-root", os.path.join(self.tmp.name, "iox"), "--iox-prefix", self.prefix,
             "--no-multicast-scouting", "-l", "tcp/127.0.0.1:%d" % self.port],
            stdout=subprocess.DEVNULL, stderr=self.stderr)
        conf = zenoh.Config()
        conf.insert_json5("mode", '"peer"')
        conf.insert_json5("connect/endpoints", json.dumps(["tcp/127.0.0.1:%d" % self.port]))
        conf.insert_json5("listen/endpoints", json.dumps(["tcp/127.0.0.1:0"]))
        conf.insert_json5("scouting/multicast/enabled", "false")
        self.session = zenoh.open(conf)

    def tearDown(self):
        self.session.close()
        if self.bridge.poll() is None:
            self.bridge.kill()
        self.bridge.wait(timeout=10)
        self.stderr.close()
        for f in os.listdir("/dev/shm"):
            if f.startswith(self.prefix):
                os.remove(os.path.join("/dev/shm", f))
        self.tmp.cleanup()

    def test_reads_json_stats_query_and_liveliness(self):
        key = "cellsar/bridge/%s/stats" % INSTANCE
        got = []
        lock = threading.Lock()

        def on_sample(sample):
            with lock:
                got.append((str(sample.encoding), sample.payload.to_bytes()))

        sub = self.session.declare_subscriber(key, on_sample)
        wait_for(lambda: got, "a published stats message")
        with lock:
            encoding, payload = got[0]
        self.assertTrue(encoding.startswith("application/json"), encoding)
        self.assertIn("bridge.stats", encoding)
        check_envelope(self, json.loads(payload))
        sub.undeclare()

        replies = list(self.session.get(key, timeout=5.0))
        self.assertGreaterEqual(len(replies), 1)
        sample = replies[0].ok
        self.assertIsNotNone(sample, "error reply")
        self.assertTrue(str(sample.encoding).startswith("application/json"))
        check_envelope(self, json.loads(sample.payload.to_bytes()))

        alive_key = "cellsar/alive/bridge/%s" % INSTANCE

        def alive():
            rs = self.session.liveliness().get("cellsar/alive/bridge/*", timeout=1.0)
            return alive_key in [str(r.ok.key_expr) for r in rs if r.ok is not None]

        wait_for(alive, "the bridge's liveliness token")
        self.bridge.send_signal(signal.SIGTERM)
        self.assertEqual(self.bridge.wait(timeout=10), 0)
        wait_for(lambda: not alive(), "the liveliness token to go away")


if __name__ == "__main__":
    unittest.main()
