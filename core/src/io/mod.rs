//! Model files: the XML model format (`docs/model-format.md`) and VTK export for ParaView
//! (a model, a series of positions, or a recorded run with its volume cells:
//! `docs/recording.md`).
//!
//! # Examples
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use lamina_core::io::{model_from_str, model_to_string};
//! use lamina_core::yardstick::{LatticeSize, lattice_model};
//! let model = lattice_model(LatticeSize { nx: 3, ny: 2, nz: 2 });
//! let text = model_to_string(&model)?;
//! assert_eq!(model_from_str(&text)?, model); // bit-exact round trip
//! let err = model_from_str("<lamina-model version=\"1\" units=\"SI (m, kg, s, N)\">\n<nodez/>")
//!     .unwrap_err();
//! assert_eq!(err.line(), Some(2));
//! # Ok(())
//! # }
//! ```

mod error;
mod format;
mod locate;
mod vtu;
mod vtu_record;
mod vtu_series;
mod xml_attrs;
mod xml_read;
mod xml_write;

pub use error::{ModelReadError, ModelWriteError, SourceLocation, VtuWriteError};
pub use format::{MODEL_FORMAT_VERSION, MODEL_UNITS, PPU_COMP_LEN, PPU_STRET_LEN_FACTOR};
use lamina_input::FileLimit;
pub use vtu::{VTK_LINE, VTK_TRIANGLE, vtu_to_string, write_vtu};
pub use vtu_record::{
    RECORD_COLLECTION, RecordReadError, RecordedFrame, VtuRecorder, read_recorded_points, read_recording,
};
pub use vtu_series::VtuSeriesWriter;
pub use xml_read::{MIN_ELEMENT_BYTES, model_from_str, read_model};
pub use xml_write::{ModelWriteOptions, model_to_string, model_to_string_with, write_model, write_model_with};

/// Model files: at most 4 GiB, parsed in at most 6 bytes of memory per byte of file (the
/// reader reserves list storage for one element per [`MIN_ELEMENT_BYTES`] of file, and the
/// largest element, a spring, takes under 96 bytes).
pub const MODEL_FILE: FileLimit = FileLimit::new("model file", 4 << 30).memory_per_byte(6);
