//! Point masses, stored as structure of arrays.

/// How a node moves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NodeKind {
    /// Integrated by the solver.
    Free,
    /// Attached to bone that does not move: position and velocity stay as they are.
    Fixed,
    /// Attached to bone that the scene moves: position set each step by the bone's motion.
    Kinematic,
}

impl NodeKind {
    /// Name used in files: `free`, `fixed`, `kinematic`.
    pub fn name(self) -> &'static str {
        match self {
            NodeKind::Free => "free",
            NodeKind::Fixed => "fixed",
            NodeKind::Kinematic => "kinematic",
        }
    }

    /// Parses [`NodeKind::name`]'s output.
    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "free" => Some(NodeKind::Free),
            "fixed" => Some(NodeKind::Fixed),
            "kinematic" => Some(NodeKind::Kinematic),
            _ => None,
        }
    }
}

/// The nodes of a model: one entry per node in every array, indexed by `u32` node index.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NodeSet {
    /// Rest (initial) positions, m.
    pub position: Vec<[f64; 3]>,
    /// Masses, kg (> 0).
    pub mass: Vec<f64>,
    /// Free, fixed to bone, or moved with bone.
    pub kind: Vec<NodeKind>,
    /// Index of the layer the node belongs to.
    pub layer: Vec<u16>,
    /// Texture coordinate (3D, for volume textures), unitless.
    pub texcoord: Vec<[f32; 3]>,
}

impl NodeSet {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.position.len()
    }

    /// True when there are no nodes.
    pub fn is_empty(&self) -> bool {
        self.position.is_empty()
    }

    /// Marks every fixed node kinematic: the bone they are attached to moves
    /// (`effects.bone_motion`). Generated models fix their innermost level to bone; a scene
    /// asking for bone motion moves it.
    ///
    /// ```
    /// use lamina_core::model::{NodeKind, NodeSet};
    /// let mut nodes = NodeSet::default();
    /// nodes.push([0.0; 3], 1e-3, NodeKind::Fixed, 0);
    /// nodes.push([0.0, 0.01, 0.0], 1e-3, NodeKind::Free, 1);
    /// nodes.set_bone_moving();
    /// assert_eq!(nodes.kind, [NodeKind::Kinematic, NodeKind::Free]);
    /// ```
    pub fn set_bone_moving(&mut self) {
        for kind in self.kind.iter_mut().filter(|k| **k == NodeKind::Fixed) {
            *kind = NodeKind::Kinematic;
        }
    }

    /// Appends a node; returns its index.
    pub fn push(&mut self, position: [f64; 3], mass: f64, kind: NodeKind, layer: u16) -> u32 {
        self.position.push(position);
        self.mass.push(mass);
        self.kind.push(kind);
        self.layer.push(layer);
        self.texcoord.push([0.0; 3]);
        (self.position.len() - 1) as u32
    }

    /// Total mass, kg.
    pub fn total_mass(&self) -> f64 {
        self.mass.iter().sum()
    }
}
