//! Constants of the XML model format, shared by its reader and writer.

/// The `version` attribute of `<lamina-model>` this code reads and writes.
pub const MODEL_FORMAT_VERSION: &str = "1";

/// The `units` attribute of `<lamina-model>`: every value in the file is SI (lengths in m,
/// masses in kg, times in s, forces in N, stiffnesses in N/m, damping in N·s/m).
pub const MODEL_UNITS: &str = "SI (m, kg, s, N)";

/// The PPU export of a bilinear spring is exact for lengths in `[CompLen, StretLen]`; the
/// writer sets `CompLen = 0` m ...
pub const PPU_COMP_LEN: f64 = 0.0;

/// ... and `StretLen = PPU_STRET_LEN_FACTOR × TurnLen` (TurnLen ≥ RestLen always): a tissue
/// spring is not stretched to four times its turning length.
pub const PPU_STRET_LEN_FACTOR: f64 = 4.0;

/// Element and attribute names, in one place so reader, writer and docs agree.
pub(crate) mod names {
    pub const ROOT: &str = "lamina-model";
    pub const PROVENANCE: &str = "provenance";
    pub const ENTRY: &str = "entry";
    pub const LAYERS: &str = "layers";
    pub const LAYER: &str = "layer";
    pub const MATERIALS: &str = "materials";
    pub const MATERIAL: &str = "material";
    pub const NODES: &str = "nodes";
    pub const NODE: &str = "node";
    pub const SPRINGS: &str = "springs";
    pub const SPRING: &str = "spring";
    pub const PPU: &str = "ppu";
    pub const PPU_FIRST: &str = "first";
    pub const PPU_SECOND: &str = "second";
    pub const SURFACES: &str = "surfaces";
    pub const SURFACE: &str = "surface";
    pub const TRIANGLES: &str = "triangles";
    pub const GRID: &str = "grid";
    pub const CELLS: &str = "cells";
    pub const CELL: &str = "cell";
    pub const CELL_KINDS: &str = "tetra, wedge, hexahedron";

    pub const LAW_LINEAR: &str = "linear";
    pub const LAW_BILINEAR: &str = "bilinear";
    pub const LAWS: &str = "linear, bilinear";
    pub const KINDS: &str = "free, fixed, kinematic";
    pub const TISSUES: &str = "skin, fat, muscle, bone, other";
}

/// Appends `s` to `out` escaped for a double-quoted attribute value such that a conforming
/// reader gives back exactly `s`: markup characters become entities and tab, line feed,
/// carriage return and other control characters become character references (literal ones
/// would be normalised to spaces). Returns `false` if `s` holds a NUL, which XML cannot carry.
pub(crate) fn escape_attribute(s: &str, out: &mut String) -> bool {
    let mut clean = 0;
    for (i, c) in s.char_indices() {
        let rep: Option<&str> = match c {
            '&' => Some("&amp;"),
            '<' => Some("&lt;"),
            '>' => Some("&gt;"),
            '"' => Some("&quot;"),
            '\0' => return false,
            c if (c as u32) < 0x20 => None,
            _ => continue,
        };
        out.push_str(&s[clean..i]);
        match rep {
            Some(r) => out.push_str(r),
            None => {
                out.push_str("&#");
                out.push_str(itoa::Buffer::new().format(c as u32));
                out.push(';');
            }
        }
        clean = i + c.len_utf8();
    }
    out.push_str(&s[clean..]);
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escape_attribute_markup_and_controls_works() {
        let mut out = String::new();
        assert!(escape_attribute("a&b<c>\"d'\te\nf\rg\u{1}é", &mut out));
        assert_eq!(out, "a&amp;b&lt;c&gt;&quot;d'&#9;e&#10;f&#13;g&#1;é");
        assert!(!escape_attribute("nul\0", &mut String::new()));
    }
}
