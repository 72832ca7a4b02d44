//! [`TriMesh`]: an indexed triangle surface in metres, and its basic measures.

use crate::error::TriMeshBuildError;
use crate::vec3::{self, V3};

/// An indexed triangle surface.
///
/// Coordinates are in metres (loaders convert). Each triangle lists three vertex indices;
/// for an oriented closed surface the winding is counter-clockwise seen from outside
/// (right-hand rule gives the outward normal). The constructor guarantees that every index
/// is in range and every coordinate finite, so no method here can panic.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
}

/// An axis-aligned box, in metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingBox {
    /// Smallest x, y, z (m).
    pub min: [f64; 3],
    /// Largest x, y, z (m).
    pub max: [f64; 3],
}

impl BoundingBox {
    /// The smallest box holding all `points`; `None` when there are none.
    pub fn of_points(points: &[[f64; 3]]) -> Option<Self> {
        let first = *points.first()?;
        let mut b = Self { min: first, max: first };
        for p in points {
            for (k, &c) in p.iter().enumerate() {
                b.min[k] = b.min[k].min(c);
                b.max[k] = b.max[k].max(c);
            }
        }
        Some(b)
    }

    /// Edge lengths along x, y, z (m).
    pub fn size(&self) -> [f64; 3] {
        vec3::sub(self.max, self.min)
    }

    /// Length of the diagonal (m).
    pub fn diagonal(&self) -> f64 {
        vec3::norm(self.size())
    }

    /// Centre point (m).
    pub fn centre(&self) -> [f64; 3] {
        vec3::scale(vec3::add(self.min, self.max), 0.5)
    }

    /// Index (0 = x, 1 = y, 2 = z) of the longest side; the first one on ties.
    pub fn longest_axis(&self) -> usize {
        let s = self.size();
        if s[0] >= s[1] && s[0] >= s[2] {
            0
        } else if s[1] >= s[2] {
            1
        } else {
            2
        }
    }
}

impl TriMesh {
    /// Builds a mesh from vertices (m) and triangles (indices into `vertices`).
    ///
    /// # Errors
    /// [`TriMeshBuildError`] when an index is out of range, a coordinate is NaN or infinite,
    /// or there are more than `u32::MAX` vertices.
    pub fn new(vertices: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Result<Self, TriMeshBuildError> {
        if u32::try_from(vertices.len()).is_err() {
            return Err(TriMeshBuildError::TooManyVertices { vertex_count: vertices.len() });
        }
        if let Some(vertex) = vertices.iter().position(|v| !vec3::is_finite(*v)) {
            return Err(TriMeshBuildError::NonFiniteVertex { vertex });
        }
        for (triangle, t) in triangles.iter().enumerate() {
            for &index in t {
                if index as usize >= vertices.len() {
                    return Err(TriMeshBuildError::IndexOutOfRange { triangle, index, vertex_count: vertices.len() });
                }
            }
        }
        Ok(Self { vertices, triangles })
    }

    /// Builds a mesh whose validity the caller has already ensured (crate-internal).
    pub(crate) fn from_valid(vertices: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Self {
        debug_assert!(Self::new(vertices.clone(), triangles.clone()).is_ok());
        Self { vertices, triangles }
    }

    /// Vertex positions (m).
    pub fn vertices(&self) -> &[[f64; 3]] {
        &self.vertices
    }

    /// Triangles as vertex-index triples.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Takes the vertex and triangle arrays out.
    pub fn into_parts(self) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        (self.vertices, self.triangles)
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// True when there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// The three corners of triangle `t` (m); `None` when `t` is out of range.
    pub fn corners(&self, t: usize) -> Option<[[f64; 3]; 3]> {
        let tri = self.triangles.get(t)?;
        Some(tri.map(|i| self.vertices[i as usize]))
    }

    /// Unit normal of triangle `t` by its winding (outward for an oriented closed surface);
    /// `None` when `t` is out of range or the triangle has zero area.
    pub fn triangle_normal(&self, t: usize) -> Option<[f64; 3]> {
        let [a, b, c] = self.corners(t)?;
        vec3::normalize(vec3::cross(vec3::sub(b, a), vec3::sub(c, a)))
    }

    /// Smallest box holding all vertices (m); `None` for a mesh without vertices.
    pub fn bounding_box(&self) -> Option<BoundingBox> {
        BoundingBox::of_points(&self.vertices)
    }

    /// Total surface area (m²).
    pub fn area(&self) -> f64 {
        area_of(&self.vertices, &self.triangles)
    }

    /// Signed enclosed volume (m³) by the divergence theorem: positive when a closed surface
    /// is wound outward. Meaningless for an open surface. Computed about the bounding-box
    /// centre so that far-from-origin coordinates lose no precision.
    pub fn signed_volume(&self) -> f64 {
        signed_volume_of(&self.vertices, &self.triangles)
    }

    /// Reverses the winding of every triangle (turns an outward surface inward).
    pub fn flip_all(&mut self) {
        for t in &mut self.triangles {
            t.swap(1, 2);
        }
    }

    /// Moves every vertex by `offset` (m).
    pub fn translate(&mut self, offset: [f64; 3]) {
        for v in &mut self.vertices {
            *v = vec3::add(*v, offset);
        }
    }
}

pub(crate) fn area_of(vertices: &[V3], triangles: &[[u32; 3]]) -> f64 {
    triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| vertices[i as usize]);
            0.5 * vec3::norm(vec3::cross(vec3::sub(b, a), vec3::sub(c, a)))
        })
        .sum()
}

/// Signed volume of the triangles listed (indices into `vertices`), about `origin`.
pub(crate) fn signed_volume_about(vertices: &[V3], triangles: impl Iterator<Item = [u32; 3]>, origin: V3) -> f64 {
    let mut six_v = 0.0;
    for t in triangles {
        let [a, b, c] = t.map(|i| vec3::sub(vertices[i as usize], origin));
        six_v += vec3::dot(a, vec3::cross(b, c));
    }
    six_v / 6.0
}

pub(crate) fn signed_volume_of(vertices: &[V3], triangles: &[[u32; 3]]) -> f64 {
    let origin = BoundingBox::of_points(vertices).map_or([0.0; 3], |b| b.centre());
    signed_volume_about(vertices, triangles.iter().copied(), origin)
}
