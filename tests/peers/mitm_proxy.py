#!/usr/bin/env python3
"""A man in the middle on a Modbus RTU serial line: an independent test peer.

What it is. The proxy sits between a Modbus RTU client (the controller, `acc run`) and a
slave (the PMC interface board, `acc board-sim`), each on its own pseudo-terminal. It opens
the board's pty (`--upstream`, the path `acc board-sim` prints), creates a new pty pair for
the controller, prints exactly one line `PTY /dev/pts/M` and forwards the traffic both ways
until SIGTERM or SIGINT. Requests pass unchanged. Replies pass unchanged unless faults are
on; then they are what a bad line or a buffering gateway delivers, always with a VALID
Modbus CRC, so that no CRC check can catch them:

  flip       one random bit of one random data register of an FC03/FC04 reply (of the
             echoed address or value of an FC06/FC16 reply);
  slave      another slave address;
  exception  an exception reply instead (function | 0x80, random code 1..4);
  bytecount  an FC03/FC04 reply whose byte count is off by +-2, the payload cut or padded
             with 2 random bytes to match;
  truncate   1 .. len-2 bytes dropped from the end (slave address and function kept);
  random     random bytes after the header (FC03/04: slave, function, byte count kept, so
             an FC04 reply parses as a well-formed but random status);
  delay      (--delay-reads N) every FC04 read answered with the FC04 reply the board gave
             N reads earlier: well-formed, valid CRC, stale.

Why it is independent of the emulator's fault injector (crates/acc-pmc/src/emu/fault.rs).
That injector lives in the board's server and does what a broken line does to the bytes:
a bad CRC, a dropped or late reply, noise before a frame. Every one of those is caught by
the client's framing and CRC check. This proxy is a separate program in another language,
written from the Modbus RTU framing and the board's register map
(../shared/docs/pmc-board.md), not from acc's code, and its faults are the ones the CRC
cannot catch: a frame that is valid on the wire but wrong in content or in time. The board
(`acc board-sim`) keeps serving normally behind it and sees every request.

How it frames. A pty has no inter-character timing, so frames are delimited by function
code: requests FC01..06 are 8 bytes, FC15/16 are 7 + byte count + 2; replies FC01..04 are
3 + byte count + 2, FC05/06/15/16 are 8, exceptions (function | 0x80) are 5. Requests are
forwarded upstream as soon as they arrive (the proxy never holds the line up); each reply
is forwarded downstream when it is complete, possibly altered, and is paired with the
oldest outstanding request of its function code (a request left without a reply for
--timeout-ms, or passed over by a later reply, counts as "no reply": the board ignores
frames it cannot take, the proxy then gives nothing downstream either). Bytes that do not
frame (an unknown function, a frame cut short by the board) are forwarded raw after
--gap-ms of silence. A reply with a bad CRC from the board is forwarded untouched (it is
the board's own fault, never made valid).

When faults act. Only while "on": from the start with `--start on`, or toggled by SIGUSR1
(on) and SIGUSR2 (off), so a harness can switch them at the fault moment. With
--corrupt-always the corruption acts all the time and the signals switch only the delay
(acc soak: 1 % garbage throughout, delay episodes every few minutes).

Records. --reads FILE: one JSON line per FC04 reply handed to the client: {"i": read_index,
"power": W or null, "applied": OVERRIDE_APPLIED or null, "altered": bool} (null when the
frame does not parse as a well-formed reply), to align the reads with the client's log.
--events FILE: one JSON line per alteration (a delayed and corrupted reply has
two): {"t": monotonic s, "read_index": FC04 ordinal (0-based, counted over the requests)
or null, "fc": function code of the reply, "kind": ..., "register": protocol address or
null, "bit": b or null, "before": value or null, "after": value or null}. For a delayed
read, register 7 (SAMPLE_SEQ): "before" is the fresh sample number, "after" the delivered
one. --stats FILE: a JSON object written at exit and on every SIGUSR2: requests, FC04
reads, replies, no replies, alterations per kind, delay episodes, and more.

usage: mitm_proxy.py --upstream /dev/pts/N [--seed S] [--corrupt FRACTION]
                     [--kinds flip,slave,exception,bytecount,truncate,random]
                     [--delay-reads N] [--start on|off] [--corrupt-always]
                     [--stats FILE] [--events FILE] [--reads FILE]
                     [--timeout-ms MS] [--gap-ms MS]

Python 3 standard library only.
"""
import argparse
import collections
import errno
import json
import os
import random
import select
import signal
import struct
import sys
import time
import tty

KINDS = ("flip", "slave", "exception", "bytecount", "truncate", "random")
SAMPLE_SEQ = 7


