//! Model files: the XML model format and VTK export.
