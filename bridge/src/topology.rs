//! The static model description sent once to every process, and its lossless wire conversion.
//!
//! [`Topology`] is the Rust-side twin of [`TopologyHeader`] + `[u32]` payload (layout in
//! [`TopologyHeader`]). It is the single source of the model for the other processes: the
//! viewer draws the tissue boundaries as Bézier patches from its surface grids, the wireframe
//! from its springs, each tissue in its own material, and samples the volume texture at the
//! nodes' rest positions; the haptics process takes the tool radius and the device-to-model
//! mapping from it. [`Topology::encode`] and [`Topology::decode`] validate every count, index
//! and value, so a malformed frame becomes an error, never a panic or an out-of-range index
//! later.
//!
//! # Examples
//!
//! ```
//! use lamina_bridge::topology::{LayerRange, SurfaceTopology, TissueKind, Topology};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let topo = Topology {
//!     name: "one triangle".into(),
//!     node_count: 3,
//!     triangles: vec![[0, 1, 2]],
//!     layers: vec![LayerRange { name: "skin".into(), tissue: TissueKind::Skin, first_node: 0, node_count: 3 }],
//!     surfaces: vec![SurfaceTopology {
//!         name: "skin_outer".into(),
//!         tissue: TissueKind::Skin,
//!         grid: None,
//!         indices: vec![0, 1, 2],
//!     }],
//!     springs: vec![[0, 1], [1, 2], [2, 0]],
//!     spring_layer: vec![0, 0, 0],
//!     node_layer: vec![0, 0, 0],
//!     rest_positions: vec![[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]],
//!     ..Topology::default()
//! };
//! let (header, words) = topo.encode()?;
//! assert_eq!(Topology::decode(&header, &words)?, topo);
//! # Ok(())
//! # }
//! ```

use crate::wire::{
    LAYER_NAME_LEN, MAX_LAYERS, MAX_SURFACES, MODEL_NAME_LEN, SURFACE_NAME_LEN, TopologyHeader, VOLUME_PATH_LEN,
    WireLayer, WireSurface, WireTool, WireVolume, tissue_code,
};

/// The tissue a layer or surface stands for, as the wire names it ([`tissue_code`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum TissueKind {
    /// Anything else.
    #[default]
    Other,
    /// Skin.
    Skin,
    /// Subcutaneous fat.
    Fat,
    /// Skeletal muscle.
    Muscle,
    /// Bone.
    Bone,
}

impl TissueKind {
    /// The wire code ([`tissue_code`]).
    pub fn code(self) -> u32 {
        match self {
            Self::Other => tissue_code::OTHER,
            Self::Skin => tissue_code::SKIN,
            Self::Fat => tissue_code::FAT,
            Self::Muscle => tissue_code::MUSCLE,
            Self::Bone => tissue_code::BONE,
        }
    }

    /// The tissue of a wire code; `None` for an unknown code.
    pub fn from_code(code: u32) -> Option<Self> {
        Some(match code {
            tissue_code::OTHER => Self::Other,
            tissue_code::SKIN => Self::Skin,
            tissue_code::FAT => Self::Fat,
            tissue_code::MUSCLE => Self::Muscle,
            tissue_code::BONE => Self::Bone,
            _ => return None,
        })
    }
}

/// One tissue layer: its name, tissue and node range. Nodes and springs name their layer by
/// its index in [`Topology::layers`].
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LayerRange {
    /// Layer name, UTF-8, at most [`LAYER_NAME_LEN`] bytes, no NUL characters.
    pub name: String,
    /// The tissue the layer models.
    pub tissue: TissueKind,
    /// Index of the first node of the layer (0 when it has none).
    pub first_node: u32,
    /// Nodes from `first_node` to the layer's last node (0 when it has none).
    pub node_count: u32,
}