def _crc_table():
    table = []
    for i in range(256):
        crc = i
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
        table.append(crc)
    return table


CRC_TABLE = _crc_table()


def crc16(data):
    """Modbus CRC-16: polynomial 0xA001 (reflected 0x8005), initial value 0xFFFF."""
    crc = 0xFFFF
    for b in data:
        crc = (crc >> 8) ^ CRC_TABLE[(crc ^ b) & 0xFF]
    return crc


def with_crc(body):
    """The frame: body and its CRC, low byte first."""
    return bytes(body) + struct.pack("<H", crc16(body))


def crc_ok(frame):
    return len(frame) >= 4 and crc16(frame[:-2]) == struct.unpack("<H", frame[-2:])[0]


def request_len(buf):
    """Length of the request at the head of buf: 0 = need more bytes, None = unknown."""
    if len(buf) < 2:
        return 0
    fc = buf[1]
    if fc in (1, 2, 3, 4, 5, 6):
        return 8
    if fc in (15, 16):
        return 9 + buf[6] if len(buf) >= 7 else 0
    return None


def reply_len(buf):
    """Length of the reply at the head of buf: 0 = need more bytes, None = unknown."""
    if len(buf) < 2:
        return 0
    fc = buf[1]
    if fc & 0x80:
        return 5
    if fc in (1, 2, 3, 4):
        return 5 + buf[2] if len(buf) >= 3 else 0
    if fc in (5, 6, 15, 16):
        return 8
    return None


class Framer:
    """Cuts a byte stream into frames by function code; raw bytes out after a silence."""

    def __init__(self, length_of, gap_s):
        self.buf = bytearray()
        self.length_of = length_of
        self.gap_s = gap_s
        self.last = 0.0

    def feed(self, data, now):
        self.buf += data
        self.last = now
        frames = []
        while self.buf:
            n = self.length_of(self.buf)
            if not n or len(self.buf) < n:
                break  # unknown function or incomplete: wait for the silence
            frames.append(bytes(self.buf[:n]))
            del self.buf[:n]
        return frames

    def stale(self, now):
        """Bytes that never made a frame, after gap_s of silence."""
        if self.buf and now - self.last >= self.gap_s:
            raw = bytes(self.buf)
            self.buf.clear()
            return raw
        return None


