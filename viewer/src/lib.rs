//! Lamina's viewer: subscribes to the core's `topology` and `nodes` over iceoryx2 (or runs a
//! built-in animated limb) and draws the layered tissue with wgpu, in a window ([`window`],
//! with the mouse and key bindings of [`controls`]) or headless into PNG files.
//!
//! # How a frame is made
//! 1. [`source`] yields the model once and then frames (node positions, tool, core stats).
//! 2. [`mesh_build`] re-patches every tissue boundary grid with the paper's adaptive
//!    bi-quartic Bézier patches ([`bezier`], Eqs. 2-4), adds the cut faces ([`cut`]), the
//!    spring wireframe and the tool.
//! 3. [`render`] draws it with [`material`]s per tissue, under the [`overlay`] text, from the
//!    [`camera`] (fixed from the first frame, moved by the user in the window); [`app`]
//!    strings the steps together and [`timing`] measures them.
//!
//! Architecture invariant: the viewer only subscribes. Starting, stopping, hanging or crashing
//! it never delays the core (the bridge's publishers do not wait for subscribers).

pub mod app;
pub mod bezier;
pub mod camera;
pub mod controls;
pub mod cut;
pub mod grab;
pub mod material;
pub mod mesh_build;
pub mod nrrd;
pub mod overlay;
pub mod png_io;
pub mod render;
pub mod replay;
pub mod scene_mesh;
pub mod source;
pub mod synthetic;
pub mod timing;
pub mod view_model;
pub mod volume;
pub mod volume_file;
pub mod window;
