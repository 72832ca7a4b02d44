//! The look of each tissue: colour and shininess, chosen to read like the usual anatomical
//! atlas palette (skin tone, yellow fat, dark red muscle, ivory bone).

use crate::view_model::Tissue;

/// A surface material for the Blinn-Phong shader.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// Base colour, sRGB components in `0..=1` (converted to linear for shading).
    pub srgb: [f32; 3],
    /// Specular strength, `0..=1`.
    pub specular: f32,
    /// Blinn-Phong exponent.
    pub shininess: f32,
}

/// sRGB component to linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

impl Material {
    /// The colour as linear RGB with the specular strength in alpha (the vertex format).
    pub fn linear_rgba(&self) -> [f32; 4] {
        [srgb_to_linear(self.srgb[0]), srgb_to_linear(self.srgb[1]), srgb_to_linear(self.srgb[2]), self.specular]
    }

    /// The material of a tissue's outer surface.
    pub fn of(tissue: Tissue) -> Self {
        match tissue {
            Tissue::Skin => Self { srgb: [0.87, 0.67, 0.57], specular: 0.28, shininess: 28.0 },
            Tissue::Fat => Self { srgb: [0.96, 0.84, 0.45], specular: 0.35, shininess: 40.0 },
            Tissue::Muscle => Self { srgb: [0.66, 0.17, 0.15], specular: 0.3, shininess: 36.0 },
            Tissue::Bone => Self { srgb: [0.93, 0.90, 0.80], specular: 0.2, shininess: 20.0 },
            Tissue::Other => Self { srgb: [0.6, 0.6, 0.62], specular: 0.2, shininess: 20.0 },
        }
    }

    /// The material of a tissue's cut face (a little darker and duller than its surface;
    /// the skin's cut face shows the pinker dermis).
    pub fn cut_face(tissue: Tissue) -> Self {
        match tissue {
            Tissue::Skin => Self { srgb: [0.90, 0.62, 0.58], specular: 0.1, shininess: 12.0 },
            Tissue::Fat => Self { srgb: [0.97, 0.86, 0.50], specular: 0.15, shininess: 16.0 },
            Tissue::Muscle => Self { srgb: [0.74, 0.20, 0.17], specular: 0.15, shininess: 16.0 },
            Tissue::Bone => Self { srgb: [0.95, 0.93, 0.84], specular: 0.1, shininess: 12.0 },
            Tissue::Other => Self { srgb: [0.55, 0.55, 0.57], specular: 0.1, shininess: 12.0 },
        }
    }

    /// Bone marrow, the core of a cut bone.
    pub fn marrow() -> Self {
        Self { srgb: [0.80, 0.56, 0.36], specular: 0.05, shininess: 8.0 }
    }

    /// The steel of the haptic tool.
    pub fn tool() -> Self {
        Self { srgb: [0.72, 0.75, 0.80], specular: 0.9, shininess: 90.0 }
    }

    /// Colour of a tissue's springs in the wireframe, linear RGBA (alpha for blending).
    pub fn spring_rgba(tissue: Tissue) -> [f32; 4] {
        let [r, g, b] = match tissue {
            Tissue::Skin => [1.0, 0.78, 0.68],
            Tissue::Fat => [1.0, 0.90, 0.40],
            Tissue::Muscle => [0.95, 0.35, 0.32],
            Tissue::Bone => [0.95, 0.95, 0.88],
            Tissue::Other => [0.7, 0.7, 0.7],
        };
        [srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b), 0.4]
    }
}
