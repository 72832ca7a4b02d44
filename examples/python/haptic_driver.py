#!/usr/bin/env python3
"""Presses Lamina's haptic tool into the skin step by step and prints force against depth.

Stands in for `lamina-haptics`: sends `ToolCommand`s on `<prefix>/tool` and reads the core's
`ContactFeedback` on `<prefix>/feedback`. Needs a scene whose tool follows the haptics process
(the built-in default scene's does).

Where to press: the top of the skin at mid-length, found in the first node frame: among the
nodes within 1 mm of the highest one (Lamina's scenes have y up), the one closest to the middle
of the model in x and z. Depth 0 puts the sphere (radius `--radius`) on that node; depth d
puts its centre d metres lower. Each depth is held for `--hold` seconds while commands go out
at `--rate` Hz; the force is the mean of the feedback over the second half of the hold (the
skin has settled). Then the tool is lifted 2 cm clear.

    lamina run --prefix demo &
    python3 examples/python/haptic_driver.py --prefix demo
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np

from lamina import wire as lw


def touch_point(x: np.ndarray) -> tuple[int, np.ndarray]:
    """The node to press on: top of the model (max y) nearest its middle in x and z."""
    top = x[:, 1].max()
    candidates = np.flatnonzero(x[:, 1] >= top - 1e-3)
    mid = (x.min(axis=0) + x.max(axis=0)) / 2
    d = (x[candidates, 0] - mid[0]) ** 2 + (x[candidates, 2] - mid[2]) ** 2
    i = int(candidates[np.argmin(d)])
    return i, x[i].astype(np.float64)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--prefix", default=lw.DEFAULT_PREFIX, help="Lamina's service prefix (default: lamina)")
    parser.add_argument("--radius", type=float, default=0.012, help="sphere radius, m (default: 0.012, the "
                        "default scene's; the core raises a smaller one to the scene's min_radius)")
    parser.add_argument("--from-depth", type=float, default=-0.003, help="first depth, m (default: -0.003)")
    parser.add_argument("--to-depth", type=float, default=0.008, help="last depth, m (default: 0.008)")
    parser.add_argument("--step", type=float, default=0.001, help="depth step, m (default: 0.001)")
    parser.add_argument("--hold", type=float, default=0.4, help="seconds per depth (default: 0.4)")
    parser.add_argument("--rate", type=float, default=500.0, help="commands per second (default: 500)")
    parser.add_argument("--timeout", type=float, default=10.0, help="seconds to wait for the core (default: 10)")
    parser.add_argument("--json", action="store_true", help="print one JSON summary instead of a table")
    args = parser.parse_args()
    values = (args.radius, args.from_depth, args.to_depth, args.step, args.hold, args.rate, args.timeout)
    if not all(math.isfinite(v) for v in values):
        parser.error("every number must be finite")
    if not (0 < args.radius < 1 and args.step > 0 and args.hold > 0 and args.rate > 0 and args.timeout > 0):
        parser.error("--radius must lie in (0, 1) m; --step, --hold, --rate and --timeout must be positive")
    if args.to_depth < args.from_depth or (args.to_depth - args.from_depth) / args.step > 10_000:
        parser.error("--to-depth must not be below --from-depth, with at most 10,000 steps between them")

    node = lw.open_node("lamina_py_haptic_driver")
    nodes_sub = lw.nodes_service(node, args.prefix).subscriber_builder().create()
    tool_pub = lw.tool_service(node, args.prefix).publisher_builder().create()
    feedback_sub = lw.feedback_service(node, args.prefix).subscriber_builder().create()

    sample = lw.receive_until(nodes_sub, args.timeout)
    if sample is None:
        print(f"error: no node frame on '{args.prefix}/nodes' within {args.timeout} s: is `lamina run "
              f"--prefix {args.prefix}` running as this user?", file=sys.stderr)
        return 2
    x = lw.positions(sample)
    sample.delete()
    nodes_sub.delete()  # positions are not needed any more; do not keep the core's frames queued
    touch_node, touch = touch_point(x)

    sequence = 0
    period = 1.0 / args.rate

    def send(centre: np.ndarray) -> None:
        nonlocal sequence
        cmd = lw.ToolCommand()
        cmd.sequence = sequence
        cmd.time_ns = time.monotonic_ns()
        cmd.position[:] = [float(c) for c in centre]
        cmd.orientation[:] = [0.0, 0.0, 0.0, 1.0]
        cmd.kind = lw.TOOL_SPHERE
        cmd.tool_radius_m = args.radius
        tool_pub.send_copy(cmd)
        sequence += 1

    feedback_seq: list[int] = []

    def hold(centre: np.ndarray, seconds: float) -> list:
        """Sends `centre` for `seconds`; returns the feedback of the second half."""
        start = time.monotonic()
        kept = []
        next_send = start
        while True:
            now = time.monotonic()
            if now - start >= seconds:
                return kept
            if now >= next_send:
                send(centre)
                next_send += period
            while (s := feedback_sub.receive()) is not None:
                fb = s.payload().contents
                feedback_seq.append(int(fb.sequence))
                if now - start >= seconds / 2:
                    kept.append((int(fb.in_contact), np.array(fb.force[:], dtype=np.float64)))
                s.delete()
            time.sleep(min(period, 0.001) / 2)

    above = touch + np.array([0.0, args.radius + 0.02, 0.0])
    if not hold(above, 0.3):
        print(f"error: no contact feedback on '{args.prefix}/feedback': does the scene's tool follow the "
              "haptics process ([effects.tool] source = \"haptics\")?", file=sys.stderr)
        return 2

    n = int(round((args.to_depth - args.from_depth) / args.step)) + 1
    steps = []
    for k in range(n):
        depth = args.from_depth + k * args.step
        centre = touch + np.array([0.0, args.radius - depth, 0.0])
        kept = hold(centre, args.hold)
        if not kept:
            print(f"error: the core stopped sending feedback at depth {depth * 1e3:.1f} mm", file=sys.stderr)
            return 2
        force = np.mean([f for _, f in kept], axis=0)
        steps.append({
            "depth_m": depth,
            "force_n": force.tolist(),
            "force_up_n": float(force[1]),
            "force_magnitude_n": float(np.linalg.norm(force)),
            "in_contact": float(np.mean([c for c, _ in kept])),
            "samples": len(kept),
        })
        if not args.json:
            if k == 0:
                print(f"pressing on node {touch_node} at {np.round(touch, 4).tolist()} m with a "
                      f"{args.radius * 1e3:.1f} mm sphere\n  depth mm   force up N   |F| N   in contact")
            print(f"  {depth * 1e3:8.2f}   {force[1]:10.4f}  {np.linalg.norm(force):7.4f}   "
                  f"{steps[-1]['in_contact']:.2f}")
    hold(above, 0.2)

    fseq = np.array(feedback_seq, dtype=np.int64)
    summary = {
        "prefix": args.prefix,
        "touch_node": touch_node,
        "touch_point_m": touch.tolist(),
        "radius_m": args.radius,
        "commands_sent": sequence,
        "feedback_received": len(feedback_seq),
        "feedback_sequence_increasing": bool((np.diff(fseq) > 0).all()),
        "steps": steps,
    }
    if args.json:
        print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt:  # Ctrl-C: stop without a traceback
        sys.exit(130)
