//! The static model description sent once to every process, and its lossless wire conversion.
//!
//! [`Topology`] is the Rust-side twin of [`TopologyHeader`] + `[u32]` payload (layout in
//! [`TopologyHeader`]). [`Topology::encode`] and [`Topology::decode`] validate every count and
//! index, so a malformed frame becomes an error, never a panic or an out-of-range index later.
//!
//! # Examples
//!
//! ```
//! use lamina_bridge::topology::{LayerRange, Topology};
//!
//! # fn main() -> Result<(), Box<dyn core::error::Error>> {
//! let topo = Topology {
//!     node_count: 3,
//!     triangles: vec![[0, 1, 2]],
//!     layers: vec![LayerRange { name: "skin".into(), first_node: 0, node_count: 3 }],
//!     tex_coords: vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]],
//! };
//! let (header, words) = topo.encode()?;
//! assert_eq!(Topology::decode(&header, &words)?, topo);
//! # Ok(())
//! # }
//! ```

use crate::wire::{LAYER_NAME_LEN, MAX_LAYERS, TopologyHeader, WireLayer};

/// A named, contiguous range of nodes forming one tissue layer.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct LayerRange {
    /// Layer name, UTF-8, at most [`LAYER_NAME_LEN`] bytes, no NUL characters.
    pub name: String,
    /// Index of the first node of the layer.
    pub first_node: u32,
    /// Number of consecutive nodes in the layer.
    pub node_count: u32,
}

/// The static part of a model that renderers and tools need: nodes, surface, layers, texture.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Topology {
    /// Number of nodes (the length of every `nodes` frame).
    pub node_count: u32,
    /// Surface triangles as node index triples, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Layer node ranges, at most [`MAX_LAYERS`].
    pub layers: Vec<LayerRange>,
    /// Texture coordinates `(u, v)` per node (dimensionless): empty, or `node_count` entries.
    pub tex_coords: Vec<[f32; 2]>,
}

/// Why a [`Topology`] cannot be put on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopologyEncodeError {
    /// More than [`MAX_LAYERS`] layers.
    TooManyLayers,
    /// A layer name is longer than [`LAYER_NAME_LEN`] bytes or contains a NUL character.
    InvalidLayerName,
    /// A layer's node range reaches past `node_count`.
    LayerOutOfRange,
    /// A triangle refers to a node index `>= node_count`.
    TriangleIndexOutOfRange,
    /// `tex_coords` is neither empty nor `node_count` long.
    TexCoordCountMismatch,
    /// The triangle count does not fit the `u32` wire fields.
    TooManyTriangles,
}

/// Why a wire topology frame is not a valid [`Topology`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TopologyDecodeError {
    /// `layer_count` exceeds [`MAX_LAYERS`].
    TooManyLayers,
    /// A layer name is not UTF-8.
    InvalidLayerName,
    /// A layer's node range reaches past `node_count`.
    LayerOutOfRange,
    /// A triangle refers to a node index `>= node_count`.
    TriangleIndexOutOfRange,
    /// `tex_coord_count` is neither 0 nor `node_count`.
    TexCoordCountMismatch,
    /// The payload length differs from what the header describes.
    PayloadLengthMismatch,
}

impl core::fmt::Display for TopologyEncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let msg = match self {
            Self::TooManyLayers => "more layers than the wire can carry",
            Self::InvalidLayerName => "layer name too long or contains NUL",
            Self::LayerOutOfRange => "layer node range exceeds node count",
            Self::TriangleIndexOutOfRange => "triangle refers to a node beyond node count",
            Self::TexCoordCountMismatch => "texture coordinates are neither empty nor one per node",
            Self::TooManyTriangles => "triangle count does not fit in u32",
        };
        write!(f, "cannot encode topology: {msg}")
    }
}

impl core::error::Error for TopologyEncodeError {}

impl core::fmt::Display for TopologyDecodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let msg = match self {
            Self::TooManyLayers => "layer count exceeds the layer table",
            Self::InvalidLayerName => "layer name is not UTF-8",
            Self::LayerOutOfRange => "layer node range exceeds node count",
            Self::TriangleIndexOutOfRange => "triangle refers to a node beyond node count",
            Self::TexCoordCountMismatch => "texture coordinates are neither empty nor one per node",
            Self::PayloadLengthMismatch => "payload length differs from the header",
        };
        write!(f, "cannot decode topology: {msg}")
    }
}

impl core::error::Error for TopologyDecodeError {}

fn range_ok(first: u32, count: u32, node_count: u32) -> bool {
    u64::from(first) + u64::from(count) <= u64::from(node_count)
}

