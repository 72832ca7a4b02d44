#!/usr/bin/env python3
"""Creates Lamina's services the way a client using the binding's defaults does, then holds
them: the payload and header types are Lamina's, every other setting is iceoryx2's default
(for `nodes`: subscriber_max_buffer_size 2, history_size 0 where Lamina needs 16 and 1).

Prints one JSON line with each created service's settings once they all exist, then keeps them
until stdin closes (or `--seconds` pass). Used by tests/tests/python_clients.rs to check that
`lamina run` refuses such a service naming the setting and the value it needs.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import os
import select
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "python"))

import iceoryx2 as iox2  # noqa: E402

from lamina import wire as lw  # noqa: E402

SERVICES = {
    "nodes": (iox2.Slice[lw.Position], lw.NodesHeader),
    "topology": (iox2.Slice[ctypes.c_uint32], lw.TopologyHeader),
    "tool": (lw.ToolCommand, None),
    "feedback": (lw.ContactFeedback, None),
    "stats": (lw.StatsSummary, None),
}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--prefix", required=True)
    parser.add_argument("--services", default="nodes", help="comma-separated, from " + ",".join(SERVICES))
    parser.add_argument("--seconds", type=float, default=120.0, help="hold at most this long (default 120)")
    args = parser.parse_args()
    names = [s for s in args.services.split(",") if s]
    unknown = [s for s in names if s not in SERVICES]
    if unknown:
        parser.error(f"unknown service(s) {unknown}; known: {list(SERVICES)}")

    node = lw.open_node("lamina_py_defaults")
    held = {}
    report = {}
    for name in names:
        payload, header = SERVICES[name]
        builder = node.service_builder(iox2.ServiceName.new(f"{args.prefix}/{name}")).publish_subscribe(payload)
        if header is not None:
            builder = builder.user_header(header)
        service = builder.create()  # no QoS set: the binding's defaults
        held[name] = service
        c = service.static_config
        report[name] = {
            "subscriber_max_buffer_size": c.subscriber_max_buffer_size,
            "history_size": c.history_size,
            "subscriber_max_borrowed_samples": c.subscriber_max_borrowed_samples,
            "max_subscribers": c.max_subscribers,
            "max_publishers": c.max_publishers,
            "max_nodes": c.max_nodes,
            "safe_overflow": c.has_safe_overflow,
        }
    print(json.dumps(report), flush=True)
    deadline = time.monotonic() + args.seconds
    while time.monotonic() < deadline:
        ready, _, _ = select.select([sys.stdin], [], [], 0.1)
        if ready and not sys.stdin.read(1):
            break  # stdin closed: the test is done
    return 0


if __name__ == "__main__":
    sys.exit(main())
