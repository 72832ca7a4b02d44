"""Lamina's iceoryx2 wire contract for Python clients, on the official `iceoryx2` package.

This module mirrors three parts of the Rust crate `lamina-bridge`; a change there must be
made here too:

* the user's iceoryx2 domain (`bridge/src/domain.rs`, `bridge/src/bridge.rs`): root directory
  `$LAMINA_IPC_DIR/`, or `<TMPDIR or /tmp>/lamina-<uid>/`, created mode 0700 and refused when
  it belongs to another user or lets other users in; file prefix `iox2_lamina_u<uid>_`.
  A client with iceoryx2's default config (`/tmp/iceoryx2/`, `iox2_`) lives in another
  domain and never sees Lamina's services;
* the service names `<prefix>/topology`, `/nodes`, `/tool`, `/feedback`, `/stats`
  (`bridge/src/bridge.rs`, default prefix `lamina`);
* every service's quality of service (`bridge/src/services.rs`): clients open or create each
  service with exactly Lamina's settings, so they may start before or after `lamina run`;
* the `#[repr(C)]` payload and header types with their type names (`bridge/src/wire.rs`).

Units are SI (m, s, N, N/m); time stamps are `CLOCK_MONOTONIC` nanoseconds, the clock of
`time.monotonic_ns()` on Linux.
"""

from __future__ import annotations

import ctypes
import importlib.metadata
import os
import stat
import sys
import time

import iceoryx2 as iox2
import numpy as np

IOX2_SERIES = "0.10."
"""The iceoryx2 release series Lamina is built with (Cargo.toml: iceoryx2 0.10)."""

try:
    _iox2_version = importlib.metadata.version("iceoryx2")
except importlib.metadata.PackageNotFoundError:  # a source build without metadata
    _iox2_version = None
if _iox2_version is not None and not _iox2_version.startswith(IOX2_SERIES):
    print(
        f"warning: iceoryx2 {_iox2_version} is installed; Lamina speaks iceoryx2 {IOX2_SERIES}x and a service "
        "of another release may refuse to open (pip install -r examples/python/requirements.txt)",
        file=sys.stderr,
    )

DEFAULT_PREFIX = "lamina"
"""Lamina's default service prefix (`lamina run --prefix`)."""

IPC_DIR_ENV = "LAMINA_IPC_DIR"
"""Environment variable naming the domain directory instead of `/tmp/lamina-<uid>`."""

# ---------------------------------------------------------------------------------------------
# Quality of service: bridge/src/services.rs
# ---------------------------------------------------------------------------------------------
MAX_SUBSCRIBERS = 8
MAX_PUBLISHERS = 2
MAX_SERVICE_NODES = 20
MAX_BORROWED_SAMPLES = 2
NODES_BUFFER_SIZE = 16
TOPOLOGY_BUFFER_SIZE = 1
TOOL_BUFFER_SIZE = 4
FEEDBACK_BUFFER_SIZE = 8
STATS_BUFFER_SIZE = 4
HISTORY_SIZE = 1
# The wake-up event services (same names as the data services), notified after every sample.
MAX_LISTENERS = 16
MAX_NOTIFIERS = 4

# ---------------------------------------------------------------------------------------------
# Wire types: bridge/src/wire.rs (type names must match the Rust `#[type_name]`s)
# ---------------------------------------------------------------------------------------------
MAX_LAYERS = 16
LAYER_NAME_LEN = 32


class Position(ctypes.Structure):
    """One node position `[x, y, z]`, metres: the element of the `nodes` payload slice.

    Rust's element type is `[f32; 3]`; iceoryx2 names it with `core::any::type_name`.
    """

    _fields_ = [("x", ctypes.c_float), ("y", ctypes.c_float), ("z", ctypes.c_float)]

    @staticmethod
    def type_name() -> str:
        return "[f32; 3]"


