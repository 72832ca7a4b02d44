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

    /// The tissue a free-form layer or surface name refers to: `skin*`/`derm*`, `fat*`/
    /// `adipose*`/`subcut*`, `muscle*`, `bone*` (any case); anything else is
    /// [`Tissue::Other`].
    pub fn from_prefix(name: &str) -> Self {
        let lower = name.to_ascii_lowercase();
        let starts = |prefixes: &[&str]| prefixes.iter().any(|p| lower.starts_with(p));
        if starts(&["skin", "derm"]) {
            Tissue::Skin
        } else if starts(&["fat", "adipose", "subcut"]) {
            Tissue::Fat
        } else if starts(&["muscle"]) {
            Tissue::Muscle
        } else if starts(&["bone"]) {
            Tissue::Bone
        } else {
            Tissue::Other
        }
    }

    /// The tissue just beneath a boundary surface named after the two tissues it separates,
    /// outer first (`skin_outer` → skin, `skin_fat` → fat, `fat_muscle` → muscle,
    /// `muscle_bone` → bone); a name without `_` is read with [`Tissue::from_prefix`].
    ///
    /// # Examples
    ///
    /// ```
    /// use lamina_core::model::Tissue;
    ///
    /// assert_eq!(Tissue::beneath_boundary("skin_outer"), Tissue::Skin);
    /// assert_eq!(Tissue::beneath_boundary("fat_muscle"), Tissue::Muscle);
    /// assert_eq!(Tissue::beneath_boundary("whatever"), Tissue::Other);
    /// ```
    pub fn beneath_boundary(name: &str) -> Self {
        match name.rsplit('_').next() {
            Some("outer") => Tissue::Skin,
            Some(last) => Tissue::from_prefix(last),
            None => Tissue::Other,
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
