#!/usr/bin/env node
// The second independent OPC UA client of tests/telemetry_opcua.rs: node-opcua (npm).
// Same protocol as tests/peers/opcua_asyncua.py: browse acc's model, read, subscribe to
// FeedOverride, Acc/Force and Acc/Period (DataChangeFilter StatusValueTimestamp) and to the
// Server object's events until period --until; print `{"ready":...}` once subscribed, then
// one JSON line with the browse result, the samples joined on their source timestamp, and
// the events.
"use strict";
const {
  OPCUAClient,
  MessageSecurityMode,
  SecurityPolicy,
  AttributeIds,
  TimestampsToReturn,
  DataChangeFilter,
  DataChangeTrigger,
  DeadbandType,
  StatusCodes,
  ClientMonitoredItemGroup,
  constructEventFilter,
  ClientMonitoredItem,
  makeBrowsePath,
} = require("node-opcua");

const NS_URI = "urn:acc:opcua";

// node-opcua gives a UInt64 as [high, low] 32-bit words.
function u64(v) {
  return Array.isArray(v) ? v[0] * 4294967296 + v[1] : Number(v);
}

function arg(name, dflt) {
  const i = process.argv.indexOf(name);
  return i > 0 ? process.argv[i + 1] : dflt;
}

async function main() {
  const url = process.argv[2];
  const until = Number(arg("--until"));
  const timeoutMs = Number(arg("--timeout", "60")) * 1000;
  const client = OPCUAClient.create({
    endpointMustExist: false,
    securityMode: MessageSecurityMode.None,
    securityPolicy: SecurityPolicy.None,
    connectionStrategy: { maxRetry: 2, initialDelay: 200, maxDelay: 1000 },
  });
  await client.connect(url);
  const session = await client.createSession();
  try {
    const nsArray = (await session.readNamespaceArray());
    const ns = nsArray.indexOf(NS_URI);
    if (ns < 0) throw new Error(`namespace ${NS_URI} not served: ${nsArray}`);
    const path = (p) => makeBrowsePath("ObjectsFolder", p);
    const ids = {};
    for (const [k, p] of Object.entries({
      fo: `/${ns}:MachineTool/${ns}:Monitoring/${ns}:Channel1/${ns}:FeedOverride`,
      eur: `/${ns}:MachineTool/${ns}:Monitoring/${ns}:Channel1/${ns}:FeedOverride.EURange`,
      spindle: `/${ns}:MachineTool/${ns}:Monitoring/${ns}:Spindle`,
      acc: `/${ns}:Acc`,
      force: `/${ns}:Acc.${ns}:Force`,
      period: `/${ns}:Acc.${ns}:Period`,
      tool: `/${ns}:Acc.${ns}:Tool`,
    })) {
      const r = await session.translateBrowsePath(path(p));
      if (!r.targets || r.targets.length === 0) throw new Error(`no node at ${p}: ${r.statusCode}`);
      ids[k] = r.targets[0].targetId;
    }
    const names = async (id) =>
      (await session.browse(id)).references
        .filter((r) => r.browseName.namespaceIndex === ns)
        .map((r) => r.browseName.name)
        .sort();
    const rng = (await session.read({ nodeId: ids.eur, attributeId: AttributeIds.Value })).value.value;
    const tdef = (await session.browse({
      nodeId: ids.fo,
      referenceTypeId: "HasTypeDefinition",
      browseDirection: 0,
      includeSubtypes: true,
      resultMask: 63,
    })).references[0].nodeId.toString();
    const browse = {
      namespace_index: ns,
      feed_override: ids.fo.toString(),
      feed_override_type: tdef,
      eurange: [rng.low, rng.high],
      spindle: await names(ids.spindle),
      acc: await names(ids.acc),
      tool_read: (await session.read({ nodeId: ids.tool, attributeId: AttributeIds.Value })).statusCode.name,
    };

    const sub = await session.createSubscription2({
      requestedPublishingInterval: 50,
      requestedLifetimeCount: 600,
      requestedMaxKeepAliveCount: 20,
      maxNotificationsPerPublish: 0,
      publishingEnabled: true,
      priority: 1,
    });
    const byTs = new Map();
    let done;
    const finished = new Promise((res) => (done = res));
    const filter = new DataChangeFilter({
      trigger: DataChangeTrigger.StatusValueTimestamp,
      deadbandType: DeadbandType.None,
    });
    const items = [
      ["fo", ids.fo],
      ["force", ids.force],
      ["period", ids.period],
    ];
    for (const [k, nodeId] of items) {
      const mi = ClientMonitoredItem.create(
        sub,
        { nodeId, attributeId: AttributeIds.Value },
        { samplingInterval: 0, queueSize: 1000, discardOldest: true, filter },
        TimestampsToReturn.Both
      );
      mi.on("changed", (dv) => {
        if (!dv.sourceTimestamp) return;
        const key = dv.sourceTimestamp.toISOString() + "/" + (dv.sourcePicoseconds || 0);
        if (!byTs.has(key)) byTs.set(key, { t: dv.sourceTimestamp.getTime() });
        byTs.get(key)[k] = { v: dv.value.value, s: dv.statusCode.name };
        if (k === "period" && dv.statusCode === StatusCodes.Good && u64(dv.value.value) >= until) done();
      });
    }
    const events = [];
    const evf = constructEventFilter(["Message", "Severity"]);
    const ev = ClientMonitoredItem.create(
      sub,
      { nodeId: "i=2253", attributeId: AttributeIds.EventNotifier },
      { queueSize: 100, filter: evf, discardOldest: true },
      TimestampsToReturn.Both
    );
    ev.on("changed", (fields) => {
      events.push({ message: fields[0].value ? fields[0].value.text : null, severity: fields[1].value });
    });
    await new Promise((r) => setTimeout(r, 300));
    console.log(JSON.stringify({ ready: true, browse }));
    await Promise.race([finished, new Promise((r) => setTimeout(r, timeoutMs))]);
    await new Promise((r) => setTimeout(r, 500));
    // Several notifications of one period share the millisecond timestamp of JS Dates:
    // the key carries the picoseconds too; sort by time.
    const samples = [...byTs.values()]
      .filter((x) => x.period && x.period.s === "Good")
      .sort((a, b) => a.t - b.t)
      .map((x) => ({
        period: u64(x.period.v),
        feed_override: x.fo && x.fo.s === "Good" ? x.fo.v : null,
        feed_override_status: x.fo ? x.fo.s : "missing",
        force: x.force && x.force.s === "Good" ? x.force.v : null,
        force_status: x.force ? x.force.s : "missing",
      }));
    console.log(JSON.stringify({ browse, samples, events }));
    await sub.terminate();
  } finally {
    await session.close();
    await client.disconnect();
  }
}

// Exit as soon as the work is done (the timeout's timer would keep the process alive).
main().then(() => process.exit(0)).catch((e) => {
  console.error(e && e.stack ? e.stack : String(e));
  process.exit(1);
});
