//! The 2-D layer: background gradient, a text panel (a built-in 5 × 7 bitmap font, so no font
//! files or text crates are needed) and the tissue legend. Everything becomes coloured
//! triangles in normalised device coordinates.

use bytemuck::{Pod, Zeroable};

use crate::material::{Material, srgb_to_linear};
use crate::view_model::Tissue;

/// A vertex of the 2-D layer.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct FlatVertex {
    /// Position in normalised device coordinates (`-1..1`, y up).
    pub position: [f32; 2],
    /// Linear RGBA (alpha-blended).
    pub color: [f32; 4],
}

/// Glyph rows (5 bits each, most significant bit left), top to bottom. Characters without a
/// glyph are drawn as `?`.
fn glyph(c: char) -> [u8; 7] {
    known_glyph(c).unwrap_or(QUESTION_MARK)
}

const QUESTION_MARK: [u8; 7] = [0x0E, 0x11, 0x01, 0x02, 0x04, 0, 0x04];

/// Whether the built-in font draws `c` (letters in either case, digits, space and
/// `. , : / % - + = ( ) _ [ ] ? ' < > *`).
pub fn has_glyph(c: char) -> bool {
    known_glyph(c).is_some()
}

fn known_glyph(c: char) -> Option<[u8; 7]> {
    Some(match c.to_ascii_uppercase() {
        '0' => [0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E],
        '1' => [0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E],
        '2' => [0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F],
        '3' => [0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E],
        '4' => [0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02],
        '5' => [0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E],
        '6' => [0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E],
        '7' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08],
        '8' => [0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E],
        '9' => [0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C],
        'A' => [0x0E, 0x11, 0x11, 0x11, 0x1F, 0x11, 0x11],
        'B' => [0x1E, 0x11, 0x11, 0x1E, 0x11, 0x11, 0x1E],
        'C' => [0x0E, 0x11, 0x10, 0x10, 0x10, 0x11, 0x0E],
        'D' => [0x1C, 0x12, 0x11, 0x11, 0x11, 0x12, 0x1C],
        'E' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x1F],
        'F' => [0x1F, 0x10, 0x10, 0x1E, 0x10, 0x10, 0x10],
        'G' => [0x0E, 0x11, 0x10, 0x17, 0x11, 0x11, 0x0F],
        'H' => [0x11, 0x11, 0x11, 0x1F, 0x11, 0x11, 0x11],
        'I' => [0x0E, 0x04, 0x04, 0x04, 0x04, 0x04, 0x0E],
        'J' => [0x07, 0x02, 0x02, 0x02, 0x02, 0x12, 0x0C],
        'K' => [0x11, 0x12, 0x14, 0x18, 0x14, 0x12, 0x11],
        'L' => [0x10, 0x10, 0x10, 0x10, 0x10, 0x10, 0x1F],
        'M' => [0x11, 0x1B, 0x15, 0x15, 0x11, 0x11, 0x11],
        'N' => [0x11, 0x11, 0x19, 0x15, 0x13, 0x11, 0x11],
        'O' => [0x0E, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'P' => [0x1E, 0x11, 0x11, 0x1E, 0x10, 0x10, 0x10],
        'Q' => [0x0E, 0x11, 0x11, 0x11, 0x15, 0x12, 0x0D],
        'R' => [0x1E, 0x11, 0x11, 0x1E, 0x14, 0x12, 0x11],
        'S' => [0x0F, 0x10, 0x10, 0x0E, 0x01, 0x01, 0x1E],
        'T' => [0x1F, 0x04, 0x04, 0x04, 0x04, 0x04, 0x04],
        'U' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x11, 0x0E],
        'V' => [0x11, 0x11, 0x11, 0x11, 0x11, 0x0A, 0x04],
        'W' => [0x11, 0x11, 0x11, 0x15, 0x15, 0x15, 0x0A],
        'X' => [0x11, 0x11, 0x0A, 0x04, 0x0A, 0x11, 0x11],
        'Y' => [0x11, 0x11, 0x11, 0x0A, 0x04, 0x04, 0x04],
        'Z' => [0x1F, 0x01, 0x02, 0x04, 0x08, 0x10, 0x1F],
        ' ' => [0; 7],
        '.' => [0, 0, 0, 0, 0, 0x0C, 0x0C],
        ',' => [0, 0, 0, 0, 0x0C, 0x04, 0x08],
        ':' => [0, 0x0C, 0x0C, 0, 0x0C, 0x0C, 0],
        '/' => [0, 0x01, 0x02, 0x04, 0x08, 0x10, 0],
        '%' => [0x18, 0x19, 0x02, 0x04, 0x08, 0x13, 0x03],
        '-' => [0, 0, 0, 0x1F, 0, 0, 0],
        '+' => [0, 0x04, 0x04, 0x1F, 0x04, 0x04, 0],
        '=' => [0, 0, 0x1F, 0, 0x1F, 0, 0],
        '(' => [0x02, 0x04, 0x08, 0x08, 0x08, 0x04, 0x02],
        ')' => [0x08, 0x04, 0x02, 0x02, 0x02, 0x04, 0x08],
        '_' => [0, 0, 0, 0, 0, 0, 0x1F],
        '[' => [0x0E, 0x08, 0x08, 0x08, 0x08, 0x08, 0x0E],
        ']' => [0x0E, 0x02, 0x02, 0x02, 0x02, 0x02, 0x0E],
        '\'' => [0x04, 0x04, 0x08, 0, 0, 0, 0],
        '<' => [0x02, 0x04, 0x08, 0x10, 0x08, 0x04, 0x02],
        '>' => [0x08, 0x04, 0x02, 0x01, 0x02, 0x04, 0x08],
        '*' => [0, 0x04, 0x15, 0x0E, 0x15, 0x04, 0],
        '?' => QUESTION_MARK,
        _ => return None,
    })
}

