#!/usr/bin/env python3
"""Soak test of a running taunet: N clients poll it for a while, some asking
for images, some through the Unix-domain socket, some authenticating over TCP
(protocol version 3, docs/protocol.md), while the daemon's resident memory is
sampled from /proc. Written from docs/protocol.md alone (standard library
only), so it is also an independent client.

  taunet --backend simulation --scene data/scenes/lab.xml \
         --config data/config/scorpion.xml --port 7010 --period 100 \
         --auth-key KEY --unix-socket /tmp/taunet.sock &
  tools/scripts/taunet-soak.py --pid $! --port 7010 --auth-key KEY \
         --unix-socket /tmp/taunet.sock --clients 10 --minutes 60 --csv rss.csv

Prints one line per sample and a summary (RSS first/min/max/last, requests,
errors by code); exits 1 when a client saw a broken connection or a reply that
does not follow the protocol.
"""
import argparse
import hashlib
import hmac
import os
import socket
import struct
import sys
import threading
import time


def frame(kind, request, payload=b""):
    return struct.pack(">IHHI", len(payload), kind, 0, request) + payload


def string(b):
    return struct.pack(">I", len(b)) + b


class Client:
    def __init__(self, args, index):
        self.args = args
        self.index = index
        self.request = 0
        self.buffer = b""
        self.sock = None

    def connect(self):
        if self.args.unix_socket and self.index % 3 == 2:
            self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            self.sock.connect(self.args.unix_socket)
            keyed = False
        else:
            self.sock = socket.create_connection((self.args.host, self.args.port), timeout=30)
            keyed = self.args.key is not None
        self.sock.settimeout(60)
        kind, payload = self.call(0x0001, struct.pack(">H", 3) + string(b"soak-%d" % self.index))
        if kind != 0x8001:
            raise RuntimeError("HELLO answered 0x%04x" % kind)
        at = 2
        for _ in range(2):
            (n,) = struct.unpack(">I", payload[at:at + 4])
            at += 4 + n
        required = payload[at]
        (n,) = struct.unpack(">I", payload[at + 1:at + 5])
        challenge = payload[at + 5:at + 5 + n]
        if keyed:
            nonce = os.urandom(32)
            mac = hmac.new(self.args.key, b"TAU3 client" + challenge + nonce, hashlib.sha256).digest()
            kind, reply = self.call(0x000A, string(nonce) + string(mac))
            if kind != 0x800A:
                raise RuntimeError("AUTHENTICATE answered 0x%04x" % kind)
            expected = hmac.new(self.args.key, b"TAU3 server" + challenge + nonce, hashlib.sha256).digest()
            if reply[4:] != expected:
                raise RuntimeError("the server's proof does not match the key")
        elif required:
            raise RuntimeError("the server requires authentication: give --auth-key")

    def call(self, kind, payload=b""):
        self.request += 1
        self.sock.sendall(frame(kind, self.request, payload))
        while True:
            if len(self.buffer) >= 12:
                length, rkind, _, rid = struct.unpack(">IHHI", self.buffer[:12])
                if len(self.buffer) >= 12 + length:
                    body = self.buffer[12:12 + length]
                    self.buffer = self.buffer[12 + length:]
                    if rid != self.request:
                        raise RuntimeError("reply for request %d while waiting for %d" % (rid, self.request))
                    return rkind, body
            data = self.sock.recv(1 << 20)
            if not data:
                raise RuntimeError("connection closed by the server")
            self.buffer += data


def run_client(args, index, stop, stats, lock):
    client = Client(args, index)
    try:
        client.connect()
        if index == 0 and args.search:
            kind, _ = client.call(0x0002)
            if kind != 0x8002:
                raise RuntimeError("START_SEARCHING answered 0x%04x" % kind)
        images = index % 2 == 0
        step = 0
        while not stop.is_set():
            step += 1
            plan = [(0x0009, b"")]
            if step % 5 == 0:
                plan.append((0x0004, struct.pack(">I", 10000)))
            else:
                plan.append((0x0005, b""))
            if images and step % 10 == 0:
                plan.append((0x0008, bytes([step % 3, 3, 80])))
            for kind, payload in plan:
                rkind, body = client.call(kind, payload)
                with lock:
                    stats["requests"] += 1
                    if rkind == 0xFFFF:
                        code = struct.unpack(">H", body[:2])[0]
                        stats["errors"][code] = stats["errors"].get(code, 0) + 1
                    elif rkind != (kind | 0x8000):
                        raise RuntimeError("reply type 0x%04x to 0x%04x" % (rkind, kind))
            stop.wait(args.poll_ms / 1000.0)
    except Exception as e:  # a soak reports, it does not stop the others
        with lock:
            stats["failures"].append("client %d: %s" % (index, e))


def rss_kib(pid):
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return -1


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--pid", type=int, required=True, help="taunet's process id (for its RSS)")
    p.add_argument("--host", default="127.0.0.1")
    p.add_argument("--port", type=int, default=7010)
    p.add_argument("--unix-socket", help="every third client connects here")
    p.add_argument("--auth-key", help="taunet's key file: TCP clients authenticate")
    p.add_argument("--clients", type=int, default=10)
    p.add_argument("--minutes", type=float, default=60)
    p.add_argument("--poll-ms", type=int, default=100, help="pause between a client's request rounds")
    p.add_argument("--sample-s", type=float, default=30, help="RSS sampling period")
    p.add_argument("--no-search", dest="search", action="store_false",
                   help="do not START_SEARCHING (by default the first client does)")
    p.add_argument("--csv", help="write elapsed_s,rss_kib,requests per sample here")
    args = p.parse_args()
    args.key = None
    if args.auth_key:
        with open(args.auth_key, "rb") as f:
            args.key = f.read().rstrip(b" \t\r\n")
    stop = threading.Event()
    lock = threading.Lock()
    stats = {"requests": 0, "errors": {}, "failures": []}
    threads = [threading.Thread(target=run_client, args=(args, i, stop, stats, lock), daemon=True)
               for i in range(args.clients)]
    for t in threads:
        t.start()
    start = time.monotonic()
    samples = []
    out = open(args.csv, "w") if args.csv else None
    if out:
        out.write("elapsed_s,rss_kib,requests\n")
    while True:
        elapsed = time.monotonic() - start
        rss = rss_kib(args.pid)
        with lock:
            requests = stats["requests"]
        samples.append(rss)
        print("%7.0f s  RSS %8d KiB  requests %d" % (elapsed, rss, requests), flush=True)
        if out:
            out.write("%.0f,%d,%d\n" % (elapsed, rss, requests))
            out.flush()
        if elapsed >= args.minutes * 60:
            break
        time.sleep(min(args.sample_s, max(0.1, args.minutes * 60 - elapsed)))
    stop.set()
    for t in threads:
        t.join(timeout=30)
    settled = samples[len(samples) // 10:] or samples
    print("RSS KiB: first %d, min %d, max %d, last %d; after the first tenth: %d..%d" %
          (samples[0], min(samples), max(samples), samples[-1], min(settled), max(settled)))
    print("requests %d, errors by code %s" % (stats["requests"], dict(sorted(stats["errors"].items()))))
    for f in stats["failures"]:
        print("FAILURE " + f)
    return 1 if stats["failures"] else 0


if __name__ == "__main__":
    sys.exit(main())
