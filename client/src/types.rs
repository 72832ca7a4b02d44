//! The types of the C ABI: the status code every call returns, the handle, and the plain
//! structs the calls fill in. All are `#[repr(C)]` and hold no pointers.

use core::ffi::c_char;

/// Bytes of a name field in `LaminaLayerInfo` and `LaminaSurfaceInfo`: the wire's 32
/// bytes of UTF-8 and a terminating NUL.
pub const LAMINA_NAME_LEN: usize = 33;

/// Bytes of `LaminaTopologyInfo::model_name`: the wire's 64 bytes of UTF-8 and a
/// terminating NUL.
pub const LAMINA_MODEL_NAME_LEN: usize = 65;

/// The version of this ABI: the layout of every struct and the meaning of every call. A
/// program compares `lamina_abi_version` with the value of the header it was
/// compiled with.
pub const LAMINA_ABI_VERSION: u32 = 2;

/// A connection to one Lamina core, as `lamina_open` gives it. 0 is never a valid
/// handle. A handle is used on the thread that opened it; after `lamina_close` it is
/// refused with `LAMINA_STATUS_BAD_HANDLE`.
pub type LaminaClient = u64;

/// What a call did. Every call but the text getters returns one; on anything but
/// `LAMINA_STATUS_OK`, `lamina_last_error_message()` says what went wrong, naming the
/// argument, the value and the bound.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(i32)]
pub enum LaminaStatus {
    /// The call did what it says.
    Ok = 0,
    /// A pointer argument was NULL.
    NullPointer = 1,
    /// An argument is out of its range (a non-finite position, an index past the table, a
    /// prefix that is not UTF-8) or misaligned.
    InvalidArgument = 2,
    /// The handle is 0, was never opened, or is closed.
    BadHandle = 3,
    /// The handle belongs to another thread (the iceoryx2 ports behind it are not thread-safe).
    WrongThread = 4,
    /// The iceoryx2 node or a service could not be opened (the user's domain, a service
    /// created with other settings, too many ports).
    Connect = 5,
    /// Nothing arrived within the timeout: no core on the prefix yet, or no frame or feedback.
    Timeout = 6,
    /// The core that published node frames is gone (stopped or killed). Open again to wait
    /// for the next one.
    CoreGone = 7,
    /// The core sent something this client cannot read: another model (node count differs
    /// from the topology's), a topology that does not decode.
    Protocol = 8,
    /// The caller's buffer is too small; the message names the size needed.
    BufferTooSmall = 9,
    /// The scene's tool does not follow tool commands (no tool, or a scripted one).
    NoTool = 10,
    /// iceoryx2 refused to receive or send.
    Ipc = 11,
    /// An internal error (a Rust panic) was caught at the boundary; please report it.
    Panic = 12,
}

/// The scene's haptic tool and the device-to-model mapping, from the topology.
///
/// A device position `p` (m; x toward the operator, y right, z up, origin at the device's
/// workspace centre) is the model position `device_origin_m + position_scale · R · p`; a model
/// force `f` is the device force `force_scale · Rᵀ · f`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct LaminaToolInfo {
    /// 0: the scene has no tool; 1: a script inside the core moves it; 2: it follows tool
    /// commands (this library's `lamina_send_*` calls, or `lamina-haptics`).
    pub source: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
    /// Sphere radius, m (a command radius of 0 uses this one).
    pub radius_m: f64,
    /// Smallest radius a command may give, m; the core raises smaller ones to it.
    pub min_radius_m: f64,
    /// Penalty stiffness per node in contact, N/m.
    pub stiffness_n_per_m: f64,
    /// Model position of the device's workspace centre, m.
    pub device_origin_m: [f64; 3],
    /// Rotation `R` from device to model axes, row-major: `model_i = Σ_j R[3 i + j] device_j`.
    pub device_rotation: [f64; 9],
    /// Model metres per device metre.
    pub position_scale: f64,
    /// Device newtons per model newton.
    pub force_scale: f64,
}

/// The model's counts and its tool, from the core's topology.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct LaminaTopologyInfo {
    /// The topology's revision (0 for a core's one topology).
    pub revision: u64,
    /// Nodes in the model, and in every node frame.
    pub node_count: u32,
    /// Outer-surface triangles (`lamina_triangles`).
    pub triangle_count: u32,
    /// Entries of the layer table (`lamina_layer_info`), at most 16.
    pub layer_count: u32,
    /// Entries of the surface table (`lamina_surface_info`), at most 8.
    pub surface_count: u32,
    /// Springs of the model.
    pub spring_count: u32,
    /// Rest positions (`lamina_rest_positions`): 0 or `node_count`.
    pub rest_position_count: u32,
    /// The scene's tool and the device mapping.
    pub tool: LaminaToolInfo,
    /// Model name, UTF-8, NUL-terminated.
    pub model_name: [c_char; LAMINA_MODEL_NAME_LEN],
}

impl Default for LaminaTopologyInfo {
    fn default() -> Self {
        Self {
            revision: 0,
            node_count: 0,
            triangle_count: 0,
            layer_count: 0,
            surface_count: 0,
            spring_count: 0,
            rest_position_count: 0,
            tool: LaminaToolInfo::default(),
            model_name: [0; LAMINA_MODEL_NAME_LEN],
        }
    }
}

