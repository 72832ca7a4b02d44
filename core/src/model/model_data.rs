//! The whole model and its consistency check.

use super::{Cell, Layer, NodeSet, SpringSet, Surface};

/// Where a model came from: generator settings, fit results, as ordered key/value pairs.
pub type Provenance = Vec<(String, String)>;

/// A layered mass-spring model. SI units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Model {
    /// Model name.
    pub name: String,
    /// Point masses.
    pub nodes: NodeSet,
    /// Springs.
    pub springs: SpringSet,
    /// Layers, indexed by the nodes' and springs' `layer` fields.
    pub layers: Vec<Layer>,
    /// Surfaces (outer skin first).
    pub surfaces: Vec<Surface>,
    /// Volume cells (tetrahedra, prisms, hexahedra) over the nodes, for exports; may be
    /// empty (a model file without a `<cells>` section).
    pub cells: Vec<Cell>,
    /// Generator settings, fit results.
    pub provenance: Provenance,
}

/// What makes a model unusable.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelValidateError {
    /// A node has a non-finite position or a mass that is not finite and positive.
    #[error("node {node}: position not finite or mass not positive")]
    BadNode {
        /// Node index.
        node: u32,
    },
    /// A spring names a node index that does not exist, or both ends are the same node.
    #[error("spring {spring}: end node missing or both ends equal")]
    BadSpringEnds {
        /// Spring index.
        spring: u32,
    },
    /// A spring's rest length, law or damping is not finite and non-negative.
    #[error("spring {spring}: rest length, law or damping not finite and non-negative")]
    BadSpringParameters {
        /// Spring index.
        spring: u32,
    },
    /// A node or spring names a layer that does not exist.
    #[error("layer {layer} is named but not defined")]
    BadLayer {
        /// Layer index named.
        layer: u16,
    },
    /// A surface names a node index that does not exist.
    #[error("surface {surface}: names a node that does not exist")]
    BadSurface {
        /// Surface name.
        surface: String,
    },
    /// A cell names a node index that does not exist, names one node twice, or names a
    /// layer that does not exist.
    #[error("cell {cell}: names a node or layer that does not exist, or one node twice")]
    BadCell {
        /// Cell index.
        cell: u32,
    },
    /// The per-node or per-spring arrays differ in length.
    #[error("per-node or per-spring arrays differ in length")]
    RaggedArrays,
}

impl Model {
    /// Checks that every index and parameter is usable by the solver.
    pub fn validate(&self) -> Result<(), ModelValidateError> {
        let n = self.nodes.len();
        let s = self.springs.len();
        let nodes = &self.nodes;
        let springs = &self.springs;
        if [nodes.mass.len(), nodes.kind.len(), nodes.layer.len(), nodes.texcoord.len()].iter().any(|&l| l != n)
            || [
                springs.b.len(),
                springs.rest_length.len(),
                springs.law.len(),
                springs.damping.len(),
                springs.layer.len(),
            ]
            .iter()
            .any(|&l| l != s)
        {
            return Err(ModelValidateError::RaggedArrays);
        }
        let layers = self.layers.len();
        for i in 0..n {
            let p = nodes.position[i];
            let m = nodes.mass[i];
            if !(p.iter().all(|c| c.is_finite()) && m.is_finite() && m > 0.0) {
                return Err(ModelValidateError::BadNode { node: i as u32 });
            }
            if nodes.layer[i] as usize >= layers {
                return Err(ModelValidateError::BadLayer { layer: nodes.layer[i] });
            }
        }
        for i in 0..s {
            let (a, b) = (springs.a[i] as usize, springs.b[i] as usize);
            if a >= n || b >= n || a == b {
                return Err(ModelValidateError::BadSpringEnds { spring: i as u32 });
            }
            let l0 = springs.rest_length[i];
            let c = springs.damping[i];
            if !(l0.is_finite() && l0 >= 0.0 && c.is_finite() && c >= 0.0 && springs.law[i].is_valid(l0)) {
                return Err(ModelValidateError::BadSpringParameters { spring: i as u32 });
            }
            if springs.layer[i] as usize >= layers {
                return Err(ModelValidateError::BadLayer { layer: springs.layer[i] });
            }
        }
        for surface in &self.surfaces {
            if surface.triangles.iter().flatten().any(|&v| v as usize >= n) {
                return Err(ModelValidateError::BadSurface { surface: surface.name.clone() });
            }
        }
        for (i, cell) in self.cells.iter().enumerate() {
            let nodes = cell.nodes();
            let repeated = (1..nodes.len()).any(|k| nodes[..k].contains(&nodes[k]));
            if repeated || nodes.iter().any(|&v| v as usize >= n) || cell.layer as usize >= layers {
                return Err(ModelValidateError::BadCell { cell: i as u32 });
            }
        }
        Ok(())
    }

    /// Index of the first layer with this name.
    pub fn layer_index(&self, name: &str) -> Option<u16> {
        self.layers.iter().position(|l| l.name == name).map(|i| i as u16)
    }
}
