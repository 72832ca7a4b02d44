//! The wire layout: every type that crosses a process boundary, and nothing else.
//!
//! All types are `#[repr(C)]`, `Copy`, hold no pointers and derive
//! [`ZeroCopySend`], so they live directly in iceoryx2 shared
//! memory. Each carries a stable `type_name` (`Lamina...V1`) so that two builds with the same
//! layout connect, and a layout change (bump the `V`) refuses to connect instead of misreading
//! bytes. Units are SI (m, s, N, N/m); times are nanoseconds of `CLOCK_MONOTONIC`
//! ([`crate::now_ns`]), which is system-wide and so comparable across processes.
//!
//! Padding is spelled out as `reserved` fields (always zero) so that the byte layout is the
//! same for every compiler and no uninitialised bytes reach shared memory.
//!
//! # Examples
//!
//! ```
//! use lamina_bridge::wire::{ContactFeedback, NodesHeader};
//!
//! let header = NodesHeader { sequence: 7, node_count: 3, ..NodesHeader::default() };
//! assert_eq!(header.node_count, 3);
//!
//! // F(x) ≈ force + K (x - x_ref): a 100 N/m spring pulling back along z.
//! let mut fb = ContactFeedback::default();
//! fb.stiffness[2][2] = -100.0;
//! fb.x_ref = [0.0, 0.0, 0.5];
//! assert_eq!(fb.force_at([0.0, 0.0, 0.75]), [0.0, 0.0, -25.0]);
//! ```

use iceoryx2::prelude::ZeroCopySend;

/// Maximum number of layers a [`TopologyHeader`] can describe.
pub const MAX_LAYERS: usize = 16;

/// Length in bytes of a layer name on the wire (UTF-8, padded with NUL bytes).
pub const LAYER_NAME_LEN: usize = 32;

/// Maximum number of named surfaces a [`TopologyHeader`] can describe.
pub const MAX_SURFACES: usize = 8;

/// Length in bytes of a surface name on the wire (UTF-8, padded with NUL bytes).
pub const SURFACE_NAME_LEN: usize = 32;

/// Length in bytes of the model name on the wire (UTF-8, padded with NUL bytes).
pub const MODEL_NAME_LEN: usize = 64;

/// Length in bytes of the volume texture's path on the wire (UTF-8, padded with NUL bytes).
pub const VOLUME_PATH_LEN: usize = 256;

/// The user header of every frame on the `nodes` service; the payload is the positions slice.
///
/// Payload: `[[f32; 3]]`, `node_count` entries, node `i`'s position `[x, y, z]` in metres in
/// the model frame. Published by the core every tick, or every `node_frame_every` ticks when
/// the scene's `[realtime]` table sets it; a tick already past `node_frame_cutoff_us` leaves
/// its frame to the next tick on time (`tick` tells which tick a frame follows).
#[derive(Debug, Default, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaNodesHeaderV1")]
pub struct NodesHeader {
    /// Frame counter of this publisher, +1 per published frame, starting at 0. A gap means
    /// frames were dropped (by a full subscriber buffer); a reset means the core restarted.
    pub sequence: u64,
    /// Physics tick this frame was taken after (ticks since the simulation started).
    pub tick: u64,
    /// Simulated time at this frame, seconds.
    pub sim_time_s: f64,
    /// `CLOCK_MONOTONIC` at the moment of sending, nanoseconds (see [`crate::now_ns`]).
    pub publish_time_ns: u64,
    /// Number of positions in the payload (equals the slice length).
    pub node_count: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
}

/// Tissue codes used in [`WireLayer::tissue`] and [`WireSurface::tissue`].
pub mod tissue_code {
    /// Anything else (a test block, an unnamed layer).
    pub const OTHER: u32 = 0;
    /// Skin (epidermis and dermis).
    pub const SKIN: u32 = 1;
    /// Subcutaneous fat.
    pub const FAT: u32 = 2;
    /// Skeletal muscle.
    pub const MUSCLE: u32 = 3;
    /// Bone.
    pub const BONE: u32 = 4;
}

