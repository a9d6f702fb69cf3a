#!/usr/bin/env python3
"""An independent MTConnect SHDR reader (written from the SHDR format of the MTConnect
C++ agent's adapter documentation, not from acc's code): connects to an adapter, sends a
`* PING` heartbeat, and parses every line until the adapter closes the connection or the
time limit.

Line grammar (SHDR): `<timestamp>|<key>|<value>[|<key>|<value>...]`; a key named in
--conditions is a CONDITION and takes the rest of the line:
`<level>|<native_code>|<native_severity>|<qualifier>|<message>`; `* PONG <ms>` answers a
`* PING`. Timestamps are ISO 8601 UTC.

Prints one JSON object: {"lines": N, "first": {item: value}, "items": {item: [values...]},
"conditions": {name: [[level, code, message], ...]}, "pong_ms": int|null, "errors": [...]}.

usage: shdr_reader.py HOST PORT --conditions a,b,c [--seconds S]
"""
import argparse
import datetime
import json
import socket
import sys
import time


def parse_ts(ts):
    # 2026-11-24T09:47:17.123Z
    if not ts.endswith("Z"):
        raise ValueError("timestamp not UTC: %r" % ts)
    return datetime.datetime.strptime(ts[:-1], "%Y-%m-%dT%H:%M:%S.%f")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("host")
    ap.add_argument("port", type=int)
    ap.add_argument("--conditions", default="")
    ap.add_argument("--seconds", type=float, default=30.0)
    a = ap.parse_args()
    conds = set(c for c in a.conditions.split(",") if c)
    deadline = time.monotonic() + a.seconds
    s = None
    while s is None:
        try:
            s = socket.create_connection((a.host, a.port), timeout=1.0)
        except OSError:
            if time.monotonic() > deadline:
                print(json.dumps({"errors": ["cannot connect"]}))
                return 1
            time.sleep(0.05)
    print("connected", file=sys.stderr, flush=True)
    s.sendall(b"* PING\n")
    s.settimeout(0.2)
    buf = b""
    out = {"lines": 0, "first": None, "items": {}, "conditions": {}, "pong_ms": None,
           "errors": [], "last_ts": None}
    last = None
    while time.monotonic() < deadline:
        try:
            chunk = s.recv(65536)
        except socket.timeout:
            continue
        if not chunk:
            break
        buf += chunk
        while b"\n" in buf:
            raw, buf = buf.split(b"\n", 1)
            line = raw.decode("utf-8").rstrip("\r")
            if not line:
                continue
            out["lines"] += 1
            if line.startswith("* PONG"):
                out["pong_ms"] = int(line.split()[2])
                continue
            if line.startswith("*"):
                continue
            f = line.split("|")
            try:
                t = parse_ts(f[0])
            except ValueError as e:
                out["errors"].append(str(e))
                continue
            if last is not None and t < last:
                out["errors"].append("timestamp went back: %s" % f[0])
            last = t
            out["last_ts"] = f[0]
            rest = f[1:]
            first = {}
            i = 0
            while i < len(rest):
                key = rest[i]
                if key in conds:
                    fields = rest[i + 1:]
                    if len(fields) != 5:
                        out["errors"].append("condition %s has %d fields" % (key, len(fields)))
                        break
                    level, code, _sev, _qual, msg = fields
                    out["conditions"].setdefault(key, []).append([level, code, msg])
                    break
                if i + 1 >= len(rest):
                    out["errors"].append("key without value: %r" % line)
                    break
                value = rest[i + 1]
                out["items"].setdefault(key, []).append(value)
                first[key] = value
                i += 2
            if out["first"] is None and first:
                out["first"] = first
    print(json.dumps(out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
