#!/usr/bin/python3
# An independent Sparkplug B host application for the sparkplug driver's tests:
# Debian's mosquitto as the broker, paho-mqtt as the host's client, and the
# payload schema built here from the Sparkplug 3.0 field numbers with
# python3-protobuf (not from the driver's .proto), so a mistake in the driver's
# schema cannot hide here. It starts rtplc runtimes as edge nodes and checks
# their traffic message by message, and mosquitto's own log for what a
# subscriber cannot see (CONNECT flags, the will, SUBSCRIBE before NBIRTH).
#
#   sparkplug_host.py RTPLC_BINARY SOURCE_DIR WORK_DIR [SCENARIO ...]
#
# Exit 0 when every scenario passed, 1 on the first failure (with what was seen),
# 77 when mosquitto or the Python modules are missing (the test is then skipped).
import faulthandler
import json
import os
import queue
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
import traceback

try:
    import paho.mqtt.client as mqtt
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
except ImportError as e:  # pragma: no cover
    print(f"SKIP: {e} (scripts/setup-deps installs python3-paho-mqtt and python3-protobuf)")
    sys.exit(77)
if not shutil.which("mosquitto"):
    print("SKIP: no mosquitto broker (scripts/setup-deps installs it)")
    sys.exit(77)

RTPLC, SRC, WORK = sys.argv[1], sys.argv[2], sys.argv[3]
faulthandler.register(signal.SIGUSR1)  # a hung run: kill -USR1 shows where
ONLY = set(sys.argv[4:])

# ---- the payload schema, from the specification's field numbers ----
F = descriptor_pb2.FieldDescriptorProto


def build_payload_class():
    fdp = descriptor_pb2.FileDescriptorProto(name="host_sparkplug_b.proto", package="host", syntax="proto2")
    payload = fdp.message_type.add(name="Payload")

    def add(msg, name, number, ftype, label=F.LABEL_OPTIONAL, type_name=None):
        f = msg.field.add(name=name, number=number, type=ftype, label=label)
        if type_name:
            f.type_name = type_name

    pv = payload.nested_type.add(name="PropertyValue")
    add(pv, "type", 1, F.TYPE_UINT32)
    add(pv, "is_null", 2, F.TYPE_BOOL)
    add(pv, "int_value", 3, F.TYPE_UINT32)
    add(pv, "long_value", 4, F.TYPE_UINT64)
    add(pv, "float_value", 5, F.TYPE_FLOAT)
    add(pv, "double_value", 6, F.TYPE_DOUBLE)
    add(pv, "boolean_value", 7, F.TYPE_BOOL)
    add(pv, "string_value", 8, F.TYPE_STRING)
    ps = payload.nested_type.add(name="PropertySet")
    add(ps, "keys", 1, F.TYPE_STRING, F.LABEL_REPEATED)
    add(ps, "values", 2, F.TYPE_MESSAGE, F.LABEL_REPEATED, ".host.Payload.PropertyValue")
    m = payload.nested_type.add(name="Metric")
    add(m, "name", 1, F.TYPE_STRING)
    add(m, "alias", 2, F.TYPE_UINT64)
    add(m, "timestamp", 3, F.TYPE_UINT64)
    add(m, "datatype", 4, F.TYPE_UINT32)
    add(m, "is_historical", 5, F.TYPE_BOOL)
    add(m, "is_transient", 6, F.TYPE_BOOL)
    add(m, "is_null", 7, F.TYPE_BOOL)
    add(m, "properties", 9, F.TYPE_MESSAGE, type_name=".host.Payload.PropertySet")
    add(m, "int_value", 10, F.TYPE_UINT32)
    add(m, "long_value", 11, F.TYPE_UINT64)
    add(m, "float_value", 12, F.TYPE_FLOAT)
    add(m, "double_value", 13, F.TYPE_DOUBLE)
    add(m, "boolean_value", 14, F.TYPE_BOOL)
    add(m, "string_value", 15, F.TYPE_STRING)
    add(payload, "timestamp", 1, F.TYPE_UINT64)
    add(payload, "metrics", 2, F.TYPE_MESSAGE, F.LABEL_REPEATED, ".host.Payload.Metric")
    add(payload, "seq", 3, F.TYPE_UINT64)
    add(payload, "uuid", 4, F.TYPE_STRING)
    add(payload, "body", 5, F.TYPE_BYTES)
    pool = descriptor_pool.DescriptorPool()
    pool.Add(fdp)
    desc = pool.FindMessageTypeByName("host.Payload")
    factory = message_factory.MessageFactory(pool)
    return factory.GetMessageClass(desc) if hasattr(factory, "GetMessageClass") else factory.GetPrototype(desc)


