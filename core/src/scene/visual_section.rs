//! The scene's `[visual]` table: how the viewer draws the tissue. Read by the viewer only;
//! the simulation ignores it.
//!
//! ```toml
//! [visual]
//! volume = "limb_volume.nii.gz"   # NIfTI-1 or NRRD volume texture, relative to the scene file
//! origin_m = [-0.15, -0.06, -0.06] # first voxel's centre, metres (default: the header's)
//! window = [0.0, 255.0]           # intensities drawn black and white (default: min, max)
//! ```

use super::section::FieldError;
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The `[visual]` table of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct VisualSection {
    /// The volume texture: a NIfTI-1 file (`.nii`, `.nii.gz`) or a NRRD file (`.nrrd`,
    /// `.nhdr`), absolute or relative to the
    /// scene file's folder as written, made absolute here. It must exist when the scene is
    /// loaded; its header and voxels are checked by the viewer that reads it.
    pub volume: PathBuf,
    /// Where the centre of the volume's first voxel lies, metres, model frame. `None`: the
    /// origin in the file's header (NIfTI: its `sform`, else its `qform` offset; NRRD: its
    /// `space origin`), converted to metres.
    pub origin_m: Option<[f64; 3]>,
    /// Intensity window `[lo, hi]`: `lo` and below is drawn black, `hi` and above white.
    /// `None`: the data's minimum and maximum.
    pub window: Option<[f64; 2]>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub(super) struct RawVisual {
    volume: Option<String>,
    origin_m: Option<[f64; 3]>,
    window: Option<[f64; 2]>,
}

/// The `[visual]` table (`None` when the scene has none), with relative paths anchored at
/// `base` (the scene file's folder).
pub(super) fn visual_section(raw: Option<RawVisual>, base: &Path) -> Result<Option<VisualSection>, FieldError> {
    let Some(raw) = raw else { return Ok(None) };
    let Some(volume) = raw.volume else {
        if raw.origin_m.is_some() || raw.window.is_some() {
            return Err(FieldError::new("visual.volume", "origin_m and window need a volume = \"FILE\""));
        }
        return Ok(None);
    };
    if volume.trim().is_empty() {
        return Err(FieldError::new(
            "visual.volume",
            "must name a NIfTI-1 (.nii, .nii.gz) or NRRD (.nrrd, .nhdr) file",
        ));
    }
    let path = base.join(&volume);
    let path = std::path::absolute(&path).unwrap_or(path);
    if !path.is_file() {
        return Err(FieldError::new("visual.volume", format!("no such file: {}", path.display())));
    }
    if let Some(o) = raw.origin_m
        && !o.iter().all(|c| c.is_finite())
    {
        return Err(FieldError::new("visual.origin_m", "must be three finite numbers, metres"));
    }
    if let Some([lo, hi]) = raw.window
        && !(lo.is_finite() && hi.is_finite() && lo < hi)
    {
        return Err(FieldError::new("visual.window", "must be [lo, hi], finite, with lo < hi"));
    }
    Ok(Some(VisualSection { volume: path, origin_m: raw.origin_m, window: raw.window }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn raw(volume: Option<&str>) -> RawVisual {
        RawVisual { volume: volume.map(str::to_string), origin_m: None, window: None }
    }

    #[test]
    fn visual_relative_path_is_anchored_at_the_scene_works() {
        let dir = std::env::temp_dir().join(format!("lamina_visual_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("v.nii"), b"x").unwrap();
        let v =
            visual_section(Some(RawVisual { window: Some([0.0, 1.0]), ..raw(Some("v.nii")) }), &dir).unwrap().unwrap();
        assert_eq!(v.volume, std::path::absolute(dir.join("v.nii")).unwrap());
        assert_eq!((v.origin_m, v.window), (None, Some([0.0, 1.0])));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn visual_bad_values_fail() {
        let here = Path::new(".");
        assert_eq!(visual_section(None, here), Ok(None));
        let e = visual_section(Some(raw(Some("no/such/volume.nii"))), here).unwrap_err();
        assert!(e.field == "visual.volume" && e.message.contains("no such file"), "{e:?}");
        let e = visual_section(Some(RawVisual { window: Some([1.0, 1.0]), ..raw(None) }), here).unwrap_err();
        assert_eq!(e.field, "visual.volume");
        let cargo = Path::new(env!("CARGO_MANIFEST_DIR"));
        let bad_window = RawVisual { window: Some([2.0, 1.0]), ..raw(Some("Cargo.toml")) };
        assert_eq!(visual_section(Some(bad_window), cargo).unwrap_err().field, "visual.window");
        let bad_origin = RawVisual { origin_m: Some([0.0, f64::NAN, 0.0]), ..raw(Some("Cargo.toml")) };
        assert_eq!(visual_section(Some(bad_origin), cargo).unwrap_err().field, "visual.origin_m");
    }
}
