//! A user's volume texture file, told apart by its name: NRRD (`.nrrd`, `.nhdr`,
//! [`crate::nrrd`]) or NIfTI-1 (any other, [`crate::volume::read_nifti`]).

use std::path::Path;

use crate::nrrd::{read_nrrd, read_nrrd_header};
use crate::view_model::VolumeSpec;
use crate::volume::{VolumeError, VolumeGeometry, VolumeImage, read_nifti, read_nifti_header};

/// Whether `path` names a NRRD file (`.nrrd`, `.nhdr`, any case) rather than a NIfTI-1 one.
pub fn is_nrrd(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("nrrd") || e.eq_ignore_ascii_case("nhdr"))
}

/// Reads and checks the header of a volume file: a NRRD file with [`read_nrrd_header`], any
/// other with [`read_nifti_header`].
pub fn read_volume_header(path: &Path) -> Result<VolumeGeometry, VolumeError> {
    if is_nrrd(path) { read_nrrd_header(path) } else { read_nifti_header(path) }
}

/// Reads the volume of `spec`: a NRRD file with [`read_nrrd`], any other with [`read_nifti`].
pub fn read_volume(spec: &VolumeSpec) -> Result<VolumeImage, VolumeError> {
    if is_nrrd(&spec.path) { read_nrrd(spec) } else { read_nifti(spec) }
}