Payload = build_payload_class()
INT64, UINT64, DOUBLE, BOOLEAN, STRING, INT32 = 4, 8, 10, 11, 12, 3
GOOD, BAD, BAD_STALE = 192, -2147483136, -2147483132


def signed32(u):
    return u - (1 << 32) if u >= (1 << 31) else u


def metric_value(m):
    if m.is_null:
        return None
    if m.datatype == BOOLEAN:
        return m.boolean_value
    if m.datatype == DOUBLE:
        return m.double_value
    if m.datatype == INT64:
        v = m.long_value
        return v - (1 << 64) if v >= (1 << 63) else v
    if m.datatype == UINT64:
        return m.long_value
    if m.datatype == STRING:
        return m.string_value
    return None


def quality(m):
    ps = m.properties
    for k, v in zip(ps.keys, ps.values):
        if k == "Quality":
            assert v.type == INT32, f"Quality property of {m.name} has type {v.type}, not Int32"
            return signed32(v.int_value)
    return None


class Failure(Exception):
    pass


def check(cond, what):
    if not cond:
        raise Failure(what)


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    p = s.getsockname()[1]
    s.close()
    return p


def wait_for(pred, timeout, what, step=0.02):
    end = time.time() + timeout
    while time.time() < end:
        r = pred()
        if r:
            return r
        time.sleep(step)
    raise Failure(f"timed out after {timeout} s waiting for {what}")


