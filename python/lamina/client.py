"""A small client of a running Lamina core: topology and node frames as numpy arrays, a
sphere tool command, contact feedback.

    import lamina

    with lamina.Core("lamina", timeout_s=10.0) as core:
        topo = core.topology                 # dict of numpy arrays, see `wire.decode_topology`
        frame = core.newest_nodes()          # NodeFrame: header fields and (N, 3) float32, m
        core.send_sphere(topo["tool"]["device_origin_m"])
        fb = core.newest_feedback()          # Feedback: force (N), stiffness (N/m), x_ref (m)

Units are SI (m, s, N, N/m); time stamps are `CLOCK_MONOTONIC` nanoseconds.
"""

from __future__ import annotations

import ctypes
import math
import time
from dataclasses import dataclass

import numpy as np

from . import wire


class LaminaError(RuntimeError):
    """A core that does not answer within the timeout, or a call on a closed `Core`."""


@dataclass(frozen=True)
class NodeFrame:
    """One `nodes` frame: the header's fields and a copy of the positions."""

    sequence: int
    """+1 per frame from 0; a gap means the subscriber's 16-frame buffer dropped frames."""
    tick: int
    """Physics tick the frame was taken after (not equal to `sequence` in general)."""
    sim_time_s: float
    """Simulated time, s."""
    publish_time_ns: int
    """`CLOCK_MONOTONIC` when the core sent the frame, ns."""
    positions: np.ndarray
    """`(N, 3)` float32 node positions, m."""


@dataclass(frozen=True)
class Feedback:
    """One `feedback` message: `F(x) = force + stiffness @ (x - x_ref)` on the tool."""

    sequence: int
    tick: int
    publish_time_ns: int
    in_contact: bool
    force: np.ndarray
    """`(3,)` force on the tool, N, model frame."""
    stiffness: np.ndarray
    """`(3, 3)` row-major dF_i/dx_j, N/m."""
    x_ref: np.ndarray
    """`(3,)` point the linear model is taken at, m."""


