//! The deformable model generator: tissue boundary surfaces to a layered mass-spring model.