class Proxy:
    def __init__(self, a, up, down):
        self.a = a
        self.up = up
        self.down = down
        self.rng = random.Random(a.seed)
        self.on = a.start == "on"
        self.stop = False
        self.want_stats = False
        self.kinds = [k for k in a.kinds.split(",") if k]
        self.requests = Framer(request_len, a.gap_ms / 1e3)
        self.replies = Framer(reply_len, a.gap_ms / 1e3)
        # Outstanding requests: (fc, start, count, read_index, time sent).
        self.pending = collections.deque()
        self.reads = 0
        # The last N+1 good FC04 replies from the board (the delay's memory).
        self.history = collections.deque(maxlen=a.delay_reads + 1)
        self.stats = {
            "requests": 0,
            "fc04_reads": 0,
            "replies": 0,
            "no_reply": 0,
            "unpaired_replies": 0,
            "altered": {k: 0 for k in KINDS + ("delay",)},
            "altered_replies": 0,
            "altered_fc04_replies": 0,
            "bad_crc_passed": 0,
            "raw_bytes_passed": 0,
            "writes_dropped": 0,
            "episodes": 1 if self.on else 0,
        }
        self.events = open(a.events, "w") if a.events else None
        self.reads_file = open(a.reads, "w") if a.reads else None

    # -------------------------------------------------------------- signals
    def on_signal(self, signum, _frame):
        if signum == signal.SIGUSR1:
            if not self.on:
                self.stats["episodes"] += 1
            self.on = True
        elif signum == signal.SIGUSR2:
            self.on = False
            self.want_stats = True
        else:
            self.stop = True

    # ---------------------------------------------------------------- output
    def write(self, fd, data):
        try:
            os.write(fd, data)
        except OSError as e:  # the peer does not read (full buffer) or is gone
            if e.errno not in (errno.EAGAIN, errno.EIO):
                raise
            self.stats["writes_dropped"] += 1

    def event(self, read_index, fc, kind, register=None, bit=None, before=None, after=None):
        self.stats["altered"][kind] += 1
        if self.events:
            self.events.write(json.dumps({
                "t": round(time.monotonic(), 6), "read_index": read_index, "fc": fc,
                "kind": kind, "register": register, "bit": bit, "before": before,
                "after": after}) + "\n")
            self.events.flush()

    def write_stats(self):
        if not self.a.stats:
            return
        s = dict(self.stats, on=self.on, pending=len(self.pending))
        tmp = self.a.stats + ".tmp"
        with open(tmp, "w") as f:
            json.dump(s, f, indent=1, sort_keys=True)
        os.replace(tmp, self.a.stats)

    # ------------------------------------------------------------- requests
    def request(self, frame, now):
        self.stats["requests"] += 1
        fc = frame[1]
        start, count, index = None, None, None
        if fc in (1, 2, 3, 4, 5, 6, 15, 16):
            start, count = struct.unpack(">HH", frame[2:6])
        if fc == 4:
            index = self.reads
            self.reads += 1
            self.stats["fc04_reads"] += 1
        self.pending.append((fc, start, count, index, now))

    def expire(self, now):
        limit = self.a.timeout_ms / 1e3
        while self.pending and now - self.pending[0][4] > limit:
            self.pending.popleft()
            self.stats["no_reply"] += 1

    def pair(self, fc):
        """The outstanding request this reply answers (earlier ones had no reply)."""
        for i, req in enumerate(self.pending):
            if req[0] == fc:
                for _ in range(i):
                    self.pending.popleft()
                    self.stats["no_reply"] += 1
                return self.pending.popleft()
        return None

    # --------------------------------------------------------------- replies
    def reply(self, frame):
        self.stats["replies"] += 1
        fc = frame[1] & 0x7F
        req = self.pair(fc)
        if req is None:
            self.stats["unpaired_replies"] += 1
        read_index = req[3] if req else None
        start = req[1] if req and req[1] is not None else 0
        if not crc_ok(frame):
            self.stats["bad_crc_passed"] += 1
            if fc == 4:
                self.record_read(read_index, frame, start, False)
            return frame
        out = frame
        altered = False
        if frame[1] == 4:
            self.history.append(frame)
            if self.on and self.a.delay_reads > 0 and len(self.history) > self.a.delay_reads:
                out = self.history[0]
                altered = True
                self.event(read_index, 4, "delay", *self.seq_change(frame, out, start))
        corrupting = self.on or self.a.corrupt_always
        if corrupting and self.a.corrupt > 0 and self.rng.random() < self.a.corrupt:
            kinds = [k for k in self.kinds if applicable(k, out)]
            if kinds:
                kind = self.rng.choice(kinds)
                out, detail = corrupt(self.rng, kind, out, start)
                altered = True
                self.event(read_index, frame[1], kind, *detail)
        if altered:
            self.stats["altered_replies"] += 1
            if frame[1] == 4:
                self.stats["altered_fc04_replies"] += 1
        if frame[1] == 4:
            self.record_read(read_index, out, start, altered)
        return out

    def record_read(self, read_index, delivered, start, altered):
        """--reads: what the client was handed for this FC04 read (power, applied
        override) when it is a well-formed reply covering them, for aligning the reads
        with the client's log."""
        if not self.reads_file:
            return
        regs = {}
        if crc_ok(delivered) and delivered[1] == 4 and len(delivered) == 5 + delivered[2]:
            for i in range(delivered[2] // 2):
                regs[start + i] = struct.unpack(">H", delivered[3 + 2 * i:5 + 2 * i])[0]
        power = (regs[4] << 16) | regs[5] if 4 in regs and 5 in regs else None
        self.reads_file.write(json.dumps({
            "i": read_index, "power": power, "applied": regs.get(1),
            "altered": altered}) + "\n")

    @staticmethod
    def seq_change(fresh, delivered, start):
        """(register, bit, before, after) of a delayed FC04 reply: its SAMPLE_SEQ."""
        i = SAMPLE_SEQ - start
        if 0 <= i and 3 + 2 * i + 2 <= len(fresh) - 2 and 3 + 2 * i + 2 <= len(delivered) - 2:
            before = struct.unpack(">H", fresh[3 + 2 * i:5 + 2 * i])[0]
            after = struct.unpack(">H", delivered[3 + 2 * i:5 + 2 * i])[0]
            return SAMPLE_SEQ, None, before, after
        return None, None, None, None

    # ------------------------------------------------------------------ loop
    def run(self):
        while not self.stop:
            if self.want_stats:
                self.want_stats = False
                self.write_stats()
            try:
                ready, _, _ = select.select([self.up, self.down], [], [], 0.02)
            except InterruptedError:
                continue
            now = time.monotonic()
            if self.down in ready:
                data = os.read(self.down, 4096)
                self.write(self.up, data)  # requests pass at once, unchanged
                for frame in self.requests.feed(data, now):
                    self.request(frame, now)
            if self.up in ready:
                try:
                    data = os.read(self.up, 4096)
                except OSError as e:
                    if e.errno != errno.EIO:
                        raise
                    data = b""
                if not data:
                    print("mitm_proxy: the board's pty hung up", file=sys.stderr)
                    break
                for frame in self.replies.feed(data, now):
                    self.write(self.down, self.reply(frame))
            self.requests.stale(now)  # bookkeeping only: the bytes went upstream already
            raw = self.replies.stale(now)
            if raw:
                self.stats["raw_bytes_passed"] += len(raw)
                self.write(self.down, raw)
            self.expire(now)
        self.write_stats()
        for f in (self.events, self.reads_file):
            if f:
                f.close()


def applicable(kind, frame):
    fc = frame[1]
    if kind == "flip":
        return (fc in (3, 4) and frame[2] >= 2) or fc in (6, 16)
    if kind == "exception":
        return not fc & 0x80
    if kind == "bytecount":
        return fc in (3, 4)
    if kind == "truncate":
        return len(frame) - 2 >= 3
    if kind == "random":
        return len(frame) - 2 > header_len(frame)
    return kind == "slave"


def header_len(frame):
    return 3 if frame[1] in (1, 2, 3, 4) else 2


def corrupt(rng, kind, frame, start):
    """The altered frame (valid CRC) and (register, bit, before, after)."""
    body = bytearray(frame[:-2])
    fc = body[1]
    detail = (None, None, None, None)
    if kind == "flip":
        if fc in (3, 4):
            r = rng.randrange(body[2] // 2)
            at, register = 3 + 2 * r, start + r
        else:  # FC06/16 echo: address (bytes 2-3) or value / quantity (4-5)
            field = rng.randrange(2)
            at = 2 + 2 * field
            register = struct.unpack(">H", body[2:4])[0]
        bit = rng.randrange(16)
        before = struct.unpack(">H", body[at:at + 2])[0]
        after = before ^ (1 << bit)
        body[at:at + 2] = struct.pack(">H", after)
        detail = (register, bit, before, after)
    elif kind == "slave":
        new = rng.choice([s for s in range(1, 248) if s != body[0]])
        detail = (None, None, body[0], new)
        body[0] = new
    elif kind == "exception":
        code = rng.randint(1, 4)
        body = bytearray([body[0], fc | 0x80, code])
        detail = (None, None, None, code)
    elif kind == "bytecount":
        bc = body[2]
        delta = rng.choice((-2, 2)) if 2 <= bc <= 248 else (2 if bc < 2 else -2)
        if delta < 0:
            del body[-2:]
        else:
            body += bytes(rng.randrange(256) for _ in range(2))
        body[2] = bc + delta
        detail = (None, None, bc, bc + delta)
    elif kind == "truncate":
        k = rng.randint(1, len(body) - 2)
        detail = (None, None, len(body), len(body) - k)
        del body[len(body) - k:]
    elif kind == "random":
        h = header_len(frame)
        body[h:] = bytes(rng.randrange(256) for _ in range(len(body) - h))
    return with_crc(body), detail


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--upstream", required=True, help="the board's pty (acc board-sim prints it)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--corrupt", type=float, default=0.0, help="fraction of replies corrupted")
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--delay-reads", type=int, default=0,
                    help="answer every FC04 read with the reply of N reads earlier (0: off)")
    ap.add_argument("--start", choices=("on", "off"), default="on")
    ap.add_argument("--corrupt-always", action="store_true",
                    help="corrupt whether on or off; SIGUSR1/SIGUSR2 switch the delay only")
    ap.add_argument("--stats")
    ap.add_argument("--events")
    ap.add_argument("--reads", help="one JSON line per FC04 reply handed downstream: "
                    "{i: read_index, power, applied, altered}")
    ap.add_argument("--timeout-ms", type=float, default=300.0,
                    help="a request without a reply after this long had none")
    ap.add_argument("--gap-ms", type=float, default=50.0,
                    help="silence after which bytes that make no frame are passed raw")
    a = ap.parse_args()
    bad = [k for k in a.kinds.split(",") if k and k not in KINDS]
    if bad or not 0.0 <= a.corrupt <= 1.0 or a.delay_reads < 0:
        ap.error("--kinds from %s, --corrupt in 0..1, --delay-reads >= 0" % ",".join(KINDS))

    up = os.open(a.upstream, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(up)
    down, down_slave = os.openpty()
    tty.setraw(down_slave)  # kept open: the master never reads EIO while the client is away
    for fd in (up, down):
        os.set_blocking(fd, False)
    proxy = Proxy(a, up, down)
    for s in (signal.SIGUSR1, signal.SIGUSR2, signal.SIGTERM, signal.SIGINT):
        signal.signal(s, proxy.on_signal)
    print("PTY " + os.ttyname(down_slave), flush=True)
    proxy.run()


if __name__ == "__main__":
    main()