def _check_timeout(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number of seconds, got {value}")
    return value


def _point(name: str, value) -> tuple[float, float, float]:
    p = np.asarray(value, dtype=np.float64).reshape(-1)
    if p.shape != (3,) or not np.isfinite(p).all():
        raise ValueError(f"{name} must be 3 finite coordinates in metres, got {value!r}")
    return float(p[0]), float(p[1]), float(p[2])


def _newest(subscriber, limit: float, listener, what: str):
    """The newest queued sample (older ones are returned to the core), waiting up to `limit`
    seconds for one; `LaminaError` naming `what` when none arrives."""
    sample = wire.receive_until(subscriber, limit, listener)
    if sample is None:
        raise LaminaError(f"no {what} within {limit} s")
    while (newer := subscriber.receive()) is not None:
        sample.delete()
        sample = newer
    return sample


class Core:
    """A connection to the core serving `prefix` (`lamina run --prefix`, default `lamina`).

    Opens the user's Lamina domain and the `topology`, `nodes`, `tool` and `feedback`
    services with Lamina's settings, then waits up to `timeout_s` seconds (default 10) for
    the topology, which the core keeps for late joiners. Raises `LaminaError` when none
    arrives, `ValueError` for an empty prefix or a timeout that is not positive.
    """

    def __init__(self, prefix: str = wire.DEFAULT_PREFIX, timeout_s: float = 10.0, name: str | None = None):
        if not isinstance(prefix, str) or not prefix.strip("/"):
            raise ValueError(f"prefix must be a non-empty service prefix such as 'lamina', got {prefix!r}")
        self.prefix = prefix
        self.timeout_s = _check_timeout("timeout_s", timeout_s)
        self._node = wire.open_node(name)
        self._topology_sub = wire.topology_service(self._node, prefix).subscriber_builder().create()
        self._nodes_sub = wire.nodes_service(self._node, prefix).subscriber_builder().create()
        self._feedback_sub = wire.feedback_service(self._node, prefix).subscriber_builder().create()
        self._tool_pub = wire.tool_service(self._node, prefix).publisher_builder().create()
        self._nodes_wake = wire.wake_listener(self._node, prefix, "nodes")
        self._sequence = 0
        self._closed = False
        sample = wire.receive_until(self._topology_sub, self.timeout_s)
        if sample is None:
            self.close()
            raise LaminaError(
                f"no topology on '{prefix}/topology' within {self.timeout_s} s: is `lamina run --prefix {prefix}` "
                "running as this user, with the same LAMINA_IPC_DIR?"
            )
        self.topology = wire.decode_topology(sample)
        """The model: see `wire.decode_topology` (node count, triangles, surfaces, springs,
        layers, rest positions `(N, 3)` m, the tool and device mapping)."""
        sample.delete()

    def _open(self) -> None:
        if self._closed:
            raise LaminaError(f"the connection to '{self.prefix}' is closed")

    def newest_nodes(self, timeout_s: float | None = None) -> NodeFrame:
        """The newest node frame: drains the queue and returns its last frame, waiting up to
        `timeout_s` (default: the connection's timeout) when none is queued."""
        self._open()
        limit = self.timeout_s if timeout_s is None else _check_timeout("timeout_s", timeout_s)
        sample = _newest(self._nodes_sub, limit, self._nodes_wake, f"node frame on '{self.prefix}/nodes'")
        h = sample.user_header().contents
        frame = NodeFrame(
            sequence=int(h.sequence),
            tick=int(h.tick),
            sim_time_s=float(h.sim_time_s),
            publish_time_ns=int(h.publish_time_ns),
            positions=wire.positions(sample),
        )
        sample.delete()
        return frame

    def send_sphere(self, position_m, radius_m: float = 0.0, grasp: bool = False) -> int:
        """Sends one tool command: the sphere's centre `position_m` (3 coordinates, model
        frame, m), its radius (0, the default: the scene's), the grasp button. Returns the
        command's sequence number. The core parks the tool when commands stop for the scene's
        `timeout_ms` (default 100 ms): send at the device's rate."""
        radius = float(radius_m)
        if not (math.isfinite(radius) and radius >= 0):
            raise ValueError(f"radius_m must be 0 (the scene's radius) or a positive finite radius in m, got {radius}")
        return self._send_tool(wire.TOOL_SPHERE, position_m, (0.0, 0.0, 0.0, 1.0), 1 if grasp else 0, radius, 0.0)

    def send_scalpel(self, tip_m, orientation=(0.0, 0.0, 0.0, 1.0), blade_length_m: float = 0.0) -> int:
        """Sends one scalpel command: the blade's tip `tip_m` (3 coordinates, model frame, m),
        the tool's orientation (unit quaternion `[x, y, z, w]`; the identity, the default,
        holds the cutting edge straight up, +y, from the tip) and the edge's length (0, the
        default: the scene's). The blade cuts what its edge sweeps between two core ticks.
        Returns the command's sequence number."""
        q = [float(c) for c in orientation]
        if len(q) != 4 or not all(math.isfinite(c) for c in q) or sum(c * c for c in q) == 0.0:
            raise ValueError(f"orientation must be 4 finite numbers [x, y, z, w], not all 0, got {orientation!r}")
        length = float(blade_length_m)
        if not (math.isfinite(length) and 0 <= length < 1):
            raise ValueError(f"blade_length_m must be 0 (the scene's) or a finite length below 1 m, got {length}")
        return self._send_tool(wire.TOOL_SCALPEL, tip_m, q, 0, 0.0, length)

    def _send_tool(self, kind: int, position_m, orientation, buttons: int, radius: float, blade: float) -> int:
        self._open()
        x = _point("position_m" if kind == wire.TOOL_SPHERE else "tip_m", position_m)
        cmd = wire.ToolCommand(
            sequence=self._sequence,
            time_ns=time.clock_gettime_ns(time.CLOCK_MONOTONIC),
            position=(ctypes.c_double * 3)(*x),
            orientation=(ctypes.c_double * 4)(*orientation),
            buttons=buttons,
            kind=kind,
            tool_radius_m=radius,
            blade_length_m=blade,
        )
        self._tool_pub.send_copy(cmd)
        self._sequence += 1
        return cmd.sequence

    def newest_feedback(self, timeout_s: float | None = None) -> Feedback:
        """The newest contact feedback (the core sends one every tick while a tool is
        active), waiting up to `timeout_s` (default: the connection's timeout)."""
        self._open()
        limit = self.timeout_s if timeout_s is None else _check_timeout("timeout_s", timeout_s)
        sample = _newest(self._feedback_sub, limit, None, f"contact feedback on '{self.prefix}/feedback'")
        f = sample.payload().contents
        out = Feedback(
            sequence=int(f.sequence),
            tick=int(f.tick),
            publish_time_ns=int(f.publish_time_ns),
            in_contact=bool(f.in_contact),
            force=np.array(f.force[:], dtype=np.float64),
            stiffness=np.array([row[:] for row in f.stiffness], dtype=np.float64),
            x_ref=np.array(f.x_ref[:], dtype=np.float64),
        )
        sample.delete()
        return out

    def close(self) -> None:
        """Releases the ports and the node (also on leaving a `with` block)."""
        if self._closed:
            return
        self._closed = True
        for attr in ("_nodes_wake", "_tool_pub", "_feedback_sub", "_nodes_sub", "_topology_sub"):
            port = getattr(self, attr)
            if hasattr(port, "delete"):
                port.delete()
        if hasattr(self._node, "delete"):
            self._node.delete()

    def __enter__(self) -> "Core":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
