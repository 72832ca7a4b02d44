//! Tissue layers.

/// The tissue a layer stands for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Tissue {
    /// Skin (epidermis and dermis).
    Skin,
    /// Subcutaneous fat (adipose tissue).
    Fat,
    /// Skeletal muscle (passive).
    Muscle,
    /// Bone (fixed or kinematic nodes).
    Bone,
    /// Anything else, e.g. a test block.
    Other,
}

impl Tissue {
    /// Name used in files.
    pub fn name(self) -> &'static str {
        match self {
            Tissue::Skin => "skin",
            Tissue::Fat => "fat",
            Tissue::Muscle => "muscle",
            Tissue::Bone => "bone",
            Tissue::Other => "other",
        }
    }

    /// Parses [`Tissue::name`]'s output.
    pub fn from_name(name: &str) -> Option<Self> {
        Some(match name {
            "skin" => Tissue::Skin,
            "fat" => Tissue::Fat,
            "muscle" => Tissue::Muscle,
            "bone" => Tissue::Bone,
            "other" => Tissue::Other,
            _ => return None,
        })
    }
}

/// One layer of the model. Nodes and springs name their layer by index.
#[derive(Clone, Debug, PartialEq)]
pub struct Layer {
    /// Display name, e.g. `skin`.
    pub name: String,
    /// Tissue the layer models.
    pub tissue: Tissue,
}
