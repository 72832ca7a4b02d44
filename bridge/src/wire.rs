//! The wire layout: every type that crosses a process boundary, and nothing else.
//!
//! All types are `#[repr(C)]`, `Copy`, hold no pointers and derive
//! [`ZeroCopySend`](iceoryx2::prelude::ZeroCopySend), so they live directly in iceoryx2 shared
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

/// The user header of every frame on the `nodes` service; the payload is the positions slice.
///
/// Payload: `[[f32; 3]]`, `node_count` entries, node `i`'s position `[x, y, z]` in metres in
/// the model frame. Published by the core every tick.
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

/// One layer's node range and name as carried in [`TopologyHeader::layers`].
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaWireLayerV1")]
pub struct WireLayer {
    /// UTF-8 name, padded with NUL bytes to [`LAYER_NAME_LEN`]; contains no NUL itself.
    pub name: [u8; LAYER_NAME_LEN],
    /// Index of the layer's first node.
    pub first_node: u32,
    /// Number of consecutive nodes belonging to the layer.
    pub node_count: u32,
}

/// The user header of the `topology` service: the static model for late joiners.
///
/// Payload: `[u32]` words, in this order:
/// 1. `3 * triangle_count` node indices, three per surface triangle (counter-clockwise seen
///    from outside);
/// 2. `2 * tex_coord_count` texture coordinates `(u, v)` stored as `f32::to_bits`, one pair
///    per node (`tex_coord_count` is 0 or `node_count`).
///
/// Use [`crate::topology::Topology`] to build and read it: it validates both directions.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaTopologyHeaderV1")]
pub struct TopologyHeader {
    /// Incremented by the publisher each time the topology is republished (model reloaded).
    pub revision: u64,
    /// Number of nodes in the model (and in every `nodes` frame).
    pub node_count: u32,
    /// Number of surface triangles in the payload.
    pub triangle_count: u32,
    /// Number of texture coordinate pairs in the payload (0 or `node_count`).
    pub tex_coord_count: u32,
    /// Number of valid entries at the start of `layers` (at most [`MAX_LAYERS`]).
    pub layer_count: u32,
    /// Layer table; entries at `layer_count..` are zero.
    pub layers: [WireLayer; MAX_LAYERS],
}

impl TopologyHeader {
    /// Number of `u32` payload words this header describes.
    pub fn word_count(&self) -> usize {
        3 * self.triangle_count as usize + 2 * self.tex_coord_count as usize
    }
}

/// Haptic tool pose and buttons (haptics → core), sent at the device rate. Newest wins.
#[derive(Debug, Clone, Copy, PartialEq, ZeroCopySend)]
#[repr(C)]
#[type_name("LaminaToolCommandV1")]
pub struct ToolCommand {
    /// Counter of the sending haptics process, +1 per command.
    pub sequence: u64,
    /// `CLOCK_MONOTONIC` when the device was sampled, nanoseconds.
    pub time_ns: u64,
    /// Tool tip position in the model frame, metres.
    pub position: [f64; 3],
    /// Tool orientation as a unit quaternion `[x, y, z, w]` (identity `[0, 0, 0, 1]`).
    pub orientation: [f64; 4],
    /// Button bit set: bit `i` set means button `i` is pressed.
    pub buttons: u32,
    /// Always zero (explicit padding).
    pub reserved: u32,
    /// Radius of the spherical tool tip, metres; 0 uses the scene's. The core raises a radius
    /// below the scene's `effects.tool.min_radius` to it (its skin contact is sampled for it).
    pub tool_radius_m: f64,
}

impl Default for ToolCommand {
    /// At the origin, identity orientation, no buttons, radius 0.
    fn default() -> Self {
        Self {
            sequence: 0,
            time_ns: 0,
            position: [0.0; 3],
            orientation: [0.0, 0.0, 0.0, 1.0],
            buttons: 0,
            reserved: 0,
            tool_radius_m: 0.0,
        }
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