/// One layer of the model as carried in [`TopologyHeader::layers`]: its name, tissue and the
/// node range it occupies. Nodes and springs name their layer by its index in this table.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaWireLayerV2")]
pub struct WireLayer {
    /// UTF-8 name, padded with NUL bytes to [`LAYER_NAME_LEN`]; contains no NUL itself.
    pub name: [u8; LAYER_NAME_LEN],
    /// Index of the layer's first node (0 when it has none).
    pub first_node: u32,
    /// Nodes from `first_node` to the layer's last node, inclusive (0 when it has none, e.g.
    /// a muscle layer whose springs join the fat and bone nodes). Lamina's models keep each
    /// layer's nodes contiguous; the per-node layer section is exact in every case.
    pub node_count: u32,
    /// Tissue code ([`tissue_code`]).
    pub tissue: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
}

/// One named surface as carried in [`TopologyHeader::surfaces`]; its node indices are in the
/// payload's surface section, surfaces one after the other in table order.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaWireSurfaceV1")]
pub struct WireSurface {
    /// UTF-8 name, padded with NUL bytes to [`SURFACE_NAME_LEN`] (e.g. `skin_outer`,
    /// `skin_fat`, `fat_muscle`, `muscle_bone`).
    pub name: [u8; SURFACE_NAME_LEN],
    /// Tissue just beneath the surface (the outer skin surface has skin beneath), a
    /// [`tissue_code`].
    pub tissue: u32,
    /// Grid columns (around the limb) when the surface is a regular grid, else 0. A closed
    /// tube repeats its first column as its last.
    pub grid_cols: u32,
    /// Grid rows (along the limb) when the surface is a regular grid, else 0.
    pub grid_rows: u32,
    /// Node indices of this surface in the payload: `grid_cols * grid_rows` grid points
    /// row-major for a grid, else three per triangle (counter-clockwise seen from outside).
    pub index_count: u32,
}

/// The scene's haptic tool and the device-to-model mapping, as carried in
/// [`TopologyHeader::tool`]. A haptics process maps a device position `p` (m; x toward the
/// operator, y right, z up, origin at the workspace centre) to the model as
/// `device_origin_m + position_scale · R · p`, and a model force `f` back to the device as
/// `force_scale · Rᵀ · f`.
#[derive(Debug, Default, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaWireToolV1")]
pub struct WireTool {
    /// Where the tool is driven from: 0 no tool in the scene, 1 a script inside the core,
    /// 2 the haptics process over `tool`.
    pub source: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
    /// Sphere radius, m (a `ToolCommand` radius of 0 means this one).
    pub radius_m: f64,
    /// Smallest radius a command may give the sphere, m (smaller ones are raised to it).
    pub min_radius_m: f64,
    /// Penalty stiffness per node in contact, N/m.
    pub stiffness_n_per_m: f64,
    /// Model position of the device's workspace centre, m.
    pub device_origin_m: [f64; 3],
    /// Rotation `R` from device to model axes, row-major (`model_i = Σ_j R[i][j] device_j`).
    pub device_rotation: [[f64; 3]; 3],
    /// Model metres per device metre.
    pub position_scale: f64,
    /// Device newtons per model newton.
    pub force_scale: f64,
}

/// The scene's volume texture (its `[visual]` table), as carried in
/// [`TopologyHeader::volume`]. A node's 3D texture coordinate is its rest position mapped into
/// the volume's box.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaWireVolumeV1")]
pub struct WireVolume {
    /// Absolute path of the NRRD or NIfTI file, UTF-8, NUL-padded; empty: the viewer's
    /// procedural tissue volume.
    pub path: [u8; VOLUME_PATH_LEN],
    /// Model position of the volume's origin, m (used when `flags` bit 0 is set; else the
    /// file header's origin).
    pub origin_m: [f64; 3],
    /// Intensity window `[low, high]` mapped to black..white (used when `flags` bit 1 is set;
    /// else the data's minimum and maximum).
    pub window: [f64; 2],
    /// Bit 0: `origin_m` is given; bit 1: `window` is given.
    pub flags: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
}

