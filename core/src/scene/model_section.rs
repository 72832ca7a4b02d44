//! The scene's `[model]` table: where the model comes from.

use super::layered_block::{BlockSpec, LayerMaterial};
use super::section::FieldError;
use super::springs_section::{RawSprings, SceneSprings, scene_springs};
use crate::generator::{AnatomySpec, CylinderLimb, GridSize, Materials};
use crate::yardstick::LatticeSize;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Where the model comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelSource {
    /// The built-in layered block.
    LayeredBlock(BlockSpec),
    /// The yardstick lattice.
    Yardstick(LatticeSize),
    /// The generator's synthetic cylindrical limb (W columns × H rows).
    CylinderLimb {
        /// Columns around.
        columns: u32,
        /// Rows along.
        rows: u32,
        /// Length, m.
        length: f64,
        /// The fitted springs (`[model.springs]`); `None`: the generator's defaults.
        springs: Option<SceneSprings>,
    },
    /// A model file (XML), path relative to the scene file.
    File(PathBuf),
    /// Generated from segmented surfaces (paths relative to the scene file); see
    /// [`crate::generator::generate_anatomy`].
    Anatomy(Box<AnatomySpec>),
}

#[derive(Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub(super) enum RawModel {
    LayeredBlock {
        #[serde(flatten)]
        spec: Box<RawBlock>,
    },
    Yardstick {
        size: String,
    },
    CylinderLimb {
        columns: Option<u32>,
        rows: Option<u32>,
        length: Option<f64>,
        springs: Option<RawSprings>,
    },
    File {
        path: PathBuf,
    },
    Anatomy(Box<RawAnatomy>),
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawBlock {
    nx: Option<usize>,
    nz: Option<usize>,
    spacing: Option<f64>,
    muscle_rows: Option<usize>,
    fat_rows: Option<usize>,
    skin_rows: Option<usize>,
    density: Option<f64>,
    skin: Option<LayerMaterial>,
    fat: Option<LayerMaterial>,
    muscle: Option<LayerMaterial>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RawAnatomy {
    skin: PathBuf,
    fat_muscle: PathBuf,
    bone: PathBuf,
    z_range_mm: [f64; 2],
    columns: u32,
    rows: u32,
    skin_fat: Option<PathBuf>,
    skin_thickness_mm: Option<f64>,
    min_layer_mm: Option<f64>,
    springs: Option<RawSprings>,
}

/// The `[model]` table (`None`: absent, the default layered block); relative paths are
/// resolved against `base`, the scene file's folder.
pub(super) fn model_source(raw: Option<RawModel>, base: &Path) -> Result<ModelSource, FieldError> {
    Ok(match raw {
        None => ModelSource::LayeredBlock(BlockSpec::default()),
        Some(RawModel::LayeredBlock { spec }) => ModelSource::LayeredBlock(layered_block(*spec)?),
        Some(RawModel::Yardstick { size }) => ModelSource::Yardstick(
            LatticeSize::parse(&size)
                .ok_or_else(|| FieldError::new("model.size", "small, medium, large or NXxNYxNZ"))?,
        ),
        Some(RawModel::CylinderLimb { columns, rows, length, springs }) => {
            cylinder_limb(columns, rows, length, springs.map(scene_springs).transpose()?)?
        }
        Some(RawModel::File { path }) => ModelSource::File(base.join(path)),
        Some(RawModel::Anatomy(raw)) => ModelSource::Anatomy(Box::new(anatomy(*raw, base)?)),
    })
}

fn layered_block(raw: RawBlock) -> Result<BlockSpec, FieldError> {
    let d = BlockSpec::default();
    let s = BlockSpec {
        nx: raw.nx.unwrap_or(d.nx),
        nz: raw.nz.unwrap_or(d.nz),
        spacing: raw.spacing.unwrap_or(d.spacing),
        muscle_rows: raw.muscle_rows.unwrap_or(d.muscle_rows),
        fat_rows: raw.fat_rows.unwrap_or(d.fat_rows),
        skin_rows: raw.skin_rows.unwrap_or(d.skin_rows),
        density: raw.density.unwrap_or(d.density),
        skin: raw.skin.unwrap_or(d.skin),
        fat: raw.fat.unwrap_or(d.fat),
        muscle: raw.muscle.unwrap_or(d.muscle),
    };
    if s.nx < 2 || s.nz < 2 {
        return Err(FieldError::new("model", format!("nx {}, nz {}: each must be at least 2", s.nx, s.nz)));
    }
    // Counts without overflow, the estimate against the memory available (both in the
    // message), before the block's fixed cap.
    s.check_size().map_err(|e| FieldError::new("model", e.to_string()))?;
    let nodes = s.nx.saturating_mul(s.nz).saturating_mul(s.rows());
    if nodes > 50_000_000 {
        let message =
            format!("nx {}, nz {}, {} rows: {nodes} nodes, more than the 5e7 a block may have", s.nx, s.nz, s.rows());
        return Err(FieldError::new("model", message));
    }
    if !(s.spacing.is_finite() && s.spacing > 0.0 && s.density.is_finite() && s.density > 0.0) {
        return Err(FieldError::new("model", "spacing and density must be finite and positive"));
    }
    for (name, m) in [("skin", &s.skin), ("fat", &s.fat), ("muscle", &s.muscle)] {
        if !m.is_valid() {
            return Err(FieldError::new(format!("model.{name}"), "material values must be finite and non-negative"));
        }
    }
    Ok(s)
}

fn cylinder_limb(
    columns: Option<u32>,
    rows: Option<u32>,
    length: Option<f64>,
    springs: Option<SceneSprings>,
) -> Result<ModelSource, FieldError> {
    let d = CylinderLimb::default();
    let (columns, rows) = (columns.unwrap_or(d.grid.columns), rows.unwrap_or(d.grid.rows));
    let length = length.unwrap_or(d.length);
    if !((3..=4096).contains(&columns) && (1..=4096).contains(&rows) && length.is_finite() && length > 0.0) {
        return Err(FieldError::new("model", "columns 3..=4096, rows 1..=4096, length finite and positive"));
    }
    Ok(ModelSource::CylinderLimb { columns, rows, length, springs })
}

fn anatomy(raw: RawAnatomy, base: &Path) -> Result<AnatomySpec, FieldError> {
    let skin_thickness = raw.skin_thickness_mm.unwrap_or(2.0) * 1e-3;
    let min_layer = raw.min_layer_mm.unwrap_or(1.0) * 1e-3;
    let z = raw.z_range_mm;
    let ok = z.iter().all(|z| z.is_finite())
        && z[0] < z[1]
        && (3..=4096).contains(&raw.columns)
        && (1..=4096).contains(&raw.rows)
        && skin_thickness.is_finite()
        && skin_thickness > 0.0
        && min_layer.is_finite()
        && min_layer > 0.0;
    if !ok {
        return Err(FieldError::new(
            "model",
            "z_range_mm increasing, columns 3..=4096, rows 1..=4096, skin_thickness_mm and min_layer_mm positive",
        ));
    }
    Ok(AnatomySpec {
        skin: base.join(raw.skin),
        fat_muscle: base.join(raw.fat_muscle),
        bone: base.join(raw.bone),
        skin_fat: raw.skin_fat.map(|p| base.join(p)),
        z_range: (z[0] * 1e-3, z[1] * 1e-3),
        grid: GridSize::new(raw.columns, raw.rows),
        skin_thickness,
        min_layer,
        materials: match raw.springs {
            Some(s) => scene_springs(s)?.materials(),
            None => Materials::default(),
        },
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<ModelSource, FieldError> {
        #[derive(Deserialize)]
        struct Wrap {
            model: RawModel,
        }
        let w: Wrap = toml::from_str(text).expect("well-formed");
        model_source(Some(w.model), Path::new("/scenes"))
    }

    #[test]
    fn model_section_defaults_and_relative_paths_works() {
        assert_eq!(model_source(None, Path::new(".")), Ok(ModelSource::LayeredBlock(BlockSpec::default())));
        let d = CylinderLimb::default();
        assert_eq!(
            parse("[model]\nkind = \"cylinder_limb\"\n"),
            Ok(ModelSource::CylinderLimb {
                columns: d.grid.columns,
                rows: d.grid.rows,
                length: d.length,
                springs: None
            })
        );
        assert_eq!(
            parse("[model]\nkind = \"file\"\npath = \"limb.xml\"\n"),
            Ok(ModelSource::File(PathBuf::from("/scenes/limb.xml")))
        );
        let text = "[model]\nkind = \"anatomy\"\nskin = \"a/skin.stl\"\nfat_muscle = \"f.stl\"\nbone = \"/abs/b.stl\"\nz_range_mm = [10.0, 30.0]\ncolumns = 12\nrows = 4\n";
        let Ok(ModelSource::Anatomy(spec)) = parse(text) else { panic!("anatomy") };
        assert_eq!(spec.skin, Path::new("/scenes/a/skin.stl"));
        assert_eq!(spec.bone, Path::new("/abs/b.stl"));
        assert_eq!(spec.z_range, (0.010, 0.030));
        assert_eq!((spec.skin_thickness, spec.min_layer), (0.002, 0.001));
    }

    #[test]
    fn model_section_bad_values_name_the_field_fails() {
        let cases = [
            ("kind = \"layered_block\"\nnx = 1\n", "model"),
            ("kind = \"layered_block\"\nspacing = 0.0\n", "model"),
            ("kind = \"layered_block\"\nskin = { law = \"linear\", k = -1.0 }\n", "model.skin"),
            ("kind = \"yardstick\"\nsize = \"huge\"\n", "model.size"),
            ("kind = \"cylinder_limb\"\ncolumns = 2\n", "model"),
            ("kind = \"cylinder_limb\"\nlength = -1.0\n", "model"),
        ];
        for (body, field) in cases {
            let e = parse(&format!("[model]\n{body}")).expect_err(body);
            assert_eq!(e.field, field, "{body}: {e:?}");
        }
    }
}