impl Topology {
    /// Number of `u32` payload words [`Topology::encode`] produces.
    pub fn word_count(&self) -> usize {
        3 * self.triangles.len() + 2 * self.tex_coords.len()
    }

    /// The wire header alone (revision 0), after validation.
    pub fn header(&self) -> Result<TopologyHeader, TopologyEncodeError> {
        if self.layers.len() > MAX_LAYERS {
            return Err(TopologyEncodeError::TooManyLayers);
        }
        let triangle_count = u32::try_from(self.triangles.len()).map_err(|_| TopologyEncodeError::TooManyTriangles)?;
        if !(self.tex_coords.is_empty() || self.tex_coords.len() == self.node_count as usize) {
            return Err(TopologyEncodeError::TexCoordCountMismatch);
        }
        if self.triangles.iter().flatten().any(|&i| i >= self.node_count) {
            return Err(TopologyEncodeError::TriangleIndexOutOfRange);
        }
        let mut layers = [WireLayer::default(); MAX_LAYERS];
        for (wire, layer) in layers.iter_mut().zip(&self.layers) {
            let bytes = layer.name.as_bytes();
            if bytes.len() > LAYER_NAME_LEN || bytes.contains(&0) {
                return Err(TopologyEncodeError::InvalidLayerName);
            }
            if !range_ok(layer.first_node, layer.node_count, self.node_count) {
                return Err(TopologyEncodeError::LayerOutOfRange);
            }
            wire.name[..bytes.len()].copy_from_slice(bytes);
            wire.first_node = layer.first_node;
            wire.node_count = layer.node_count;
        }
        Ok(TopologyHeader {
            revision: 0,
            node_count: self.node_count,
            triangle_count,
            // Checked above: empty or node_count long, so it fits.
            tex_coord_count: if self.tex_coords.is_empty() { 0 } else { self.node_count },
            // Checked above: at most MAX_LAYERS.
            layer_count: self.layers.len() as u32,
            layers,
        })
    }

    /// Payload word `i` of the encoding (see [`TopologyHeader`]); 0 past the end.
    pub fn word(&self, i: usize) -> u32 {
        let tri_words = 3 * self.triangles.len();
        if i < tri_words {
            self.triangles[i / 3][i % 3]
        } else {
            let j = i - tri_words;
            self.tex_coords.get(j / 2).map_or(0, |uv| uv[j % 2].to_bits())
        }
    }

    /// Validates and converts to the wire: header (revision 0) and payload words.
    pub fn encode(&self) -> Result<(TopologyHeader, Vec<u32>), TopologyEncodeError> {
        let header = self.header()?;
        let words = (0..self.word_count()).map(|i| self.word(i)).collect();
        Ok((header, words))
    }

    /// Validates a wire frame and converts it back; the exact inverse of [`Topology::encode`].
    pub fn decode(header: &TopologyHeader, words: &[u32]) -> Result<Self, TopologyDecodeError> {
        let layer_count = header.layer_count as usize;
        if layer_count > MAX_LAYERS {
            return Err(TopologyDecodeError::TooManyLayers);
        }
        if !(header.tex_coord_count == 0 || header.tex_coord_count == header.node_count) {
            return Err(TopologyDecodeError::TexCoordCountMismatch);
        }
        if words.len() != header.word_count() {
            return Err(TopologyDecodeError::PayloadLengthMismatch);
        }
        let (tri_words, uv_words) = words.split_at(3 * header.triangle_count as usize);
        if tri_words.iter().any(|&i| i >= header.node_count) {
            return Err(TopologyDecodeError::TriangleIndexOutOfRange);
        }
        let mut layers = Vec::with_capacity(layer_count);
        for wire in &header.layers[..layer_count] {
            let len = wire.name.iter().position(|&b| b == 0).unwrap_or(LAYER_NAME_LEN);
            let name = core::str::from_utf8(&wire.name[..len]).map_err(|_| TopologyDecodeError::InvalidLayerName)?;
            if !range_ok(wire.first_node, wire.node_count, header.node_count) {
                return Err(TopologyDecodeError::LayerOutOfRange);
            }
            layers.push(LayerRange { name: name.to_owned(), first_node: wire.first_node, node_count: wire.node_count });
        }
        Ok(Self {
            node_count: header.node_count,
            triangles: tri_words.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect(),
            layers,
            tex_coords: uv_words.chunks_exact(2).map(|uv| [f32::from_bits(uv[0]), f32::from_bits(uv[1])]).collect(),
        })
    }
}
