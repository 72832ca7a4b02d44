"""Lamina's iceoryx2 wire contract for Python clients, on the official `iceoryx2` package.

The one Python mirror of the Rust crate `lamina-bridge`. It mirrors three parts of that
crate; a change there must be made here too (the workspace test `python_wire_layout`
compares every structure's size, alignment and field offsets with the Rust types):

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
        "of another release may refuse to open (pip install ./python)",
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
MAX_SURFACES = 8
SURFACE_NAME_LEN = 32
MODEL_NAME_LEN = 64
VOLUME_PATH_LEN = 256
TISSUES = {0: "other", 1: "skin", 2: "fat", 3: "muscle", 4: "bone"}
"""Tissue codes of `WireLayer.tissue` and `WireSurface.tissue`."""


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
    """One layer in the topology header: name, node range, tissue code. Springs and nodes
    name their layer by its index in the table."""

    _fields_ = [
        ("name", ctypes.c_uint8 * LAYER_NAME_LEN),  # UTF-8, NUL padded
        ("first_node", ctypes.c_uint32),
        ("node_count", ctypes.c_uint32),  # 0 for a layer without nodes
        ("tissue", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaWireLayerV2"


class WireSurface(ctypes.Structure):
    """One named surface; its node indices are in the payload's surface section."""

    _fields_ = [
        ("name", ctypes.c_uint8 * SURFACE_NAME_LEN),
        ("tissue", ctypes.c_uint32),  # tissue just beneath the surface
        ("grid_cols", ctypes.c_uint32),  # 0: a triangle list
        ("grid_rows", ctypes.c_uint32),
        ("index_count", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaWireSurfaceV1"


class WireTool(ctypes.Structure):
    """The scene's tool and the device-to-model mapping:
    model = device_origin_m + position_scale * R @ device; device force = force_scale * R.T @ f."""

    _fields_ = [
        ("source", ctypes.c_uint32),  # 0 none, 1 scripted in the core, 2 haptics process
        ("reserved", ctypes.c_uint32),
        ("radius_m", ctypes.c_double),
        ("min_radius_m", ctypes.c_double),
        ("stiffness_n_per_m", ctypes.c_double),
        ("device_origin_m", ctypes.c_double * 3),
        ("device_rotation", (ctypes.c_double * 3) * 3),  # row-major R
        ("position_scale", ctypes.c_double),
        ("force_scale", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaWireToolV1"


class WireVolume(ctypes.Structure):
    """The scene's volume texture (empty path: the viewer's procedural volume)."""

    _fields_ = [
        ("path", ctypes.c_uint8 * VOLUME_PATH_LEN),
        ("origin_m", ctypes.c_double * 3),  # used when flags bit 0 is set
        ("window", ctypes.c_double * 2),  # used when flags bit 1 is set
        ("flags", ctypes.c_uint32),
        ("reserved", ctypes.c_uint32),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaWireVolumeV1"


class TopologyHeader(ctypes.Structure):
    """User header of the `topology` service; the payload is `u32` words in seven sections:
    triangles (3 per), 2D texture coordinates (2 per node, f32 bits), surface indices,
    springs (2 per), spring layers (1 per spring), node layers (1 per node), rest positions
    (3 per node, f32 bits). See `decode_topology`."""

    _fields_ = [
        ("revision", ctypes.c_uint64),
        ("node_count", ctypes.c_uint32),
        ("triangle_count", ctypes.c_uint32),
        ("tex_coord_count", ctypes.c_uint32),
        ("layer_count", ctypes.c_uint32),
        ("surface_count", ctypes.c_uint32),
        ("spring_count", ctypes.c_uint32),
        ("node_layer_count", ctypes.c_uint32),
        ("rest_position_count", ctypes.c_uint32),
        ("model_name", ctypes.c_uint8 * MODEL_NAME_LEN),
        ("layers", WireLayer * MAX_LAYERS),
        ("surfaces", WireSurface * MAX_SURFACES),
        ("tool", WireTool),
        ("volume", WireVolume),
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaTopologyHeaderV2"

    def surface_index_words(self) -> int:
        return sum(int(s.index_count) for s in self.surfaces[: min(int(self.surface_count), MAX_SURFACES)])

    def word_count(self) -> int:
        """Payload words this header describes."""
        return (
            3 * self.triangle_count
            + 2 * self.tex_coord_count
            + self.surface_index_words()
            + 3 * self.spring_count
            + self.node_layer_count
            + 3 * self.rest_position_count
        )


# Tool kinds: `ToolCommand.kind` (bridge/src/wire.rs `ToolKind`).
TOOL_SPHERE = 0
TOOL_SCALPEL = 1
TOOL_KINDS = {TOOL_SPHERE: "sphere", TOOL_SCALPEL: "scalpel"}


class ToolCommand(ctypes.Structure):
    """Haptic tool pose and kind (client -> core). The newest command wins; commands older
    than the scene's `timeout_ms` (default 100 ms) park the tool. The scalpel's cutting edge
    runs from the tip at `position` along the tool's local +y axis rotated by `orientation`,
    `blade_length_m` long (0: the scene's)."""

    _fields_ = [
        ("sequence", ctypes.c_uint64),
        ("time_ns", ctypes.c_uint64),  # CLOCK_MONOTONIC when the device was sampled
        ("position", ctypes.c_double * 3),  # sphere centre or scalpel tip, model frame, m
        ("orientation", ctypes.c_double * 4),  # unit quaternion [x, y, z, w]
        ("buttons", ctypes.c_uint32),  # bit 0 held: the sphere grasps
        ("kind", ctypes.c_uint32),  # TOOL_SPHERE or TOOL_SCALPEL; other codes are refused
        ("tool_radius_m", ctypes.c_double),  # 0: the scene's radius
        ("blade_length_m", ctypes.c_double),  # scalpel edge length; 0: the scene's
    ]

    @staticmethod
    def type_name() -> str:
        return "LaminaToolCommandV2"


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


# The byte sizes of the Rust types (bridge/tests/settings.rs checks the same figures; the
# workspace test `python_wire_layout` checks every field's offset too).
WIRE_SIZES = {
    Position: 12,
    NodesHeader: 40,
    WireLayer: 48,
    WireSurface: 48,
    WireTool: 144,
    WireVolume: 304,
    TopologyHeader: 1704,
    ToolCommand: 96,
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
    """`<prefix>/nodes`: `[[f32; 3]]` positions with a `NodesHeader`, every tick (every
    `node_frame_every` ticks when the scene says so; a tick already late leaves its frame to
    the next, and the header's `tick` says which tick a frame follows)."""
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
    words = h.word_count()
    if words == 0:
        return np.zeros(0, dtype=np.uint32)
    view = np.ctypeslib.as_array((ctypes.c_uint32 * words).from_address(sample.payload().as_ptr()))
    return view.copy()


def _text(field) -> str:
    return bytes(field).split(b"\0", 1)[0].decode("utf-8", "replace")


def decode_topology(sample) -> dict:
    """The topology as plain Python and numpy: the model's name and node count, outer
    triangles `(T, 3)`, 2D texture coordinates `(N, 2)`, surfaces (grids for Bézier patches,
    or triangles), springs `(S, 2)` with their layer, each node's layer, rest positions
    `(N, 3)` in metres, layers with their tissue, the tool and device mapping, the volume."""
    h = sample.user_header().contents
    words = topology_words(sample)
    at = 0

    def take(n: int) -> np.ndarray:
        nonlocal at
        out = words[at : at + n]
        at += n
        return out

    triangles = take(3 * h.triangle_count).reshape(-1, 3)
    tex_coords = take(2 * h.tex_coord_count).view(np.float32).reshape(-1, 2)
    surfaces = []
    for s in h.surfaces[: min(int(h.surface_count), MAX_SURFACES)]:
        indices = take(int(s.index_count))
        grid = (int(s.grid_cols), int(s.grid_rows)) if s.grid_cols else None
        surfaces.append(
            {
                "name": _text(s.name),
                "tissue": TISSUES.get(int(s.tissue), "other"),
                "grid": grid,
                "nodes": indices.reshape(grid[1], grid[0]) if grid else indices.reshape(-1, 3),
            }
        )
    springs = take(2 * h.spring_count).reshape(-1, 2)
    spring_layer = take(h.spring_count)
    node_layer = take(h.node_layer_count)
    rest_positions = take(3 * h.rest_position_count).view(np.float32).reshape(-1, 3)
    layers = [
        {
            "name": _text(layer.name),
            "tissue": TISSUES.get(int(layer.tissue), "other"),
            "first_node": int(layer.first_node),
            "node_count": int(layer.node_count),
        }
        for layer in h.layers[: min(int(h.layer_count), MAX_LAYERS)]
    ]
    t = h.tool
    tool = {
        "source": {0: "none", 1: "scripted", 2: "haptics"}.get(int(t.source), "unknown"),
        "radius_m": float(t.radius_m),
        "min_radius_m": float(t.min_radius_m),
        "stiffness_n_per_m": float(t.stiffness_n_per_m),
        "device_origin_m": np.array(t.device_origin_m[:], dtype=np.float64),
        "device_rotation": np.array([row[:] for row in t.device_rotation], dtype=np.float64),
        "position_scale": float(t.position_scale),
        "force_scale": float(t.force_scale),
    }
    v = h.volume
    volume = {
        "path": _text(v.path),
        "origin_m": list(v.origin_m) if v.flags & 1 else None,
        "window": list(v.window) if v.flags & 2 else None,
    }
    return {
        "revision": int(h.revision),
        "name": _text(h.model_name),
        "node_count": int(h.node_count),
        "triangles": triangles,
        "tex_coords": tex_coords,
        "surfaces": surfaces,
        "springs": springs,
        "spring_layer": spring_layer,
        "node_layer": node_layer,
        "rest_positions": rest_positions,
        "layers": layers,
        "tool": tool,
        "volume": volume,
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
