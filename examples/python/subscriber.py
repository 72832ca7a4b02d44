#!/usr/bin/env python3
"""Reads Lamina's model and node positions over iceoryx2 as numpy arrays.

Receives the topology (node count, surface triangles and grids, springs, layers with their
tissue, rest positions, the tool and device mapping) and then `--frames` node
frames from `<prefix>/nodes`: each frame's sequence number and node count, and its positions
as an `(N, 3)` float32 array in metres. Prints a line per second, or with `--json` one JSON
object at the end (what the workspace test `python_clients` checks).

    lamina run --prefix demo &
    python3 examples/python/subscriber.py --prefix demo --frames 2000
"""

from __future__ import annotations

import argparse
import ctypes
import json
import sys
import time

import numpy as np

from lamina import wire as lw


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--prefix", default=lw.DEFAULT_PREFIX, help="Lamina's service prefix (default: lamina)")
    parser.add_argument("--frames", type=int, default=1000, help="node frames to read (default: 1000)")
    parser.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for each message (default: 10)")
    parser.add_argument("--json", action="store_true", help="print one JSON summary instead of progress lines")
    parser.add_argument("--poll", action="store_true", help="poll every 0.5 ms instead of sleeping until the core "
                        "notifies (tens of microseconds sooner, some CPU spent between frames)")
    args = parser.parse_args()
    if args.frames < 1 or not args.timeout > 0:
        parser.error("--frames must be at least 1 and --timeout positive")

    node = lw.open_node("lamina_py_subscriber")
    topology_sub = lw.topology_service(node, args.prefix).subscriber_builder().create()
    nodes_sub = lw.nodes_service(node, args.prefix).subscriber_builder().create()
    stats_sub = lw.stats_service(node, args.prefix).subscriber_builder().create()
    topology_wake = None if args.poll else lw.wake_listener(node, args.prefix, "topology")
    nodes_wake = None if args.poll else lw.wake_listener(node, args.prefix, "nodes")

    # The topology is kept for late joiners; the core hands it over within a second.
    sample = lw.receive_until(topology_sub, args.timeout, topology_wake)
    if sample is None:
        print(f"error: no topology on '{args.prefix}/topology' within {args.timeout} s: is `lamina run "
              f"--prefix {args.prefix}` running as this user?", file=sys.stderr)
        return 2
    topology = lw.decode_topology(sample)
    sample.delete()
    if not args.json:
        layers = ", ".join(f"{l['name']} ({l['node_count']})" for l in topology["layers"])
        grids = ", ".join(f"{s['name']} {s['grid'][0]}x{s['grid'][1]}" for s in topology["surfaces"] if s["grid"])
        print(f"topology rev {topology['revision']} of '{topology['name']}': {topology['node_count']} nodes, "
              f"{len(topology['triangles'])} surface triangles, {len(topology['springs'])} springs, "
              f"layers: {layers}; grids: {grids}; tool: {topology['tool']['source']}, "
              f"radius {topology['tool']['radius_m'] * 1e3:.1f} mm")

    sequences: list[int] = []
    node_counts: set[int] = set()
    payload_len_raw = None
    finite = True
    lo = np.full(3, np.inf, dtype=np.float64)
    hi = np.full(3, -np.inf, dtype=np.float64)
    first = last = None
    last_print = time.monotonic()
    while len(sequences) < args.frames:
        sample = lw.receive_until(nodes_sub, args.timeout, nodes_wake)
        if sample is None:
            print(f"error: no node frame on '{args.prefix}/nodes' within {args.timeout} s "
                  f"(after {len(sequences)} frames)", file=sys.stderr)
            return 2
        header = sample.user_header().contents
        if payload_len_raw is None:
            payload_len_raw = sample.payload().len()
        sequences.append(int(header.sequence))
        node_counts.add(int(header.node_count))
        tick, sim_time = int(header.tick), float(header.sim_time_s)
        x = lw.positions(sample)  # (N, 3) float32, metres
        sample.delete()  # return the chunk to the core at once
        finite &= bool(np.isfinite(x).all())
        lo = np.minimum(lo, x.min(axis=0))
        hi = np.maximum(hi, x.max(axis=0))
        if first is None:
            first = x
        last = x
        now = time.monotonic()
        if not args.json and now - last_print >= 1.0:
            last_print = now
            print(f"frame {sequences[-1]} tick {tick} t {sim_time:.3f} s: {x.shape[0]} nodes, "
                  f"max displacement {np.linalg.norm(x - first, axis=1).max() * 1e3:.3f} mm")

    # The newest deadline-monitor summary (once a second; the last one is kept for late joiners).
    stats = None
    while (s := stats_sub.receive()) is not None:
        m = s.payload().contents
        stats = {"sequence": int(m.sequence), "ticks": int(m.ticks), "misses": int(m.misses),
                 "compute_p99_us": m.compute.p99_ns / 1e3, "lateness_p99_us": m.lateness.p99_ns / 1e3}
        s.delete()

    seq = np.array(sequences, dtype=np.int64)
    steps = np.diff(seq)
    summary = {
        "prefix": args.prefix,
        "topology": {
            "revision": topology["revision"],
            "node_count": topology["node_count"],
            "triangle_count": int(len(topology["triangles"])),
            "tex_coord_count": int(len(topology["tex_coords"])),
            "triangle_index_max": int(topology["triangles"].max()) if len(topology["triangles"]) else -1,
            "layers": topology["layers"],
            "name": topology["name"],
            "surfaces": [{"name": s["name"], "tissue": s["tissue"], "grid": s["grid"]} for s in topology["surfaces"]],
            "spring_count": int(len(topology["springs"])),
            "spring_index_max": int(topology["springs"].max()) if len(topology["springs"]) else -1,
            "spring_layer_tissues": sorted({topology["layers"][int(l)]["tissue"] for l in np.unique(topology["spring_layer"])}),
            "rest_positions_shape": list(topology["rest_positions"].shape),
            # How far the first frame is from the rest positions the topology carries, m.
            "rest_to_first_frame_max_m": float(np.abs(first - topology["rest_positions"]).max())
            if first is not None and topology["rest_positions"].shape == first.shape
            else None,
            "tool_source": topology["tool"]["source"],
            "tool_radius_m": topology["tool"]["radius_m"],
            "device_origin_m": topology["tool"]["device_origin_m"].tolist(),
        },
        "frames": len(sequences),
        "sequence_first": int(seq[0]),
        "sequence_last": int(seq[-1]),
        "sequence_increasing": bool((steps > 0).all()),
        "frames_dropped": int((steps - 1).clip(min=0).sum()),
        "node_counts": sorted(node_counts),
        # The binding's payload().len() on a slice is in bytes (iceoryx2 0.10.0); shown so a
        # fixed binding is noticed: then it equals the node count.
        "payload_len_raw": payload_len_raw,
        "payload_len_elements": payload_len_raw // ctypes.sizeof(lw.Position),
        "positions_shape": list(last.shape),
        "positions_dtype": str(last.dtype),
        "positions_finite": finite,
        "bbox_min_m": lo.tolist(),
        "bbox_max_m": hi.tolist(),
        "max_displacement_m": float(np.linalg.norm(last.astype(np.float64) - first, axis=1).max()),
        "stats": stats,
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"{summary['frames']} frames, sequence {summary['sequence_first']}..{summary['sequence_last']} "
              f"({summary['frames_dropped']} dropped), node count {summary['node_counts']}, "
              f"positions finite: {finite}, bounding box {np.round(lo, 4).tolist()} .. {np.round(hi, 4).tolist()} m")
        if stats is not None:
            print(f"core: {stats['ticks']} ticks, {stats['misses']} missed, compute p99 "
                  f"{stats['compute_p99_us']:.1f} us, wake-up lateness p99 {stats['lateness_p99_us']:.1f} us")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:  # Ctrl-C: stop without a traceback
        sys.exit(130)