/// One named surface: a regular grid of nodes (the tissue boundaries the viewer re-patches
/// with Bézier patches) or a triangle list.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct SurfaceTopology {
    /// Surface name, UTF-8, at most [`SURFACE_NAME_LEN`] bytes, no NUL characters.
    pub name: String,
    /// Tissue just beneath the surface.
    pub tissue: TissueKind,
    /// `Some((columns, rows))` for a grid (a closed tube repeats its first column as its
    /// last), `None` for triangles.
    pub grid: Option<(u32, u32)>,
    /// Grid points row-major (`columns * rows`), or three node indices per triangle.
    pub indices: Vec<u32>,
}

/// Everything about the model that renderers and tools need; see the module documentation.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Topology {
    /// Model name, UTF-8, at most [`MODEL_NAME_LEN`] bytes, no NUL characters.
    pub name: String,
    /// Number of nodes (the length of every `nodes` frame).
    pub node_count: u32,
    /// Outer-surface triangles as node index triples, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Layers, at most [`MAX_LAYERS`].
    pub layers: Vec<LayerRange>,
    /// Texture coordinates `(u, v)` per node (dimensionless): empty, or `node_count` entries.
    pub tex_coords: Vec<[f32; 2]>,
    /// Named surfaces, at most [`MAX_SURFACES`].
    pub surfaces: Vec<SurfaceTopology>,
    /// Springs as node index pairs.
    pub springs: Vec<[u32; 2]>,
    /// Layer index of each spring: empty when `springs` is, else one per spring.
    pub spring_layer: Vec<u32>,
    /// Layer index of each node: empty, or `node_count` entries.
    pub node_layer: Vec<u32>,
    /// Rest position of each node, m: empty, or `node_count` entries.
    pub rest_positions: Vec<[f32; 3]>,
    /// The scene's tool and device mapping (`source` 0: none).
    pub tool: WireTool,
    /// The scene's volume texture, when it names one or sets its placement.
    pub volume: Option<VolumeTopology>,
}

/// The scene's volume texture as carried on the wire ([`WireVolume`]).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct VolumeTopology {
    /// Absolute path of the NRRD or NIfTI file; empty: the viewer's procedural volume.
    pub path: String,
    /// Model position of the volume's origin, m; `None`: the file header's.
    pub origin_m: Option<[f64; 3]>,
    /// Intensity window `[low, high]`; `None`: the data's minimum and maximum.
    pub window: Option<[f64; 2]>,
}

impl VolumeTopology {
    /// Longest volume path the wire carries, bytes of UTF-8 ([`VOLUME_PATH_LEN`]).
    pub const MAX_PATH_BYTES: usize = VOLUME_PATH_LEN;

    /// Checks that `path` fits the wire: at most [`Self::MAX_PATH_BYTES`] bytes, no NUL. A
    /// core calls it when it loads a scene, so a path that could not be published is refused
    /// there, naming the file and the limit.
    ///
    /// # Errors
    /// [`VolumePathError`] with the path, its length and the limit.
    pub fn check_path(path: &str) -> Result<(), VolumePathError> {
        if path.len() > Self::MAX_PATH_BYTES || path.contains('\0') {
            return Err(VolumePathError { path: path.to_owned(), bytes: path.len() });
        }
        Ok(())
    }
}

/// A volume path the wire cannot carry ([`VolumeTopology::check_path`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "visual.volume {path:?}: {bytes} bytes; a volume path published to the viewer may have at most {} bytes and no NUL \
     (give the file a shorter path)",
    VolumeTopology::MAX_PATH_BYTES
)]
pub struct VolumePathError {
    /// The path.
    pub path: String,
    /// Its length, bytes.
    pub bytes: usize,
}