impl Default for WireVolume {
    fn default() -> Self {
        Self { path: [0; VOLUME_PATH_LEN], origin_m: [0.0; 3], window: [0.0; 2], flags: 0, reserved: 0 }
    }
}

/// The user header of the `topology` service: the static model for late joiners, everything
/// a viewer and a haptics process need (no scene file on their side).
///
/// Payload: `[u32]` words, sections in this order (a section of count 0 is absent):
/// 1. `3 * triangle_count` node indices, three per outer-surface triangle (counter-clockwise
///    seen from outside): every surface's triangles, for clients that draw only a shell;
/// 2. `2 * tex_coord_count` 2D texture coordinates `(u, v)` stored as `f32::to_bits`, one
///    pair per node (`tex_coord_count` is 0 or `node_count`);
/// 3. the surfaces' node indices, `surfaces[i].index_count` words each, in table order;
/// 4. `2 * spring_count` node indices, two per spring;
/// 5. `spring_count` layer indices, one per spring (into `layers`);
/// 6. `node_layer_count` layer indices, one per node (0 or `node_count`);
/// 7. `3 * rest_position_count` rest positions `[x, y, z]` in metres as `f32::to_bits`, one
///    triple per node (0 or `node_count`).
///
/// Use [`crate::topology::Topology`] to build and read it: it validates both directions.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaTopologyHeaderV2")]
pub struct TopologyHeader {
    /// Incremented by the publisher each time the topology is republished (model reloaded).
    pub revision: u64,
    /// Number of nodes in the model (and in every `nodes` frame).
    pub node_count: u32,
    /// Number of outer-surface triangles in the payload's first section.
    pub triangle_count: u32,
    /// Number of texture coordinate pairs in the payload (0 or `node_count`).
    pub tex_coord_count: u32,
    /// Number of valid entries at the start of `layers` (at most [`MAX_LAYERS`]).
    pub layer_count: u32,
    /// Number of valid entries at the start of `surfaces` (at most [`MAX_SURFACES`]).
    pub surface_count: u32,
    /// Number of springs in the payload.
    pub spring_count: u32,
    /// Number of per-node layer indices in the payload (0 or `node_count`).
    pub node_layer_count: u32,
    /// Number of rest positions in the payload (0 or `node_count`).
    pub rest_position_count: u32,
    /// Model name, UTF-8, NUL-padded.
    pub model_name: [u8; MODEL_NAME_LEN],
    /// Layer table; entries at `layer_count..` are zero.
    pub layers: [WireLayer; MAX_LAYERS],
    /// Surface table; entries at `surface_count..` are zero.
    pub surfaces: [WireSurface; MAX_SURFACES],
    /// The haptic tool and device mapping.
    pub tool: WireTool,
    /// The volume texture.
    pub volume: WireVolume,
}

impl Default for TopologyHeader {
    fn default() -> Self {
        Self {
            revision: 0,
            node_count: 0,
            triangle_count: 0,
            tex_coord_count: 0,
            layer_count: 0,
            surface_count: 0,
            spring_count: 0,
            node_layer_count: 0,
            rest_position_count: 0,
            model_name: [0; MODEL_NAME_LEN],
            layers: [WireLayer::default(); MAX_LAYERS],
            surfaces: [WireSurface::default(); MAX_SURFACES],
            tool: WireTool::default(),
            volume: WireVolume::default(),
        }
    }
}

impl TopologyHeader {
    /// Number of `u32` words of the surfaces' section (saturating: a corrupt header gives a
    /// count no payload matches).
    pub fn surface_index_words(&self) -> usize {
        let n = (self.surface_count as usize).min(MAX_SURFACES);
        self.surfaces[..n].iter().fold(0usize, |acc, s| acc.saturating_add(s.index_count as usize))
    }

