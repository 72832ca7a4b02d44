//! The layers of a generated model, by index.

use crate::model::{Layer, Tissue};

/// Layer index of the skin: the outer grid nodes, the skin/fat nodes and the tetrahedral
/// skin springs.
pub const SKIN: u16 = 0;
/// Layer index of the fat: the fat/muscle nodes and the springs of the fat block.
pub const FAT: u16 = 1;
/// Layer index of the muscle: the springs of the muscle block (its nodes are on the
/// fat/muscle and muscle/bone boundaries).
pub const MUSCLE: u16 = 2;
/// Layer index of the bone: the fixed nodes on the muscle/bone boundary. No springs.
pub const BONE: u16 = 3;

/// The four layers of a generated model, in index order.
pub fn generated_layers() -> Vec<Layer> {
    [("skin", Tissue::Skin), ("fat", Tissue::Fat), ("muscle", Tissue::Muscle), ("bone", Tissue::Bone)]
        .into_iter()
        .map(|(name, tissue)| Layer { name: name.into(), tissue })
        .collect()
}