# ---- the broker ----
class Broker:
    def __init__(self, name, port=None, bridge_to=None):
        self.port = port or free_port()
        self.dir = os.path.join(WORK, name)
        os.makedirs(self.dir, exist_ok=True)
        self.log = os.path.join(self.dir, "mosquitto.log")
        # Run as root, mosquitto becomes its own user: its log folder must let it write.
        os.chmod(self.dir, 0o777)
        conf = [f"listener {self.port} 127.0.0.1", "allow_anonymous true", f"log_dest file {self.log}",
                "log_type all", "persistence true", f"persistence_location {self.dir}/",
                "queue_qos0_messages true", "max_queued_messages 100000"]
        if bridge_to:
            conf += [f"connection bridge-{name}", f"address 127.0.0.1:{bridge_to}", "topic spBv1.0/# both 1",
                     "cleansession true", "try_private false", "notifications false"]
        with open(os.path.join(self.dir, "mosquitto.conf"), "w") as f:
            f.write("\n".join(conf) + "\n")
        self.proc = None
        self.start()

    def start(self):
        self.proc = subprocess.Popen(["mosquitto", "-c", os.path.join(self.dir, "mosquitto.conf")],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        wait_for(self.listening, 10, f"mosquitto on port {self.port}")

    def listening(self):
        try:
            socket.create_connection(("127.0.0.1", self.port), 0.2).close()
            return True
        except OSError:
            return False

    def stop(self):
        if self.proc and self.proc.poll() is None:
            self.proc.terminate()
            self.proc.wait(10)

    def log_text(self):
        try:
            with open(self.log, errors="replace") as f:
                return f.read()
        except FileNotFoundError:
            return ""


# ---- the host application ----
class Host:
    """Records every Sparkplug message on a broker and checks the per-node rules as they arrive."""

    def __init__(self, broker_port, client_id=None):
        self.msgs = []
        self.lock = threading.Lock()
        self.violations = []
        self.nodes = {}  # (group, node) -> {"seq": last, "bdseq": n, "born": set(devices), "alive": bool}
        # With a client id of its own the session persists (the broker keeps it
        # across a restart and queues what arrives meanwhile).
        self.c = mqtt.Client(client_id=client_id or f"host-{os.getpid()}-{free_port()}",
                             clean_session=client_id is None)
        self.c.on_message = self._on_message
        self.connected = threading.Event()
        self.c.on_connect = lambda c, u, f, rc: self.connected.set()
        self.c.connect("127.0.0.1", broker_port, 30)
        self.c.subscribe("spBv1.0/#", 1)
        self.c.loop_start()
        if not self.connected.wait(10):
            raise Failure("the host cannot connect to the broker")
        time.sleep(0.2)

    def close(self):
        self.c.loop_stop()
        self.c.disconnect()

    def _on_message(self, c, u, m):
        parts = m.topic.split("/")
        rec = {"topic": m.topic, "t": time.time(), "retain": m.retain, "parts": parts}
        if len(parts) >= 4 and parts[2] in ("NCMD", "DCMD"):
            rec["type"] = parts[2]  # commands (ours, some malformed on purpose): not the node's traffic
        elif len(parts) >= 4 and parts[1] != "STATE":
            p = Payload()
            try:
                p.ParseFromString(m.payload)
            except Exception as e:
                self.violations.append(f"{m.topic}: payload does not decode: {e}")
                return
            rec["p"] = p
            rec["type"] = parts[2]
            self._rules(parts, p)
        with self.lock:
            self.msgs.append(rec)

    def _rules(self, parts, p):
        group, mtype, node = parts[1], parts[2], parts[3]
        key = (group, node)
        # A node first seen mid-session (the host joined late) is checked from its next NBIRTH on.
        st = self.nodes.setdefault(key, {"seq": None, "bdseq": None, "born": set(), "alive": False, "known": False})
        bad = self.violations.append
        if mtype == "NDEATH":
            check_ = [m for m in p.metrics if m.name == "bdSeq"]
            if not check_ or check_[0].datatype != INT64:
                bad(f"NDEATH of {node} without an Int64 bdSeq")
            elif st["bdseq"] is not None and metric_value(check_[0]) != st["bdseq"] and st["alive"]:
                bad(f"NDEATH of {node} bdSeq {metric_value(check_[0])} != NBIRTH's {st['bdseq']}")
            if p.HasField("seq"):
                bad(f"NDEATH of {node} carries a seq")
            st["alive"] = False
            st["born"] = set()
            st["seq"] = None
            return
        if not p.HasField("seq"):
            bad(f"{mtype} of {node} without seq")
            return
        if not st["known"] and mtype != "NBIRTH":
            return
        if mtype == "NBIRTH":
            if p.seq != 0:
                bad(f"NBIRTH of {node} with seq {p.seq}")
            names = {m.name: m for m in p.metrics}
            if "bdSeq" not in names or names["bdSeq"].datatype != INT64:
                bad(f"NBIRTH of {node} without Int64 bdSeq")
            if "Node Control/Rebirth" not in names or names["Node Control/Rebirth"].datatype != BOOLEAN:
                bad(f"NBIRTH of {node} without Node Control/Rebirth")
            st["bdseq"] = metric_value(names["bdSeq"]) if "bdSeq" in names else None
            st["seq"] = 0
            st["alive"] = True
            st["known"] = True
            st["born"] = set()
            return
        if not st["alive"]:
            bad(f"{mtype} of {node} before its NBIRTH")
        elif st["seq"] is not None and p.seq != (st["seq"] + 1) % 256:
            bad(f"{mtype} of {node}: seq {p.seq} after {st['seq']}")
        st["seq"] = p.seq
        device = parts[4] if len(parts) > 4 else None
        if mtype == "DBIRTH":
            for m in p.metrics:
                if not m.name or not m.HasField("datatype") or not m.HasField("timestamp") or quality(m) is None:
                    bad(f"DBIRTH {node}/{device}: metric {m.name!r} lacks name, datatype, timestamp or Quality")
            st["born"].add(device)
        elif mtype == "DDATA":
            if device not in st["born"]:
                bad(f"DDATA {node}/{device} before its DBIRTH")
            for m in p.metrics:
                if quality(m) is None:
                    bad(f"DDATA {node}/{device}: metric {m.name or m.alias} without Quality")
        elif mtype == "DDEATH":
            st["born"].discard(device)

    def since(self, mark, pred=lambda r: True):
        with self.lock:
            seen = self.msgs[mark:]
        return [r for r in seen if pred(r)]

    def mark(self):
        with self.lock:
            return len(self.msgs)

    def wait(self, mark, pred, timeout, what):
        return wait_for(lambda: self.since(mark, pred), timeout, what)

    def send(self, topic, payload, retain=False):
        self.c.publish(topic, payload, 1, retain).wait_for_publish(5)

    def assert_clean(self):
        if self.violations:
            with self.lock:
                trail = [f"{r['topic']} seq={r['p'].seq if 'p' in r and r['p'].HasField('seq') else '-'}"
                         for r in self.msgs[-60:]]
            print("last messages:\n  " + "\n  ".join(trail))
        check(not self.violations, "Sparkplug rules broken:\n  " + "\n  ".join(self.violations[:20]))


def command(*metrics, timestamp=None):
    p = Payload()
    p.timestamp = timestamp or int(time.time() * 1000)
    for name, dtype, value in metrics:
        m = p.metrics.add()
        m.name = name
        m.datatype = dtype
        if dtype == DOUBLE:
            m.double_value = value
        elif dtype == BOOLEAN:
            m.boolean_value = value
        elif dtype == INT32:
            m.int_value = value & 0xFFFFFFFF
    return p.SerializeToString()


def is_type(t, node=None, device=None):
    def pred(r):
        if r.get("type") != t:
            return False
        if node and r["parts"][3] != node:
            return False
        return not device or (len(r["parts"]) > 4 and r["parts"][4] == device)
    return pred


def metric(rec, name):
    for m in rec["p"].metrics:
        if m.name == name:
            return m
    return None


# ---- an rtplc runtime as an edge node ----
class Node:
    def __init__(self, name, broker_port, extra="", node_id=None, keepalive="10s"):
        self.name = name
        self.node_id = node_id or name
        self.dir = os.path.join(WORK, name)
        os.makedirs(self.dir, exist_ok=True)
        os.chmod(self.dir, 0o700)  # the runtime's own folder: it refuses one others may enter
        shutil.copy(os.path.join(SRC, "examples", "seed_pid.fbd"), self.dir)
        self.config = os.path.join(self.dir, "node.yaml")
        with open(self.config, "w") as f:
            f.write(f"""runtime:
  name: {name}
  socket: {self.dir}/rt.sock
  retain_file: {self.dir}/retain.txt
tasks:
  - name: loop
    program: seed_pid.fbd
    setpoints: {{Setpoint: {{min: 0, max: 100}}}}
drivers:
  - kind: sim
  - kind: sparkplug
    name: plant
    broker: 127.0.0.1:{broker_port}
    group: Plant1
    node: {self.node_id}
    keepalive: {keepalive}
    writable: [Setpoint]
{extra}""")
        self.proc = None

    def start(self):
        self.out = open(os.path.join(self.dir, "run.log"), "ab")
        self.proc = subprocess.Popen([RTPLC, "run", self.config, "--no-lock"], stdout=self.out, stderr=subprocess.STDOUT)
        return self

    def log(self):
        with open(os.path.join(self.dir, "run.log"), errors="replace") as f:
            return f.read()

    def alive(self):
        return self.proc and self.proc.poll() is None

    def kill9(self):
        self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(10)

    def stop(self):
        if self.alive():
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                raise Failure(f"{self.name} did not stop on SIGTERM within 20 s")


def nbirth_bdseq(rec):
    return metric_value(metric(rec, "bdSeq"))


# ---- the scenarios ----
def scenario_basic(broker, host):
    """Births, data, rebirth (and a burst), refused and accepted DCMDs, bad commands, kill -9, restart."""
    n = Node("spb-basic", broker.port)
    mark = host.mark()
    n.start()
    nb = host.wait(mark, is_type("NBIRTH", n.node_id), 20, "NBIRTH")[0]
    bd0 = nbirth_bdseq(nb)
    db = host.wait(mark, is_type("DBIRTH", n.node_id, "loop"), 10, "DBIRTH of device loop")[0]
    names = {m.name for m in db["p"].metrics}
    check({"ProcVal", "ManiVal", "Setpoint"} <= names, f"DBIRTH metrics {names}")
    check(metric(db, "Setpoint").datatype == DOUBLE and metric_value(metric(db, "Setpoint")) == 50,
          "Setpoint born as Double 50")
    data = host.wait(mark, lambda r: is_type("DDATA", n.node_id, "loop")(r) and metric(r, "ProcVal"), 10,
                     "DDATA with ProcVal")
    check(all(quality(metric(r, "ProcVal")) in (GOOD, BAD, BAD_STALE) for r in data), "Quality codes")

    # mosquitto's view: clean session, the will QoS 1 not retained, SUBSCRIBE before NBIRTH.
    client = f"rtplc-Plant1-{n.node_id}"
    log = wait_for(lambda: (lambda t: t if f"'spBv1.0/Plant1/NBIRTH/{n.node_id}'" in t else None)(broker.log_text()),
                   10, "the NBIRTH in mosquitto's log")
    check(f"as {client} (p5, c1," in log, f"CONNECT of {client} with clean session:\n{log[-2000:]}")
    check("Will message specified" in log and "(r0, q1)" in log, "a will with QoS 1, not retained")
    sub = log.find(f"{client} 1 spBv1.0/Plant1/NCMD/{n.node_id}")
    dsub = log.find(f"{client} 1 spBv1.0/Plant1/DCMD/{n.node_id}/+")
    birth = log.find(f"'spBv1.0/Plant1/NBIRTH/{n.node_id}'")
    check(0 <= sub < birth and 0 <= dsub < birth, "NCMD and DCMD subscribed before the NBIRTH")

    # Rebirth: NBIRTH (seq 0, same bdSeq) and DBIRTH again, on the same connection.
    connects = log.count(f"as {client} ")
    mark = host.mark()
    host.send(f"spBv1.0/Plant1/NCMD/{n.node_id}", command(("Node Control/Rebirth", BOOLEAN, True)))
    rb = host.wait(mark, is_type("NBIRTH", n.node_id), 10, "NBIRTH after a rebirth command")[0]
    check(nbirth_bdseq(rb) == bd0, "a rebirth keeps the bdSeq")
    host.wait(mark, is_type("DBIRTH", n.node_id, "loop"), 10, "DBIRTH after the rebirth")
    # A burst of 30 is coalesced, never a storm of births.
    mark = host.mark()
    for _ in range(30):
        host.c.publish(f"spBv1.0/Plant1/NCMD/{n.node_id}", command(("Node Control/Rebirth", BOOLEAN, True)), 1)
    host.wait(mark, is_type("NBIRTH", n.node_id), 10, "NBIRTH after a rebirth burst")
    time.sleep(1.0)
    births = len(host.since(mark, is_type("NBIRTH", n.node_id)))
    check(1 <= births <= 10, f"a burst of 30 rebirths gave {births} NBIRTHs")
    check(broker.log_text().count(f"as {client} ") == connects, "rebirth without reconnecting")

    def setpoint_seen(mark, value):
        return host.since(mark, lambda r: is_type("DDATA", n.node_id, "loop")(r) and metric(r, "Setpoint")
                          and metric_value(metric(r, "Setpoint")) == value)

    topic = f"spBv1.0/Plant1/DCMD/{n.node_id}/loop"
    # Refused: an output, a value beyond the set-point's limits, garbage, a retained command, an oversized one.
    mark = host.mark()
    host.send(topic, command(("ManiVal", DOUBLE, 5.0)))
    host.send(topic, command(("Setpoint", DOUBLE, 150.0)))
    host.send(topic, b"\x0a\xff\xff\xff\xff\x0f garbage")
    host.send(topic, command(("Setpoint", DOUBLE, 60.0)), retain=True)
    host.send(topic, command(("Setpoint", DOUBLE, 61.0)) + b"\x2a" + b"\x00" * 70000)
    host.send(topic, command(("Setpoint", STRING, 0)))
    wait_for(lambda: n.log().count("refused") >= 6, 10, "six refusals in the runtime's log")
    host.send(topic, b"", retain=True)  # clear the retained command from the broker
    time.sleep(0.5)
    check(not setpoint_seen(mark, 150.0) and not setpoint_seen(mark, 60.0) and not setpoint_seen(mark, 61.0),
          "no refused value reached the set-point")
    check(n.alive(), "the runtime survived the bad commands")
    # Accepted: the set-point changes, as DDATA shows; the operator API audited it.
    mark = host.mark()
    host.send(topic, command(("Setpoint", DOUBLE, 42.0)))
    wait_for(lambda: setpoint_seen(mark, 42.0), 10, "DDATA with Setpoint 42")
    audit = subprocess.run([RTPLC, "audit", "--socket", f"{n.dir}/rt.sock"], capture_output=True, text=True)
    check("Setpoint" in audit.stdout and "sparkplug" in audit.stdout,
          f"the write is in the audit trail:\n{audit.stdout}{audit.stderr}")

    # kill -9: the broker publishes the will, an NDEATH with this session's bdSeq.
    mark = host.mark()
    n.kill9()
    nd = host.wait(mark, is_type("NDEATH", n.node_id), 30, "NDEATH after kill -9")[0]
    check(metric_value(metric(nd, "bdSeq")) == bd0, f"NDEATH bdSeq {metric_value(metric(nd, 'bdSeq'))} != {bd0}")
    # A restart: the next bdSeq, kept on disk.
    mark = host.mark()
    n.start()
    nb = host.wait(mark, is_type("NBIRTH", n.node_id), 20, "NBIRTH after the restart")[0]
    check(nbirth_bdseq(nb) == (bd0 + 1) % 256, f"bdSeq after restart {nbirth_bdseq(nb)}, expected {bd0 + 1}")
    # An orderly stop: DDEATH, then NDEATH before the DISCONNECT.
    mark = host.mark()
    n.stop()
    host.wait(mark, is_type("NDEATH", n.node_id), 10, "NDEATH at an orderly stop")
    check(host.since(mark, is_type("DDEATH", n.node_id, "loop")), "DDEATH of the stopped task")
    host.assert_clean()


def scenario_broker_restart(broker, host):
    """The broker goes away: changes are stored, and after the new births replayed with is_historical."""
    n = Node("spb-restart", broker.port, extra="    store_and_forward: 500\n")
    mark = host.mark()
    n.start()
    nb = host.wait(mark, is_type("NBIRTH", n.node_id), 20, "NBIRTH")[0]
    bd = nbirth_bdseq(nb)
    host.wait(mark, is_type("DDATA", n.node_id), 10, "DDATA")
    # A host with a persistent session: the broker keeps its subscription across
    # its restart, so it sees the node's first messages whoever reconnects first.
    host2 = Host(broker.port, client_id=f"host-persistent-{os.getpid()}")
    host2.close()
    host.close()
    broker.stop()
    time.sleep(2.0)  # the loop keeps changing: the node stores
    broker.start()
    host2 = Host(broker.port, client_id=f"host-persistent-{os.getpid()}")
    mark = 0
    nb = host2.wait(mark, is_type("NBIRTH", n.node_id), 30, "NBIRTH after the broker came back")[0]
    check(nbirth_bdseq(nb) == (bd + 1) % 256, "a new session, a new bdSeq")
    hist = host2.wait(mark, lambda r: is_type("DDATA", n.node_id)(r) and any(m.is_historical for m in r["p"].metrics),
                      15, "replayed DDATA with is_historical")
    first_hist = hist[0]["t"]
    births = host2.since(mark, is_type("DBIRTH", n.node_id))
    check(births and births[0]["t"] <= first_hist, "the replay comes after the DBIRTH")
    stats = subprocess.run([RTPLC, "stats", "--name", n.name], capture_output=True, text=True)
    check("replayed" in stats.stdout and "bdSeq" in stats.stdout and "last error" in stats.stdout,
          f"stats shows the link's figures and its last error:\n{stats.stdout}")
    n.stop()
    host2.assert_clean()
    return host2


def scenario_primary_host(broker, host):
    """Births wait for the primary host's STATE; stale and wrong-host STATEs change nothing; offline ends the session."""
    n = Node("spb-primary", broker.port, extra="    primary_host: scada\n")
    host.send("spBv1.0/STATE/scada", json.dumps({"online": False, "timestamp": 1000}).encode(), retain=True)
    mark = host.mark()
    n.start()
    time.sleep(2.0)
    check(not host.since(mark, is_type("NBIRTH", n.node_id)), "no NBIRTH while the primary host is offline")
    host.send("spBv1.0/STATE/other", json.dumps({"online": True, "timestamp": 5000}).encode(), retain=True)
    time.sleep(1.0)
    check(not host.since(mark, is_type("NBIRTH", n.node_id)), "another host's STATE is not ours")
    host.send("spBv1.0/STATE/other", b"", retain=True)
    host.send("spBv1.0/STATE/scada", json.dumps({"online": True, "timestamp": 2000}).encode(), retain=True)
    nb = host.wait(mark, is_type("NBIRTH", n.node_id), 10, "NBIRTH once the primary host is online")[0]
    bd = nbirth_bdseq(nb)
    # A stale offline (older timestamp) is ignored.
    mark = host.mark()
    host.send("spBv1.0/STATE/scada", json.dumps({"online": False, "timestamp": 1500}).encode(), retain=True)
    time.sleep(1.0)
    check(not host.since(mark, is_type("NDEATH", n.node_id)), "a stale STATE offline is ignored")
    host.send("spBv1.0/STATE/scada", b"not json", retain=False)
    time.sleep(0.3)
    check(n.alive(), "a malformed STATE changes nothing")
    # The host goes offline: NDEATH, a new session that waits.
    mark = host.mark()
    host.send("spBv1.0/STATE/scada", json.dumps({"online": False, "timestamp": 3000}).encode(), retain=True)
    host.wait(mark, is_type("NDEATH", n.node_id), 10, "NDEATH when the primary host goes offline")
    time.sleep(1.0)
    check(not host.since(mark, is_type("NBIRTH", n.node_id)), "no births while the host is offline")
    host.send("spBv1.0/STATE/scada", json.dumps({"online": True, "timestamp": 4000}).encode(), retain=True)
    nb = host.wait(mark, is_type("NBIRTH", n.node_id), 15, "NBIRTH when the host is back")[0]
    check(nbirth_bdseq(nb) != bd, "the new session has a new bdSeq")
    host.wait(mark, lambda r: is_type("DDATA", n.node_id)(r) and any(m.is_historical for m in r["p"].metrics),
              10, "the changes stored while the host was away, replayed")
    n.stop()
    host.send("spBv1.0/STATE/scada", b"", retain=True)
    host.assert_clean()


def scenario_three_nodes_and_bridge(broker, host):
    """Three runtimes as three edge nodes; a host behind a mosquitto bridge sees them too."""
    far = Broker("bridge-far", bridge_to=broker.port)
    far_host = Host(far.port)
    time.sleep(1.0)  # the bridge connects
    nodes = [Node(f"spb-three-{i}", broker.port, node_id=f"rtplc-{i:02}") for i in range(3)]
    mark = host.mark()
    far_mark = far_host.mark()
    for n in nodes:
        n.start()
    for n in nodes:
        host.wait(mark, is_type("DBIRTH", n.node_id, "loop"), 30, f"DBIRTH of {n.node_id}")
        far_host.wait(far_mark, is_type("DDATA", n.node_id, "loop"), 30, f"DDATA of {n.node_id} across the bridge")
    # A command from the far side reaches the node.
    far_mark = far_host.mark()
    far_host.send(f"spBv1.0/Plant1/DCMD/{nodes[1].node_id}/loop", command(("Setpoint", DOUBLE, 33.0)))
    far_host.wait(far_mark, lambda r: is_type("DDATA", nodes[1].node_id)(r) and metric(r, "Setpoint")
                  and metric_value(metric(r, "Setpoint")) == 33.0, 15, "the far host's write, applied")
    for n in nodes:
        n.stop()
    far_host.assert_clean()
    far_host.close()
    far.stop()
    host.assert_clean()


class Proxy:
    """socat between a node and the broker: reset (kill) or half-open (SIGSTOP) the link."""

    def __init__(self, broker_port):
        self.port = free_port()
        self.proc = subprocess.Popen(["socat", f"TCP-LISTEN:{self.port},bind=127.0.0.1,reuseaddr,fork",
                                      f"TCP:127.0.0.1:{broker_port}"], stderr=subprocess.DEVNULL)
        wait_for(lambda: self._up(), 10, "socat proxy")

    def _up(self):
        try:
            socket.create_connection(("127.0.0.1", self.port), 0.2).close()
            return True
        except OSError:
            return False


def scenario_proxy_faults(broker, host):
    """A link cut hard (reset) and a half-open link (proxy frozen): the will arrives, the node comes back."""
    if not shutil.which("socat"):
        raise Failure("socat is missing (scripts/setup-deps installs it)")
    proxy = Proxy(broker.port)
    n = Node("spb-proxy", proxy.port, keepalive="2s")
    mark = host.mark()
    n.start()
    nb = host.wait(mark, is_type("NBIRTH", n.node_id), 20, "NBIRTH through the proxy")[0]
    # Half-open: socat frozen, nothing flows either way; the broker's keep-alive expires.
    mark = host.mark()
    subprocess.run(["pkill", "-STOP", "-f", f"TCP-LISTEN:{proxy.port}"])
    nd = host.wait(mark, is_type("NDEATH", n.node_id), 20, "the will after a half-open link")[0]
    check(metric_value(metric(nd, "bdSeq")) == nbirth_bdseq(nb), "the will's bdSeq is the NBIRTH's")
    subprocess.run(["pkill", "-CONT", "-f", f"TCP-LISTEN:{proxy.port}"])
    nb = host.wait(mark, is_type("NBIRTH", n.node_id), 30, "NBIRTH after the link came back")[0]
    # Reset: every proxy process killed, then a new proxy on the same port.
    mark = host.mark()
    subprocess.run(["pkill", "-KILL", "-f", f"TCP-LISTEN:{proxy.port}"])
    host.wait(mark, is_type("NDEATH", n.node_id), 20, "the will after the link was reset")
    proxy2 = subprocess.Popen(["socat", f"TCP-LISTEN:{proxy.port},bind=127.0.0.1,reuseaddr,fork",
                               f"TCP:127.0.0.1:{broker.port}"], stderr=subprocess.DEVNULL)
    host.wait(mark, is_type("NBIRTH", n.node_id), 30, "NBIRTH after the reset")
    n.stop()
    proxy2.kill()
    host.assert_clean()


def scenario_cli(broker, host):
    """rtplc sparkplug listen decodes a node's traffic; rtplc sparkplug command writes a set-point."""
    n = Node("spb-cli", broker.port)
    n.start()
    listen = subprocess.Popen([RTPLC, "sparkplug", "listen", f"127.0.0.1:{broker.port}", "--group", "Plant1",
                               "--seconds", "8"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    time.sleep(1.0)
    mark = host.mark()
    subprocess.run([RTPLC, "sparkplug", "command", f"Plant1/{n.node_id}", "--rebirth", "--broker",
                    f"127.0.0.1:{broker.port}"], check=True, capture_output=True)
    host.wait(mark, is_type("NBIRTH", n.node_id), 10, "NBIRTH after `rtplc sparkplug command --rebirth`")
    r = subprocess.run([RTPLC, "sparkplug", "command", f"Plant1/{n.node_id}/loop", "Setpoint=25", "--broker",
                        f"127.0.0.1:{broker.port}"], capture_output=True, text=True)
    check(r.returncode == 0, f"command: {r.stdout}{r.stderr}")
    out, _ = listen.communicate(20)
    check(f"spBv1.0/Plant1/NBIRTH/{n.node_id} seq=0" in out, f"listen shows the NBIRTH:\n{out[:2000]}")
    check("Setpoint Double = 25 Quality=192(Good)" in out, f"listen shows the written set-point:\n{out[-3000:]}")
    n.stop()
    host.assert_clean()


SCENARIOS = [("basic", scenario_basic), ("broker_restart", scenario_broker_restart),
             ("primary_host", scenario_primary_host), ("three_nodes_and_bridge", scenario_three_nodes_and_bridge),
             ("proxy_faults", scenario_proxy_faults), ("cli", scenario_cli)]


def main():
    # A fresh folder each run: a runtime retains its set-points, bdSeq and state there.
    shutil.rmtree(WORK, ignore_errors=True)
    os.makedirs(WORK, exist_ok=True)
    broker = Broker("broker")
    host = Host(broker.port)
    failed = False
    try:
        for name, fn in SCENARIOS:
            if ONLY and name not in ONLY:
                continue
            t0 = time.time()
            try:
                r = fn(broker, host)
                if isinstance(r, Host):
                    host = r
                print(f"PASS {name} ({time.time() - t0:.1f} s)", flush=True)
            except Exception as e:
                failed = True
                print(f"FAIL {name}: {e}", flush=True)
                traceback.print_exc()
                for d in sorted(os.listdir(WORK)):
                    p = os.path.join(WORK, d, "run.log")
                    if os.path.exists(p) and d.startswith("spb-" + name.split("_")[0][:5]):
                        print(f"--- {p} (tail)\n" + open(p, errors="replace").read()[-3000:])
                break
    finally:
        subprocess.run(["pkill", "-KILL", "-f", f"rtplc run {WORK}"], capture_output=True)
        host.close()
        broker.stop()
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