    /// Number of `u32` payload words this header describes (saturating).
    pub fn word_count(&self) -> usize {
        [
            3 * self.triangle_count as usize,
            2 * self.tex_coord_count as usize,
            self.surface_index_words(),
            3 * self.spring_count as usize,
            self.node_layer_count as usize,
            3 * self.rest_position_count as usize,
        ]
        .iter()
        .fold(0usize, |acc, &w| acc.saturating_add(w))
    }
}

/// What a [`ToolCommand`] drives: the value of [`ToolCommand::kind`] on the wire.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum ToolKind {
    /// The sphere tool (code 0): presses the skin, and grasps while button 0 is held.
    #[default]
    Sphere = 0,
    /// The scalpel (code 1): its cutting edge runs from the tip along the tool's local +y
    /// axis for the blade length, and cuts what the edge sweeps between two ticks.
    Scalpel = 1,
}

impl ToolKind {
    /// Every kind, in code order.
    pub const ALL: [ToolKind; 2] = [ToolKind::Sphere, ToolKind::Scalpel];

    /// The code sent in [`ToolCommand::kind`].
    pub const fn code(self) -> u32 {
        self as u32
    }

    /// The kind of wire code `code`, or the code itself when no kind has it.
    pub const fn from_code(code: u32) -> Result<Self, u32> {
        match code {
            0 => Ok(Self::Sphere),
            1 => Ok(Self::Scalpel),
            other => Err(other),
        }
    }

    /// The kind's name as the command line and trajectory files write it: `sphere`, `scalpel`.
    pub const fn name(self) -> &'static str {
        match self {
            Self::Sphere => "sphere",
            Self::Scalpel => "scalpel",
        }
    }

    /// The kind named `text`: its name (`sphere`, `scalpel`) or its code (`0`, `1`).
    pub fn parse(text: &str) -> Option<Self> {
        let text = text.trim();
        Self::ALL.into_iter().find(|k| text == k.name() || text.parse::<u32>().ok() == Some(k.code()))
    }
}

impl core::fmt::Display for ToolKind {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.name())
    }
}

/// Haptic tool pose, buttons and kind (haptics → core), sent at the device rate. Newest wins.
///
/// # Examples
///
/// ```
/// use lamina_bridge::wire::{ToolCommand, ToolKind};
///
/// let cut = ToolCommand { kind: ToolKind::Scalpel.code(), blade_length_m: 0.01, ..ToolCommand::default() };
/// assert_eq!(cut.kind(), Ok(ToolKind::Scalpel));
/// // The cutting edge with identity orientation: straight up (+y) from the tip, 10 mm long.
/// assert_eq!(cut.blade_end(0.01), [0.0, 0.01, 0.0]);
/// let odd = ToolCommand { kind: 7, ..ToolCommand::default() };
/// assert_eq!(odd.kind(), Err(7));
/// ```
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaToolCommandV2")]
pub struct ToolCommand {
    /// Counter of the sending haptics process, +1 per command.
    pub sequence: u64,
    /// `CLOCK_MONOTONIC` when the device was sampled, nanoseconds.
    pub time_ns: u64,
    /// Tool tip position in the model frame, metres: the sphere's centre, or the scalpel's
    /// tip (one end of its cutting edge).
    pub position: [f64; 3],
    /// Tool orientation as a unit quaternion `[x, y, z, w]` (identity `[0, 0, 0, 1]`), model
    /// frame. The scalpel's cutting edge is the tool's local +y axis rotated by it.
    pub orientation: [f64; 4],
    /// Button bit set: bit `i` set means button `i` is pressed.
    pub buttons: u32,
    /// The tool, a [`ToolKind`] code: 0 sphere, 1 scalpel. Read it with [`ToolCommand::kind`];
    /// the core refuses (counts and ignores) a command of any other code.
    pub kind: u32,
    /// Radius of the spherical tool tip, metres; 0 uses the scene's. The core raises a radius
    /// below the scene's `effects.tool.min_radius` to it (its skin contact is sampled for it).
    pub tool_radius_m: f64,
    /// Length of the scalpel's cutting edge, metres; 0 uses the scene's. Unused by the sphere.
    pub blade_length_m: f64,
}