/// Why a [`Topology`] cannot be put on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TopologyEncodeError {
    /// More than [`MAX_LAYERS`] layers.
    #[error("cannot encode topology: more layers than the wire can carry")]
    TooManyLayers,
    /// More than [`MAX_SURFACES`] surfaces.
    #[error("cannot encode topology: more surfaces than the wire can carry")]
    TooManySurfaces,
    /// A layer name is longer than [`LAYER_NAME_LEN`] bytes or contains a NUL character.
    #[error("cannot encode topology: layer name too long or contains NUL")]
    InvalidLayerName,
    /// A surface name or the model name is too long or contains NUL.
    #[error("cannot encode topology: surface name or model name too long or contains NUL")]
    InvalidName,
    /// The volume path is longer than [`VolumeTopology::MAX_PATH_BYTES`] or contains NUL.
    #[error(
        "cannot encode topology: the volume path (visual.volume) is {bytes} bytes; the wire carries at most {} \
         and no NUL",
        VolumeTopology::MAX_PATH_BYTES
    )]
    VolumePath {
        /// The path's length, bytes.
        bytes: usize,
    },
    /// A layer's node range reaches past `node_count`.
    #[error("cannot encode topology: layer node range exceeds node count")]
    LayerOutOfRange,
    /// A triangle refers to a node index `>= node_count`.
    #[error("cannot encode topology: triangle refers to a node beyond node count")]
    TriangleIndexOutOfRange,
    /// A surface or spring refers to a node index `>= node_count`.
    #[error("cannot encode topology: a surface or spring refers to a node beyond node count")]
    NodeIndexOutOfRange,
    /// A grid's index count is not `columns * rows`, or a triangle surface's not a multiple of 3.
    #[error("cannot encode topology: a surface's index count does not match its grid or triangles")]
    SurfaceShapeMismatch,
    /// A spring or node names a layer beyond the layer table.
    #[error("cannot encode topology: a spring or node names a layer beyond the layer table")]
    LayerIndexOutOfRange,
    /// `tex_coords`, `node_layer` or `rest_positions` is neither empty nor `node_count` long,
    /// or `spring_layer` is not one per spring.
    #[error("cannot encode topology: a per-node or per-spring table has the wrong length")]
    TexCoordCountMismatch,
    /// A tool, volume or rest-position value is NaN or infinite.
    #[error("cannot encode topology: a tool, volume or rest-position value is not finite")]
    NonFinite,
    /// A count does not fit the `u32` wire fields.
    #[error("cannot encode topology: a count does not fit in u32")]
    TooManyTriangles,
}

/// Why a wire topology frame is not a valid [`Topology`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TopologyDecodeError {
    /// `layer_count` exceeds [`MAX_LAYERS`] or `surface_count` [`MAX_SURFACES`].
    #[error("cannot decode topology: layer or surface count exceeds its table")]
    TooManyLayers,
    /// A layer or surface name, the model name or the volume path is not UTF-8.
    #[error("cannot decode topology: a name is not UTF-8")]
    InvalidLayerName,
    /// A layer's node range reaches past `node_count`.
    #[error("cannot decode topology: layer node range exceeds node count")]
    LayerOutOfRange,
    /// A triangle, surface or spring refers to a node index `>= node_count`.
    #[error("cannot decode topology: triangle refers to a node beyond node count")]
    TriangleIndexOutOfRange,
    /// A grid's index count is not `columns * rows`, or a triangle surface's not a multiple of 3.
    #[error("cannot decode topology: a surface's index count does not match its grid or triangles")]
    SurfaceShapeMismatch,
    /// A spring or node names a layer beyond `layer_count`.
    #[error("cannot decode topology: a spring or node names a layer beyond the layer table")]
    LayerIndexOutOfRange,
    /// A tissue code is unknown.
    #[error("cannot decode topology: unknown tissue code")]
    UnknownTissue,
    /// `tex_coord_count`, `node_layer_count` or `rest_position_count` is neither 0 nor
    /// `node_count`.
    #[error("cannot decode topology: texture coordinates are neither empty nor one per node")]
    TexCoordCountMismatch,
    /// A tool, volume or rest-position value is NaN or infinite.
    #[error("cannot decode topology: a tool, volume or rest-position value is not finite")]
    NonFinite,
    /// The payload length differs from what the header describes.
    #[error("cannot decode topology: payload length differs from the header")]
    PayloadLengthMismatch,
}

fn range_ok(first: u32, count: u32, node_count: u32) -> bool {
    u64::from(first) + u64::from(count) <= u64::from(node_count)
}

fn count_u32(n: usize) -> Result<u32, TopologyEncodeError> {
    u32::try_from(n).map_err(|_| TopologyEncodeError::TooManyTriangles)
}