class NodesHeader(ctypes.Structure):
    """User header of every `nodes` frame."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),  # +1 per frame from 0; a gap means dropped frames
        ("tick", ctypes.c_uint64),  # physics tick the frame was taken after
        ("sim_time_s", ctypes.c_double),  # simulated time, s
        ("publish_time_ns", ctypes.c_uint64),  # CLOCK_MONOTONIC at sending, ns
        ("node_count", ctypes.c_uint32),  # positions in the payload
        ("reserved", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaNodesHeaderV1"


class WireLayer(ctypes.Structure):
    """One layer's name and node range in the topology header."""

    _fields_ = [
        ("name", ctypes.c_uint8 * LAYER_NAME_LEN),  # UTF-8, NUL padded
        ("first_node", ctypes.c_uint32),
        ("node_count", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaWireLayerV1"


class TopologyHeader(ctypes.Structure):
    """User header of the `topology` service; the payload is `u32` words:
    `3 * triangle_count` node indices, then `2 * tex_coord_count` texture coordinates stored
    as the bits of `f32` values."""

    _fields_ = [
        ("revision", ctypes.c_uint64),
        ("node_count", ctypes.c_uint32),
        ("triangle_count", ctypes.c_uint32),
        ("tex_coord_count", ctypes.c_uint32),
        ("layer_count", ctypes.c_uint32),
        ("layers", WireLayer * MAX_LAYERS),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaTopologyHeaderV1"


class ToolCommand(ctypes.Structure):
    """Haptic tool pose (client -> core). The newest command wins; commands older than the
    scene's `timeout_ms` (default 100 ms) park the tool."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("time_ns", ctypes.c_uint64),  # CLOCK_MONOTONIC when the device was sampled
        ("position", ctypes.c_double * 3),  # sphere centre, model frame, m
        ("orientation", ctypes.c_double * 4),  # unit quaternion [x, y, z, w]
        ("buttons", ctypes.c_uint32),  # bit 0 held: grasp
        ("reserved", ctypes.c_uint32),
        ("tool_radius_m", ctypes.c_double),  # 0: the scene's radius
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaToolCommandV1"


class ContactFeedback(ctypes.Structure):
    """Contact force and its local linear model (core -> client), every tick:
    `F(x) = force + stiffness @ (x - x_ref)`."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("tick", ctypes.c_uint64),
        ("publish_time_ns", ctypes.c_uint64),
        ("in_contact", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
        ("force", ctypes.c_double * 3),  # N, on the tool, model frame
        ("stiffness", (ctypes.c_double * 3) * 3),  # N/m, row-major dF_i/dx_j
        ("x_ref", ctypes.c_double * 3),  # m
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaContactFeedbackV1"


class Percentiles(ctypes.Structure):
    _fields_ = [
        ("p50_ns", ctypes.c_uint64),
        ("p99_ns", ctypes.c_uint64),
        ("p999_ns", ctypes.c_uint64),
        ("max_ns", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaPercentilesV1"


class StatsSummary(ctypes.Structure):
    """Deadline-monitor summary (core -> all), once a second."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("publish_time_ns", ctypes.c_uint64),
        ("ticks", ctypes.c_uint64),
        ("misses", ctypes.c_uint64),
        ("lateness", Percentiles),
        ("compute", Percentiles),
        ("period", Percentiles),
        ("worst_tick", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaStatsSummaryV1"


# The byte sizes of the Rust types (bridge/tests/settings.rs checks the same figures).
WIRE_SIZES = {
    Position: 12,
    NodesHeader: 40,
    WireLayer: 40,
    TopologyHeader: 664,
    ToolCommand: 88,
    ContactFeedback: 152,
    StatsSummary: 136,
}
for _t, _size in WIRE_SIZES.items():
    assert ctypes.sizeof(_t) == _size, f"{_t.__name__}: {ctypes.sizeof(_t)} bytes, Lamina sends {_size}"


# ---------------------------------------------------------------------------------------------
# The domain: bridge/src/domain.rs
# ---------------------------------------------------------------------------------------------
class DomainError(RuntimeError):
    """The domain directory is missing, foreign or open to other users."""


def domain_root() -> str:
    """Lamina's iceoryx2 root directory for this user, ending in `/`.

    `$LAMINA_IPC_DIR` when set and not empty, else `<TMPDIR or /tmp>/lamina-<euid>` (the
    directory Rust's `std::env::temp_dir()` gives).
    """
    root = os.environ.get(IPC_DIR_ENV) or os.path.join(
        os.environ.get("TMPDIR") or "/tmp", f"lamina-{os.geteuid()}"
    )
    return root if root.endswith("/") else root + "/"


def domain_file_prefix() -> str:
    """iceoryx2's file prefix for this user's shared memory: `iox2_lamina_u<euid>_`."""
    return f"iox2_lamina_u{os.geteuid()}_"


def prepare_domain(root: str) -> None:
    """Creates the domain directory mode 0700 when missing and checks it like Lamina does: a
    real directory, owned by this user, without group or other access."""
    path = root.rstrip("/") or "/"
    try:
        os.mkdir(path, 0o700)
    except FileExistsError:
        pass
    meta = os.lstat(path)
    if not stat.S_ISDIR(meta.st_mode):
        raise DomainError(f"{path}: the iceoryx2 domain must be a directory, not a link or a file")
    if meta.st_uid != os.geteuid():
        raise DomainError(
            f"{path}: belongs to uid {meta.st_uid}, not to this user (uid {os.geteuid()}); "
            f"remove it or set {IPC_DIR_ENV}"
        )
    if meta.st_mode & 0o077:
        raise DomainError(
            f"{path}: mode {stat.S_IMODE(meta.st_mode):04o} lets other users in; "
            "the iceoryx2 domain must be 0700 (chmod 700 it)"
        )


def domain_config() -> "iox2.config.Config":
    """iceoryx2's config for Lamina's domain: iceoryx2's defaults with the root path and the
    file prefix replaced, as `Bridge::open` builds it."""
    root = domain_root()
    prepare_domain(root)
    config = iox2.config.default()
    config.global_cfg.root_path = iox2.Path.new(root)
    config.global_cfg.prefix = iox2.FileName.new(domain_file_prefix())
    return config


def open_node(name: str | None = None) -> "iox2.Node":
    """The process's iceoryx2 node in Lamina's domain (quiet: log level Error unless
    `IOX2_LOG_LEVEL` says otherwise), with dead peers cleaned up."""
    iox2.set_log_level_from_env_or(iox2.LogLevel.Error)
    builder = iox2.NodeBuilder.new().config(domain_config())
    if name:
        builder = builder.name(iox2.NodeName.new(name))
    node = builder.create(iox2.ServiceType.Ipc)
    return node


# ---------------------------------------------------------------------------------------------
# Services: bridge/src/services.rs, with exactly Lamina's QoS
# ---------------------------------------------------------------------------------------------
def _service(node, prefix: str, name: str, payload, header, buffer_size: int):
    builder = node.service_builder(iox2.ServiceName.new(f"{prefix}/{name}")).publish_subscribe(payload)
    if header is not None:
        builder = builder.user_header(header)
    return (
        builder.enable_safe_overflow(True)
        .history_size(HISTORY_SIZE)
        .subscriber_max_buffer_size(buffer_size)
        .subscriber_max_borrowed_samples(MAX_BORROWED_SAMPLES)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .max_nodes(MAX_SERVICE_NODES)
        .open_or_create()
    )


def nodes_service(node, prefix: str = DEFAULT_PREFIX):
    """`<prefix>/nodes`: `[[f32; 3]]` positions with a `NodesHeader`, every tick."""
    return _service(node, prefix, "nodes", iox2.Slice[Position], NodesHeader, NODES_BUFFER_SIZE)


def topology_service(node, prefix: str = DEFAULT_PREFIX):
    """`<prefix>/topology`: `[u32]` words with a `TopologyHeader`, kept for late joiners."""
    return _service(node, prefix, "topology", iox2.Slice[ctypes.c_uint32], TopologyHeader, TOPOLOGY_BUFFER_SIZE)


def tool_service(node, prefix: str = DEFAULT_PREFIX):
    """`<prefix>/tool`: `ToolCommand`, client -> core, newest wins."""
    return _service(node, prefix, "tool", ToolCommand, None, TOOL_BUFFER_SIZE)


def feedback_service(node, prefix: str = DEFAULT_PREFIX):
    """`<prefix>/feedback`: `ContactFeedback`, core -> client, every tick."""
    return _service(node, prefix, "feedback", ContactFeedback, None, FEEDBACK_BUFFER_SIZE)


def stats_service(node, prefix: str = DEFAULT_PREFIX):
    """`<prefix>/stats`: `StatsSummary`, core -> all, once a second."""
    return _service(node, prefix, "stats", StatsSummary, None, STATS_BUFFER_SIZE)


# ---------------------------------------------------------------------------------------------
# Reading samples
# ---------------------------------------------------------------------------------------------
def slice_elements(sample, element) -> int:
    """Number of elements in a slice sample's payload.

    iceoryx2 0.10.0's Python binding reports `payload().len()` (and `number_of_elements`) in
    BYTES for slices, not elements; this divides by the element size. Lamina's headers also
    carry the count (`NodesHeader.node_count`, `TopologyHeader.word_count()`): prefer those.
    """
    return sample.payload().len() // ctypes.sizeof(element)


def positions(sample) -> np.ndarray:
    """A copy of a `nodes` sample's positions as an `(N, 3)` float32 array, metres.

    `N` comes from the header. The copy lets the sample be dropped at once: a subscriber may
    hold only 2 samples, and the publisher gets the chunk back when the sample is deleted.
    """
    n = int(sample.user_header().contents.node_count)
    view = np.ctypeslib.as_array((ctypes.c_float * (3 * n)).from_address(sample.payload().as_ptr()))
    return view.reshape(n, 3).copy()


def topology_words(sample) -> np.ndarray:
    """A copy of a `topology` sample's payload as a `uint32` array (length from the header)."""
    h = sample.user_header().contents
    words = 3 * h.triangle_count + 2 * h.tex_coord_count
    if words == 0:
        return np.zeros(0, dtype=np.uint32)
    view = np.ctypeslib.as_array((ctypes.c_uint32 * words).from_address(sample.payload().as_ptr()))
    return view.copy()


def decode_topology(sample) -> dict:
    """The topology as plain Python: node count, triangles `(T, 3)`, layers, tex coords."""
    h = sample.user_header().contents
    words = topology_words(sample)
    t = int(h.triangle_count)
    layers = []
    for layer in h.layers[: min(int(h.layer_count), MAX_LAYERS)]:
        name = bytes(layer.name).split(b"\0", 1)[0].decode("utf-8", "replace")
        layers.append({"name": name, "first_node": int(layer.first_node), "node_count": int(layer.node_count)})
    return {
        "revision": int(h.revision),
        "node_count": int(h.node_count),
        "triangles": words[: 3 * t].reshape(t, 3),
        "tex_coords": words[3 * t :].view(np.float32).reshape(-1, 2),
        "layers": layers,
    }


def wake_listener(node, prefix: str, service: str):
    """A listener on the wake-up event of `<prefix>/<service>` (an event service of the same
    name as the data service), which Lamina's publishers notify after every sample they send.

    Opened or created with Lamina's settings (`bridge/src/services.rs`, `open_wake_service`):
    at least 16 listeners, 4 notifiers, 20 nodes. Sleeping on it instead of polling costs no
    CPU between frames; wake-up takes tens of microseconds longer than a busy poll.
    """
    event = (
        node.service_builder(iox2.ServiceName.new(f"{prefix}/{service}"))
        .event()
        .max_listeners(MAX_LISTENERS)
        .max_notifiers(MAX_NOTIFIERS)
        .max_nodes(MAX_SERVICE_NODES)
        .open_or_create()
    )
    return event.listener_builder().create()


def receive_until(subscriber, timeout_s: float, listener=None, poll_s: float = 0.0005):
    """The oldest queued sample, waiting until one arrives or `timeout_s` passes (`None`).

    With `listener` (from `wake_listener`) the wait sleeps until Lamina notifies, in slices of
    at most 10 ms: the topology reaches a late joiner without a notification. Without it, the
    subscriber is polled every `poll_s` seconds.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        sample = subscriber.receive()
        if sample is not None:
            return sample
        remaining = deadline - time.monotonic()
        if remaining <= 0:
            return None
        if listener is None:
            time.sleep(poll_s)
        else:
            listener.timed_wait(iox2.Duration.from_secs_f64(min(remaining, 0.01)))