impl Default for ToolCommand {
    /// A sphere at the origin, identity orientation, no buttons, radius and blade length 0.
    fn default() -> Self {
        Self {
            sequence: 0,
            time_ns: 0,
            position: [0.0; 3],
            orientation: [0.0, 0.0, 0.0, 1.0],
            buttons: 0,
            kind: ToolKind::Sphere.code(),
            tool_radius_m: 0.0,
            blade_length_m: 0.0,
        }
    }
}

impl ToolCommand {
    /// The tool this command drives, or its code when it is none Lamina knows.
    ///
    /// # Errors
    /// The unknown code (a client of a newer protocol, or a corrupt command).
    pub const fn kind(&self) -> Result<ToolKind, u32> {
        ToolKind::from_code(self.kind)
    }

    /// The far end of the scalpel's cutting edge for a blade `length_m` long (m, model frame):
    /// `position + length_m · q ŷ q*` with `q` = [`ToolCommand::orientation`] normalised (the
    /// tip itself when the quaternion has no length). The edge is the segment from
    /// [`ToolCommand::position`] to this point.
    pub fn blade_end(&self, length_m: f64) -> [f64; 3] {
        let [x, y, z, w] = self.orientation;
        let n2 = x * x + y * y + z * z + w * w;
        if n2 <= 0.0 || !n2.is_finite() {
            return self.position;
        }
        // The rotation matrix's second column, divided by |q|².
        let axis = [2.0 * (x * y - w * z) / n2, 1.0 - 2.0 * (x * x + z * z) / n2, 2.0 * (y * z + w * x) / n2];
        [0, 1, 2].map(|c| self.position[c] + length_m * axis[c])
    }
}

/// Contact force and its local linear model (core → haptics), sent every tick.
///
/// The haptics loop renders `F(x) ≈ force + stiffness · (x - x_ref)` between core ticks
/// ([`ContactFeedback::force_at`]).
#[derive(Debug, Default, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaContactFeedbackV1")]
pub struct ContactFeedback {
    /// Counter of the core's feedback publisher, +1 per message.
    pub sequence: u64,
    /// Physics tick this feedback was computed at.
    pub tick: u64,
    /// `CLOCK_MONOTONIC` at the moment of sending, nanoseconds.
    pub publish_time_ns: u64,
    /// 1 when the tool touches the tissue, 0 otherwise (then `force` and `stiffness` are 0).
    pub in_contact: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
    /// Force on the tool at `x_ref`, newtons, model frame.
    pub force: [f64; 3],
    /// `∂F/∂x` at `x_ref`, N/m, row-major (`stiffness[i][j] = ∂F_i/∂x_j`). A restoring contact
    /// has a negative semi-definite matrix.
    pub stiffness: [[f64; 3]; 3],
    /// Tool position the model was linearised at, metres.
    pub x_ref: [f64; 3],
}

impl ContactFeedback {
    /// Whether the tool touches the tissue.
    pub fn is_in_contact(&self) -> bool {
        self.in_contact != 0
    }

    /// The linear force model evaluated at tool position `x` (metres), newtons.
    pub fn force_at(&self, x: [f64; 3]) -> [f64; 3] {
        let d = [x[0] - self.x_ref[0], x[1] - self.x_ref[1], x[2] - self.x_ref[2]];
        let mut f = self.force;
        for (fi, row) in f.iter_mut().zip(self.stiffness.iter()) {
            *fi += row[0] * d[0] + row[1] * d[1] + row[2] * d[2];
        }
        f
    }
}

/// Percentiles of one measured quantity, nanoseconds.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaPercentilesV1")]
pub struct Percentiles {
    /// Median, ns.
    pub p50_ns: u64,
    /// 99th percentile, ns.
    pub p99_ns: u64,
    /// 99.9th percentile, ns.
    pub p999_ns: u64,
    /// Maximum, ns.
    pub max_ns: u64,
}