/// Copies `text` into a NUL-padded field, or `None` if too long or containing NUL.
fn put_name<const N: usize>(text: &str) -> Option<[u8; N]> {
    let bytes = text.as_bytes();
    if bytes.len() > N || bytes.contains(&0) {
        return None;
    }
    let mut out = [0u8; N];
    out[..bytes.len()].copy_from_slice(bytes);
    Some(out)
}

/// The text of a NUL-padded field, or `None` if not UTF-8.
fn get_name(field: &[u8]) -> Option<String> {
    let len = field.iter().position(|&b| b == 0).unwrap_or(field.len());
    core::str::from_utf8(&field[..len]).ok().map(str::to_owned)
}

fn tool_is_finite(t: &WireTool) -> bool {
    let scalars = [t.radius_m, t.min_radius_m, t.stiffness_n_per_m, t.position_scale, t.force_scale];
    scalars.iter().chain(&t.device_origin_m).chain(t.device_rotation.iter().flatten()).all(|v| v.is_finite())
}

/// Number of payload sections; see [`TopologyHeader`].
const SECTIONS: usize = 7;

impl Topology {
    /// Word counts of the payload's sections, in order.
    fn section_words(&self) -> [usize; SECTIONS] {
        [
            3 * self.triangles.len(),
            2 * self.tex_coords.len(),
            self.surfaces.iter().map(|s| s.indices.len()).sum(),
            2 * self.springs.len(),
            self.spring_layer.len(),
            self.node_layer.len(),
            3 * self.rest_positions.len(),
        ]
    }

    /// Number of `u32` payload words [`Topology::encode`] produces.
    pub fn word_count(&self) -> usize {
        self.section_words().iter().sum()
    }

    /// The wire header alone (revision 0), after validation.
    pub fn header(&self) -> Result<TopologyHeader, TopologyEncodeError> {
        use TopologyEncodeError as E;
        let n = self.node_count;
        if self.layers.len() > MAX_LAYERS {
            return Err(E::TooManyLayers);
        }
        if self.surfaces.len() > MAX_SURFACES {
            return Err(E::TooManySurfaces);
        }
        let per_node_ok = |len: usize| len == 0 || len == n as usize;
        if !per_node_ok(self.tex_coords.len())
            || !per_node_ok(self.node_layer.len())
            || !per_node_ok(self.rest_positions.len())
            || self.spring_layer.len() != self.springs.len()
        {
            return Err(E::TexCoordCountMismatch);
        }
        if self.triangles.iter().flatten().any(|&i| i >= n) {
            return Err(E::TriangleIndexOutOfRange);
        }
        let surface_nodes = self.surfaces.iter().flat_map(|s| s.indices.iter());
        if surface_nodes.chain(self.springs.iter().flatten()).any(|&i| i >= n) {
            return Err(E::NodeIndexOutOfRange);
        }
        let layer_count = self.layers.len() as u32;
        if self.spring_layer.iter().chain(&self.node_layer).any(|&l| l >= layer_count) {
            return Err(E::LayerIndexOutOfRange);
        }
        if self.rest_positions.iter().flatten().any(|v| !v.is_finite()) || !tool_is_finite(&self.tool) {
            return Err(E::NonFinite);
        }
        let mut layers = [WireLayer::default(); MAX_LAYERS];
        for (wire, layer) in layers.iter_mut().zip(&self.layers) {
            wire.name = put_name::<LAYER_NAME_LEN>(&layer.name).ok_or(E::InvalidLayerName)?;
            if !range_ok(layer.first_node, layer.node_count, n) {
                return Err(E::LayerOutOfRange);
            }
            wire.first_node = layer.first_node;
            wire.node_count = layer.node_count;
            wire.tissue = layer.tissue.code();
        }
        let mut surfaces = [WireSurface::default(); MAX_SURFACES];
        for (wire, surface) in surfaces.iter_mut().zip(&self.surfaces) {
            wire.name = put_name::<SURFACE_NAME_LEN>(&surface.name).ok_or(E::InvalidName)?;
            wire.tissue = surface.tissue.code();
            wire.index_count = count_u32(surface.indices.len())?;
            match surface.grid {
                Some((cols, rows)) => {
                    if u64::from(cols) * u64::from(rows) != surface.indices.len() as u64 || cols < 2 || rows < 2 {
                        return Err(E::SurfaceShapeMismatch);
                    }
                    (wire.grid_cols, wire.grid_rows) = (cols, rows);
                }
                None if surface.indices.len() % 3 != 0 => return Err(E::SurfaceShapeMismatch),
                None => {}
            }
        }
        let volume = match &self.volume {
            None => WireVolume::default(),
            Some(v) => {
                let values = v.origin_m.iter().flatten().chain(v.window.iter().flatten());
                if values.clone().any(|x| !x.is_finite()) {
                    return Err(E::NonFinite);
                }
                WireVolume {
                    path: put_name::<VOLUME_PATH_LEN>(&v.path).ok_or(E::VolumePath { bytes: v.path.len() })?,
                    origin_m: v.origin_m.unwrap_or_default(),
                    window: v.window.unwrap_or_default(),
                    flags: u32::from(v.origin_m.is_some()) | (u32::from(v.window.is_some()) << 1),
                    reserved: 0,
                }
            }
        };
        let words = self.word_count();
        count_u32(words)?;
        let per_node = |len: usize| if len == 0 { 0 } else { n };
        Ok(TopologyHeader {
            revision: 0,
            node_count: n,
            triangle_count: count_u32(self.triangles.len())?,
            tex_coord_count: per_node(self.tex_coords.len()),
            layer_count,
            surface_count: self.surfaces.len() as u32,
            spring_count: count_u32(self.springs.len())?,
            node_layer_count: per_node(self.node_layer.len()),
            rest_position_count: per_node(self.rest_positions.len()),
            model_name: put_name::<MODEL_NAME_LEN>(&self.name).ok_or(E::InvalidName)?,
            layers,
            surfaces,
            tool: self.tool,
            volume,
        })
    }

