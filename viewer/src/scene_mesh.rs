//! One frame's geometry as the renderer uploads it: lit triangle vertices, line vertices and
//! what the tessellation produced. [`crate::mesh_build`] fills it; [`crate::cut`] adds the cut
//! faces; [`crate::render`] draws it.

use bytemuck::{Pod, Zeroable};

/// A vertex of a lit triangle, as the shader reads it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct LitVertex {
    /// Position, metres, model frame.
    pub position: [f32; 3],
    /// Normal (any orientation: lighting is two-sided).
    pub normal: [f32; 3],
    /// Linear RGB and specular strength.
    pub color: [f32; 4],
    /// Blinn-Phong exponent, and 1 if the cut plane removes this vertex's side, else 0.
    pub params: [f32; 2],
    /// 3D texture coordinate: the point's rest position, metres, model frame (interpolated
    /// like the position), and 1 in `w` if the volume texture applies (tissue), else 0 (tool).
    pub rest: [f32; 4],
}

/// A vertex of a line (springs, outlines).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct LineVertex {
    /// Position, metres.
    pub position: [f32; 3],
    /// Linear RGBA (alpha-blended).
    pub color: [f32; 4],
}

/// Counts that describe one tessellation.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MeshStats {
    /// Bézier patches evaluated.
    pub patches: usize,
    /// Triangles produced in total.
    pub triangles: usize,
    /// Line segments produced.
    pub lines: usize,
    /// Largest `n` and `m` of any patch (before conforming).
    pub max_counts: (u32, u32),
    /// Mean of `n · m` over the patches (before conforming).
    pub mean_quads_per_patch: f32,
}

/// One frame's geometry, ready for upload.
#[derive(Debug, Clone, Default)]
pub struct SceneMesh {
    /// Lit triangle vertices.
    pub vertices: Vec<LitVertex>,
    /// Triangle list indices into `vertices`.
    pub indices: Vec<u32>,
    /// Line list vertices (pairs).
    pub lines: Vec<LineVertex>,
    /// What was built.
    pub stats: MeshStats,
}

impl SceneMesh {
    /// Empties the buffers, keeping their capacity.
    pub(crate) fn clear(&mut self) {
        self.vertices.clear();
        self.indices.clear();
        self.lines.clear();
        self.stats = MeshStats::default();
    }
}