/// One layer of the model. Tissue codes: 0 other, 1 skin, 2 fat, 3 muscle, 4 bone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(C)]
pub struct LaminaLayerInfo {
    /// Index of the layer's first node (0 when it has none).
    pub first_node: u32,
    /// Nodes from `first_node` on (0 for a layer with springs but no nodes of its own).
    pub node_count: u32,
    /// Tissue code.
    pub tissue: u32,
    /// Layer name (`skin`, `fat`, `muscle`, `bone`, ...), UTF-8, NUL-terminated.
    pub name: [c_char; LAMINA_NAME_LEN],
}

impl Default for LaminaLayerInfo {
    fn default() -> Self {
        Self { first_node: 0, node_count: 0, tissue: 0, name: [0; LAMINA_NAME_LEN] }
    }
}

/// One named surface of the model: a regular grid of nodes, or a triangle list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(C)]
pub struct LaminaSurfaceInfo {
    /// Tissue code of the tissue just beneath the surface.
    pub tissue: u32,
    /// Grid points around the limb (a closed tube repeats its first column as its last);
    /// 0 for a triangle list.
    pub grid_cols: u32,
    /// Grid points along the limb; 0 for a triangle list.
    pub grid_rows: u32,
    /// Node indices of the surface (`lamina_surface_indices`): `grid_cols · grid_rows`
    /// row-major, or three per triangle.
    pub index_count: u32,
    /// Surface name (`skin_outer`, `skin_fat`, ...), UTF-8, NUL-terminated.
    pub name: [c_char; LAMINA_NAME_LEN],
}

impl Default for LaminaSurfaceInfo {
    fn default() -> Self {
        Self { tissue: 0, grid_cols: 0, grid_rows: 0, index_count: 0, name: [0; LAMINA_NAME_LEN] }
    }
}

/// The header of one node frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct LaminaFrameInfo {
    /// The core's frame counter: +1 per frame it publishes, from 0. A gap: frames this client
    /// did not take in time (16 are queued). Not the tick: with `node_frame_every` or late
    /// ticks, ticks and frames differ.
    pub sequence: u64,
    /// The core tick the frame was taken after.
    pub tick: u64,
    /// Simulated time at the frame, s.
    pub sim_time_s: f64,
    /// `CLOCK_MONOTONIC` when the core sent it, ns.
    pub publish_time_ns: u64,
    /// Positions in the frame (equals the topology's `node_count`).
    pub node_count: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
}

/// `LaminaToolCommand::kind` of the sphere: it presses the skin, and grasps while button 0
/// is held.
pub const LAMINA_TOOL_SPHERE: u32 = 0;

/// `LaminaToolCommand::kind` of the scalpel: its cutting edge runs from the tip along the
/// tool's local +y axis, rotated by the orientation, for the blade length, and cuts what the
/// edge sweeps between two core ticks.
pub const LAMINA_TOOL_SCALPEL: u32 = 1;

/// A tool command: which tool, and where it goes, in the model frame.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C)]
pub struct LaminaToolCommand {
    /// Sphere centre or scalpel tip, model frame, m; each coordinate finite and below 1000 m
    /// in magnitude.
    pub position: [f64; 3],
    /// Orientation as a unit quaternion `[x, y, z, w]`, model frame (identity `[0, 0, 0, 1]`;
    /// the sphere does not use it, the scalpel's edge is the tool's +y axis turned by it).
    pub orientation: [f64; 4],
    /// Sphere radius, m, `0 <= r < 1`; 0 uses the scene's.
    pub radius_m: f64,
    /// Buttons: bit 0 held grasps the nodes near the sphere; the other bits are not used.
    pub buttons: u32,
    /// The tool: `LAMINA_TOOL_SPHERE` (0) or `LAMINA_TOOL_SCALPEL` (1); others are refused.
    pub kind: u32,
    /// Length of the scalpel's cutting edge, m, `0 <= l < 1`; 0 uses the scene's. The sphere
    /// does not use it.
    pub blade_length_m: f64,
}

impl Default for LaminaToolCommand {
    /// The sphere at the origin, identity orientation, radius and blade length 0.
    fn default() -> Self {
        Self {
            position: [0.0; 3],
            orientation: [0.0, 0.0, 0.0, 1.0],
            radius_m: 0.0,
            buttons: 0,
            kind: LAMINA_TOOL_SPHERE,
            blade_length_m: 0.0,
        }
    }
}

/// The contact force and its local linear model: `F(x) = force + stiffness · (x − x_ref)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
#[repr(C)]
pub struct LaminaFeedback {
    /// The core's feedback counter, +1 per message.
    pub sequence: u64,
    /// The core tick this feedback was computed at.
    pub tick: u64,
    /// `CLOCK_MONOTONIC` when the core sent it, ns.
    pub publish_time_ns: u64,
    /// 1 when the tool touches the tissue; 0: `force` and `stiffness` are zero (also while
    /// the core has parked the tool: no good command for the scene's `timeout_ms`).
    pub in_contact: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
    /// Force on the tool at `x_ref`, N, model frame.
    pub force: [f64; 3],
    /// `∂F/∂x` at `x_ref`, N/m, row-major: `stiffness[3 i + j] = ∂F_i/∂x_j`.
    pub stiffness: [f64; 9],
    /// Tool centre the model was linearised at, m.
    pub x_ref: [f64; 3],
}