/// Deadline-monitor summary (core → all), sent once per second.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaStatsSummaryV1")]
pub struct StatsSummary {
    /// Counter of summaries, +1 per message.
    pub sequence: u64,
    /// `CLOCK_MONOTONIC` at the moment of sending, nanoseconds.
    pub publish_time_ns: u64,
    /// Ticks run since the core started.
    pub ticks: u64,
    /// Ticks that missed their frame budget since the core started.
    pub misses: u64,
    /// Wake-up lateness (actual wake-up minus deadline), ns.
    pub lateness: Percentiles,
    /// Compute time per tick, ns.
    pub compute: Percentiles,
    /// Period between consecutive tick starts, ns.
    pub period: Percentiles,
    /// Tick number of the worst tick seen: the largest lateness + compute time (0 before any).
    pub worst_tick: u64,
}

/// One field of a wire type as the compiler lays it out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FieldLayout {
    /// The field's name in the Rust type.
    pub name: &'static str,
    /// Byte offset from the start of the type.
    pub offset: usize,
    /// Size in bytes.
    pub size: usize,
}

/// The byte layout of one wire type: what a declaration in another language (Python's
/// `ctypes`, a C header, the wire documentation) must reproduce.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TypeLayout {
    /// The Rust type's name, e.g. `NodesHeader`.
    pub name: &'static str,
    /// The name iceoryx2 registers for it (`#[type_name]`), e.g. `LaminaNodesHeaderV1`.
    pub type_name: &'static str,
    /// Size in bytes.
    pub size: usize,
    /// Alignment in bytes.
    pub align: usize,
    /// Every field, in declaration order.
    pub fields: Vec<FieldLayout>,
}

fn field_size<T, F>(_get: fn(&T) -> &F) -> usize {
    core::mem::size_of::<F>()
}

macro_rules! type_layout {
    ($t:ty, [$($f:ident),+ $(,)?]) => {
        TypeLayout {
            name: stringify!($t),
            // SAFETY: `type_name` only returns the string the derive registered.
            type_name: unsafe { <$t as ZeroCopySend>::type_name() },
            size: core::mem::size_of::<$t>(),
            align: core::mem::align_of::<$t>(),
            fields: vec![$(FieldLayout {
                name: stringify!($f),
                offset: core::mem::offset_of!($t, $f),
                size: field_size(|s: &$t| &s.$f),
            }),+],
        }
    };
}

/// The layout of every wire struct (the `nodes` element `[f32; 3]` aside), in the order of
/// this module: sizes and offsets from `size_of`, `align_of` and `offset_of!`.
pub fn layouts() -> Vec<TypeLayout> {
    vec![
        type_layout!(NodesHeader, [sequence, tick, sim_time_s, publish_time_ns, node_count, reserved]),
        type_layout!(WireLayer, [name, first_node, node_count, tissue, reserved]),
        type_layout!(WireSurface, [name, tissue, grid_cols, grid_rows, index_count]),
        type_layout!(
            WireTool,
            [
                source,
                reserved,
                radius_m,
                min_radius_m,
                stiffness_n_per_m,
                device_origin_m,
                device_rotation,
                position_scale,
                force_scale
            ]
        ),
        type_layout!(WireVolume, [path, origin_m, window, flags, reserved]),
        type_layout!(
            TopologyHeader,
            [
                revision,
                node_count,
                triangle_count,
                tex_coord_count,
                layer_count,
                surface_count,
                spring_count,
                node_layer_count,
                rest_position_count,
                model_name,
                layers,
                surfaces,
                tool,
                volume
            ]
        ),
        type_layout!(
            ToolCommand,
            [sequence, time_ns, position, orientation, buttons, kind, tool_radius_m, blade_length_m]
        ),
        type_layout!(ContactFeedback, [sequence, tick, publish_time_ns, in_contact, reserved, force, stiffness, x_ref]),
        type_layout!(Percentiles, [p50_ns, p99_ns, p999_ns, max_ns]),
        type_layout!(StatsSummary, [sequence, publish_time_ns, ticks, misses, lateness, compute, period, worst_tick]),
    ]
}
