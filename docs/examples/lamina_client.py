#!/usr/bin/env python3
"""A Lamina client in Python on the `lamina` package (`pip install ./python`).

The package brings the iceoryx2 package 0.10.0 from PyPI, the same iceoryx2 release as
Lamina, and declares the wire types of docs/wire-protocol.md. Against a running core
(`lamina run --prefix lamina`):

    python3 lamina_client.py --prefix lamina --seconds 3           # topology, frames, stats
    python3 lamina_client.py --prefix lamina --seconds 3 --press   # also drives the tool

With --press it also sends tool commands (the scene must have a haptics tool, as the default
scene does): the tool starts at the device origin the topology carries (the scene's
effects.tool.device_origin; --origin overrides it), goes 8 mm down along -y over one second,
holds, and the client prints the contact force it gets back.
"""

import argparse
import ctypes
import sys
import time

import iceoryx2 as iox2

from lamina import wire as lw


def now_ns():
    """The wire's clock: CLOCK_MONOTONIC, ns."""
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--prefix", default="lamina")
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--press", action="store_true", help="drive the tool: press 8 mm along -y and hold")
    ap.add_argument("--origin", help="tool start, m, x,y,z (default: the topology's device origin)")
    args = ap.parse_args()
    p = args.prefix
    # The node lives in this user's Lamina domain; every service is opened (or created, when
    # the client starts first) with Lamina's settings (docs/wire-protocol.md).
    node = lw.open_node()
    topology_sub = lw.topology_service(node, p).subscriber_builder().create()
    nodes_sub = lw.nodes_service(node, p).subscriber_builder().create()
    stats_sub = lw.stats_service(node, p).subscriber_builder().create()
    nodes_listener = lw.wake_listener(node, p, "nodes")
    tool_pub = feedback_sub = None
    if args.press:
        tool_pub = lw.tool_service(node, p).publisher_builder().create()
        feedback_sub = lw.feedback_service(node, p).subscriber_builder().create()
    origin = [float(v) for v in args.origin.split(",")] if args.origin else None
    press_start = None

    first_tick = last_seq = last_frame = None
    frames, gaps, stats_seen, commands, feedbacks = 0, 0, 0, 0, 0
    last_feedback = None
    node_count = None
    start = now_ns()
    end = start + int(args.seconds * 1e9)
    while now_ns() < end:
        # Topology: the history sample arrives within a second of subscribing.
        sample = topology_sub.receive()
        if sample is not None:
            h = sample.user_header().contents
            words = sample.payload()
            count = sample.header.number_of_elements
            assert count == h.word_count(), "payload length"
            layers = [bytes(h.layers[i].name).rstrip(b"\0").decode() for i in range(h.layer_count)]
            grids = [
                bytes(g.name).rstrip(b"\0").decode() + f" {g.grid_cols}x{g.grid_rows}"
                for g in h.surfaces[: h.surface_count]
                if g.grid_cols
            ]
            node_count = h.node_count
            if origin is None:
                origin = list(h.tool.device_origin_m)
            print(
                f"topology revision {h.revision}: {h.node_count} nodes, {h.triangle_count} triangles, "
                f"{h.tex_coord_count} texture coordinates, {h.spring_count} springs, layers {layers}, "
                f"grids {grids}, tool radius {h.tool.radius_m * 1e3:.1f} mm at device origin "
                f"({origin[0]:.4f}, {origin[1]:.4f}, {origin[2]:.4f}) m"
            )
        # Node frames: wait on the `nodes` event (the core notifies after every frame).
        nodes_listener.timed_wait(iox2.Duration.from_millis(5))
        while True:
            sample = nodes_sub.receive()
            if sample is None:
                break
            h = sample.user_header().contents
            positions = sample.payload()
            # iceoryx2's Python package 0.10.0 gives a slice's length in bytes (Slice.len(),
            # iceoryx2 issue #1533); the sample header has the element count.
            assert sample.header.number_of_elements == h.node_count, "slice length equals node_count"
            if first_tick is None:
                first_tick = (h.tick, h.sim_time_s, h.sequence)
                p0 = positions[0]
                print(
                    f"first frame: sequence {h.sequence}, tick {h.tick}, sim_time_s {h.sim_time_s:.6f}, "
                    f"{h.node_count} nodes, node 0 at ({p0.x:.4f}, {p0.y:.4f}, {p0.z:.4f}) m, "
                    f"latency {(now_ns() - h.publish_time_ns) / 1e3:.0f} us"
                )
            if last_seq is not None and h.sequence != last_seq + 1:
                gaps += 1
            last_seq = h.sequence
            last_frame = (h.sequence, h.tick, h.sim_time_s)
            frames += 1
        sample = stats_sub.receive()
        if sample is not None:
            s = sample.payload().contents
            stats_seen += 1
            print(
                f"stats {s.sequence}: ticks {s.ticks}, misses {s.misses}, compute p50 {s.compute.p50_ns / 1e3:.1f} us "
                f"p99 {s.compute.p99_ns / 1e3:.1f} us, period p99 {s.period.p99_ns / 1e3:.1f} us"
            )
        if tool_pub is not None and origin is not None:
            press_start = press_start or now_ns()
            t = (now_ns() - press_start) / 1e9
            depth = min(t, 1.0) * 0.008
            cmd = lw.ToolCommand(
                sequence=commands,
                time_ns=now_ns(),
                position=(ctypes.c_double * 3)(origin[0], origin[1] - depth, origin[2]),
                orientation=(ctypes.c_double * 4)(0.0, 0.0, 0.0, 1.0),
                buttons=0,
                kind=lw.TOOL_SPHERE,
                tool_radius_m=0.0,
                blade_length_m=0.0,
            )
            tool_pub.send_copy(cmd)
            commands += 1
            while True:
                sample = feedback_sub.receive()
                if sample is None:
                    break
                f = sample.payload().contents
                feedbacks += 1
                last_feedback = (f.tick, f.in_contact, list(f.force), [list(r) for r in f.stiffness], list(f.x_ref))
    if first_tick is None:
        print("no node frames: is `lamina run --prefix %s` running?" % p, file=sys.stderr)
        return 1
    seq, tick, sim = last_frame
    print(
        f"{frames} frames, last: sequence {seq}, tick {tick}, sim_time_s {sim:.6f}; "
        f"sequence gaps {gaps}; {stats_seen} stats messages; topology node count {node_count}"
    )
    if tool_pub is not None:
        print(f"{commands} tool commands sent, {feedbacks} feedback messages received")
        if last_feedback is not None:
            tick, contact, force, k, x_ref = last_feedback
            print(
                f"last feedback: tick {tick}, in_contact {contact}, force ({force[0]:.4f}, {force[1]:.4f}, "
                f"{force[2]:.4f}) N at x_ref ({x_ref[0]:.4f}, {x_ref[1]:.4f}, {x_ref[2]:.4f}) m, "
                f"stiffness yy {k[1][1]:.1f} N/m"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