    /// Payload word `i` of the encoding (see [`TopologyHeader`]); 0 past the end.
    pub fn word(&self, i: usize) -> u32 {
        let mut j = i;
        for (section, len) in self.section_words().into_iter().enumerate() {
            if j >= len {
                j -= len;
                continue;
            }
            return match section {
                0 => self.triangles[j / 3][j % 3],
                1 => self.tex_coords[j / 2][j % 2].to_bits(),
                2 => {
                    for s in &self.surfaces {
                        if j < s.indices.len() {
                            return s.indices[j];
                        }
                        j -= s.indices.len();
                    }
                    0
                }
                3 => self.springs[j / 2][j % 2],
                4 => self.spring_layer[j],
                5 => self.node_layer[j],
                _ => self.rest_positions[j / 3][j % 3].to_bits(),
            };
        }
        0
    }

    /// Validates and converts to the wire: header (revision 0) and payload words.
    pub fn encode(&self) -> Result<(TopologyHeader, Vec<u32>), TopologyEncodeError> {
        let header = self.header()?;
        let mut words = Vec::with_capacity(self.word_count());
        words.extend(self.triangles.iter().flatten());
        words.extend(self.tex_coords.iter().flatten().map(|v| v.to_bits()));
        words.extend(self.surfaces.iter().flat_map(|s| s.indices.iter()));
        words.extend(self.springs.iter().flatten());
        words.extend(&self.spring_layer);
        words.extend(&self.node_layer);
        words.extend(self.rest_positions.iter().flatten().map(|v| v.to_bits()));
        Ok((header, words))
    }