/// Builds the 2-D layer for an image of `width × height` pixels.
#[derive(Debug, Clone)]
pub struct Overlay {
    width: f32,
    height: f32,
    /// Size of one font pixel in image pixels.
    pub scale: f32,
    /// The triangles built so far.
    pub vertices: Vec<FlatVertex>,
}

/// Linear RGBA from sRGB components and alpha.
pub fn rgba(srgb: [f32; 3], alpha: f32) -> [f32; 4] {
    [srgb_to_linear(srgb[0]), srgb_to_linear(srgb[1]), srgb_to_linear(srgb[2]), alpha]
}

impl Overlay {
    /// An empty layer; the font scale grows with the image height (1 below 720 px, 2 at 720 px…).
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width: width as f32,
            height: height as f32,
            scale: (height as f32 / 360.0).floor().max(1.0),
            vertices: Vec::new(),
        }
    }

    /// Height of one text line in pixels.
    pub fn line_height(&self) -> f32 {
        10.0 * self.scale
    }

    /// Width of `text` in pixels.
    pub fn text_width(&self, text: &str) -> f32 {
        text.chars().count() as f32 * 6.0 * self.scale
    }

    fn ndc(&self, x: f32, y: f32) -> [f32; 2] {
        [x / self.width * 2.0 - 1.0, 1.0 - y / self.height * 2.0]
    }

    /// A quad with a colour per corner (top-left, top-right, bottom-right, bottom-left), pixels.
    pub fn quad(&mut self, x: f32, y: f32, w: f32, h: f32, colors: [[f32; 4]; 4]) {
        let corners = [self.ndc(x, y), self.ndc(x + w, y), self.ndc(x + w, y + h), self.ndc(x, y + h)];
        for k in [0, 1, 2, 0, 2, 3] {
            self.vertices.push(FlatVertex { position: corners[k], color: colors[k] });
        }
    }

    /// A filled rectangle, pixels from the top-left corner.
    pub fn rect(&mut self, x: f32, y: f32, w: f32, h: f32, color: [f32; 4]) {
        self.quad(x, y, w, h, [color; 4]);
    }

    /// The whole image as a vertical gradient from `top` to `bottom`.
    pub fn background(&mut self, top: [f32; 4], bottom: [f32; 4]) {
        self.quad(0.0, 0.0, self.width, self.height, [top, top, bottom, bottom]);
    }

    /// Draws `text` with its top-left corner at `(x, y)` pixels; returns the width drawn.
    pub fn text(&mut self, x: f32, y: f32, text: &str, color: [f32; 4]) -> f32 {
        let s = self.scale;
        for (k, c) in text.chars().enumerate() {
            let rows = glyph(c);
            let gx = x + k as f32 * 6.0 * s;
            for (r, bits) in rows.iter().enumerate() {
                // Runs of set bits become one rectangle each.
                let mut col = 0;
                while col < 5 {
                    if bits & (0x10 >> col) != 0 {
                        let start = col;
                        while col < 5 && bits & (0x10 >> col) != 0 {
                            col += 1;
                        }
                        self.rect(gx + start as f32 * s, y + r as f32 * s, (col - start) as f32 * s, s, color);
                    } else {
                        col += 1;
                    }
                }
            }
        }
        self.text_width(text)
    }

    /// A translucent panel with `lines` of text at the top-left corner.
    pub fn panel(&mut self, lines: &[String]) {
        let pad = 4.0 * self.scale;
        self.panel_at(pad, pad, lines, 0.45);
    }

    /// A translucent panel (background `alpha`) with `lines` of text, its top-left corner at
    /// `(x, y)` pixels; returns its width and height.
    pub fn panel_at(&mut self, x: f32, y: f32, lines: &[String], alpha: f32) -> (f32, f32) {
        let pad = 4.0 * self.scale;
        let width = lines.iter().map(|l| self.text_width(l)).fold(0.0, f32::max) + 2.0 * pad;
        let height = lines.len() as f32 * self.line_height() + 2.0 * pad - 3.0 * self.scale;
        self.rect(x, y, width, height, [0.0, 0.0, 0.0, alpha]);
        let ink = rgba([0.92, 0.95, 0.97], 1.0);
        for (i, line) in lines.iter().enumerate() {
            self.text(x + pad, y + pad + i as f32 * self.line_height(), line, ink);
        }
        (width, height)
    }

    /// A panel of `lines` centred in the image (the key list).
    pub fn centred_panel(&mut self, lines: &[String]) {
        let pad = 4.0 * self.scale;
        let width = lines.iter().map(|l| self.text_width(l)).fold(0.0, f32::max) + 2.0 * pad;
        let height = lines.len() as f32 * self.line_height() + 2.0 * pad - 3.0 * self.scale;
        let x = ((self.width - width) * 0.5).max(0.0).floor();
        let y = ((self.height - height) * 0.5).max(0.0).floor();
        self.panel_at(x, y, lines, 0.7);
    }

    /// Colour swatches and names of the tissues along the bottom-left edge.
    pub fn legend(&mut self) {
        let s = self.scale;
        let y = self.height - 14.0 * s;
        let mut x = 4.0 * s;
        let ink = rgba([0.92, 0.95, 0.97], 1.0);
        for (tissue, name) in
            [(Tissue::Skin, "SKIN"), (Tissue::Fat, "FAT"), (Tissue::Muscle, "MUSCLE"), (Tissue::Bone, "BONE")]
        {
            let m = Material::cut_face(tissue);
            self.rect(x - s, y - s, 9.0 * s, 9.0 * s, [0.0, 0.0, 0.0, 0.6]);
            self.rect(x, y, 7.0 * s, 7.0 * s, rgba(m.srgb, 1.0));
            x += 10.0 * s;
            x += self.text(x, y, name, ink) + 6.0 * s;
        }
    }
}
