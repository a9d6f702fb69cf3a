#!/usr/bin/env python3
"""The independent OPC UA client of tests/telemetry_opcua.rs: Python `asyncua` (PyPI).

Browses acc's model (docs/opcua.md), reads the values, subscribes to FeedOverride,
Acc/Force and Acc/Period (DataChangeFilter StatusValueTimestamp: one notification per
period, even when the value did not change) and to the events of the Server object, until
it has seen period --until. Prints one JSON line `{"ready": ...}` once subscribed, then one
JSON line with what it saw:

  {"browse": {...}, "samples": [{"period", "feed_override", "force", "force_status"}],
   "events": [{"message", "severity"}]}

Samples are joined on the source timestamp the server gives every value of one period.

--user / --password-file: connect with Basic256Sha256 SignAndEncrypt (a client certificate
is made in --cert-dir); exit 3 with `{"refused": "..."}` when the server refuses.
"""
import argparse
import asyncio
import json
import os
import sys

from asyncua import Client, ua

NS_URI = "urn:acc:opcua"


class Collect:
    def __init__(self, period_node, until):
        self.by_ts = {}
        self.events = []
        self.period_node = period_node
        self.until = until
        self.done = asyncio.Event()

    def datachange_notification(self, node, val, data):
        dv = data.monitored_item.Value
        ts = dv.SourceTimestamp
        if ts is None:
            return
        status = dv.StatusCode.name if dv.StatusCode is not None else "Good"
        key = ts.isoformat()
        self.by_ts.setdefault(key, {})[node.nodeid.to_string()] = (val, status)
        if node.nodeid == self.period_node and isinstance(val, int) and val >= self.until:
            self.done.set()

    def event_notification(self, event):
        msg = event.Message.Text if event.Message is not None else None
        self.events.append({"message": msg, "severity": event.Severity})

    def status_change_notification(self, status):
        pass


async def child(node, ns, *names):
    return await node.get_child([f"{ns}:{n}" for n in names])


async def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("url")
    ap.add_argument("--until", type=int, required=True, help="last period to wait for")
    ap.add_argument("--timeout", type=float, default=60.0)
    ap.add_argument("--user")
    ap.add_argument("--password-file")
    ap.add_argument("--cert-dir")
    a = ap.parse_args()

    client = Client(url=a.url, timeout=10)
    if a.user:
        from asyncua.crypto.cert_gen import setup_self_signed_certificate
        from cryptography.x509.oid import ExtendedKeyUsageOID
        from pathlib import Path

        d = Path(a.cert_dir or ".")
        d.mkdir(parents=True, exist_ok=True)
        cert, key = d / "asyncua-cert.der", d / "asyncua-key.pem"
        app_uri = "urn:acc:test:asyncua"
        await setup_self_signed_certificate(
            key, cert, app_uri, "localhost", [ExtendedKeyUsageOID.CLIENT_AUTH], {"commonName": "acc test asyncua"}
        )
        client.application_uri = app_uri
        await client.set_security_string(f"Basic256Sha256,SignAndEncrypt,{cert},{key}")
        client.set_user(a.user)
        with open(a.password_file) as f:
            client.set_password(f.readline().rstrip("\n"))
    try:
        await client.connect()
    except Exception as e:  # noqa: BLE001 - report any refusal as such
        print(json.dumps({"refused": f"{type(e).__name__}: {e}"}), flush=True)
        sys.exit(3)
    try:
        ns = await client.get_namespace_index(NS_URI)
        objects = client.nodes.objects
        fo = await child(objects, ns, "MachineTool", "Monitoring", "Channel1", "FeedOverride")
        spindle = await child(objects, ns, "MachineTool", "Monitoring", "Spindle")
        acc = await child(objects, ns, "Acc")
        eur = await fo.get_child(["0:EURange"])
        eu = await fo.get_child(["0:EngineeringUnits"])
        rng = await eur.read_value()
        unit = await eu.read_value()
        tdef = await fo.read_type_definition()
        browse = {
            "namespace_index": ns,
            "feed_override": fo.nodeid.to_string(),
            "feed_override_type": tdef.to_string() if tdef else None,
            "eurange": [rng.Low, rng.High],
            "unit": unit.DisplayName.Text,
            "spindle": sorted([(await c.read_browse_name()).Name for c in await spindle.get_children()]),
            "acc": sorted([(await c.read_browse_name()).Name for c in await acc.get_children()]),
            "tool_read": (await (await child(acc, ns, "Tool")).read_data_value(raise_on_bad_status=False)).StatusCode.name,
        }
        period = await child(acc, ns, "Period")
        force = await child(acc, ns, "Force")
        handler = Collect(period.nodeid, a.until)
        sub = await client.create_subscription(50, handler)
        mfilter = ua.DataChangeFilter(Trigger=ua.DataChangeTrigger.StatusValueTimestamp)
        await sub._subscribe([fo, force, period], mfilter=mfilter, queuesize=1000, sampling_interval=0)
        await sub.subscribe_events(ua.ObjectIds.Server, queuesize=100)
        print(json.dumps({"ready": True, "browse": browse}), flush=True)
        try:
            await asyncio.wait_for(handler.done.wait(), a.timeout)
        except asyncio.TimeoutError:
            pass
        await asyncio.sleep(0.5)  # the events of the last period
        samples = []
        fo_id, f_id, p_id = fo.nodeid.to_string(), force.nodeid.to_string(), period.nodeid.to_string()
        for _, vals in sorted(handler.by_ts.items()):
            if p_id not in vals or vals[p_id][1] != "Good":
                continue
            fov = vals.get(fo_id, (None, "missing"))
            fv = vals.get(f_id, (None, "missing"))
            samples.append(
                {
                    "period": vals[p_id][0],
                    "feed_override": fov[0] if fov[1] == "Good" else None,
                    "feed_override_status": fov[1],
                    "force": fv[0] if fv[1] == "Good" else None,
                    "force_status": fv[1],
                }
            )
        print(json.dumps({"browse": browse, "samples": samples, "events": handler.events}), flush=True)
    finally:
        await client.disconnect()


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    asyncio.run(main())