    /// Validates a wire frame and converts it back; the exact inverse of [`Topology::encode`].
    pub fn decode(header: &TopologyHeader, words: &[u32]) -> Result<Self, TopologyDecodeError> {
        use TopologyDecodeError as E;
        let n = header.node_count;
        let (layer_count, surface_count) = (header.layer_count as usize, header.surface_count as usize);
        if layer_count > MAX_LAYERS || surface_count > MAX_SURFACES {
            return Err(E::TooManyLayers);
        }
        let per_node_ok = |count: u32| count == 0 || count == n;
        if !per_node_ok(header.tex_coord_count)
            || !per_node_ok(header.node_layer_count)
            || !per_node_ok(header.rest_position_count)
        {
            return Err(E::TexCoordCountMismatch);
        }
        if words.len() != header.word_count() {
            return Err(E::PayloadLengthMismatch);
        }
        let mut rest = words;
        let mut take = |len: usize| {
            let (head, tail) = rest.split_at(len);
            rest = tail;
            head
        };
        let tri_words = take(3 * header.triangle_count as usize);
        let uv_words = take(2 * header.tex_coord_count as usize);
        let surface_words = take(header.surface_index_words());
        let spring_words = take(2 * header.spring_count as usize);
        let spring_layer = take(header.spring_count as usize);
        let node_layer = take(header.node_layer_count as usize);
        let rest_words = take(3 * header.rest_position_count as usize);
        if tri_words.iter().chain(surface_words).chain(spring_words).any(|&i| i >= n) {
            return Err(E::TriangleIndexOutOfRange);
        }
        if spring_layer.iter().chain(node_layer).any(|&l| l as usize >= layer_count) {
            return Err(E::LayerIndexOutOfRange);
        }
        let rest_positions: Vec<[f32; 3]> =
            rest_words.chunks_exact(3).map(|p| [0, 1, 2].map(|k| f32::from_bits(p[k]))).collect();
        if rest_positions.iter().flatten().any(|v| !v.is_finite()) || !tool_is_finite(&header.tool) {
            return Err(E::NonFinite);
        }
        let mut layers = Vec::with_capacity(layer_count);
        for wire in &header.layers[..layer_count] {
            if !range_ok(wire.first_node, wire.node_count, n) {
                return Err(E::LayerOutOfRange);
            }
            layers.push(LayerRange {
                name: get_name(&wire.name).ok_or(E::InvalidLayerName)?,
                tissue: TissueKind::from_code(wire.tissue).ok_or(E::UnknownTissue)?,
                first_node: wire.first_node,
                node_count: wire.node_count,
            });
        }
        let mut surfaces = Vec::with_capacity(surface_count);
        let mut surface_words = surface_words;
        for wire in &header.surfaces[..surface_count] {
            let (indices, tail) = surface_words.split_at(wire.index_count as usize);
            surface_words = tail;
            let grid = (wire.grid_cols != 0 || wire.grid_rows != 0).then_some((wire.grid_cols, wire.grid_rows));
            let shape_ok = match grid {
                Some((c, r)) => c >= 2 && r >= 2 && u64::from(c) * u64::from(r) == indices.len() as u64,
                None => indices.len() % 3 == 0,
            };
            if !shape_ok {
                return Err(E::SurfaceShapeMismatch);
            }
            surfaces.push(SurfaceTopology {
                name: get_name(&wire.name).ok_or(E::InvalidLayerName)?,
                tissue: TissueKind::from_code(wire.tissue).ok_or(E::UnknownTissue)?,
                grid,
                indices: indices.to_vec(),
            });
        }
        let v = &header.volume;
        let path = get_name(&v.path).ok_or(E::InvalidLayerName)?;
        let volume = (!path.is_empty() || v.flags & 3 != 0).then(|| VolumeTopology {
            path,
            origin_m: (v.flags & 1 != 0).then_some(v.origin_m),
            window: (v.flags & 2 != 0).then_some(v.window),
        });
        if v.origin_m.iter().chain(&v.window).any(|x| !x.is_finite()) {
            return Err(E::NonFinite);
        }
        Ok(Self {
            name: get_name(&header.model_name).ok_or(E::InvalidLayerName)?,
            node_count: n,
            triangles: tri_words.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
            layers,
            tex_coords: uv_words.chunks_exact(2).map(|uv| [f32::from_bits(uv[0]), f32::from_bits(uv[1])]).collect(),
            surfaces,
            springs: spring_words.chunks_exact(2).map(|s| [s[0], s[1]]).collect(),
            spring_layer: spring_layer.to_vec(),
            node_layer: node_layer.to_vec(),
            rest_positions,
            tool: header.tool,
            volume,
        })
    }
}
