//! Length units of mesh files and the rule that infers them.
//!
//! Everything inside Lamina is in metres; a mesh file is in whatever unit its author used.
//! [`Units`] names that unit and converts to metres. When the caller does not say, the unit is
//! inferred with [`Units::infer`]: a bounding-box diagonal above
//! [`Units::INFER_MILLIMETRE_ABOVE`] (10 file units) means millimetres, anything else metres.
//! The rule fits Lamina's subject: a limb or organ is 0.01–2 m across, which is 10–2000 in
//! millimetres and below 10 in metres. Centimetre or inch files must be named explicitly.

use std::fmt;
use std::str::FromStr;

/// A length unit of the coordinates stored in a mesh file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Units {
    /// Metres (scale 1).
    Metre,
    /// Centimetres (scale 0.01).
    Centimetre,
    /// Millimetres (scale 0.001); the usual unit of medical-imaging surfaces.
    Millimetre,
    /// Inches (scale 0.0254).
    Inch,
}

impl Units {
    /// Bounding-box diagonal, in file units, above which [`Units::infer`] picks millimetres.
    pub const INFER_MILLIMETRE_ABOVE: f64 = 10.0;

    /// Metres per file unit: multiply a file coordinate by this to get metres.
    pub fn metres_per_unit(self) -> f64 {
        match self {
            Self::Metre => 1.0,
            Self::Centimetre => 0.01,
            Self::Millimetre => 0.001,
            Self::Inch => 0.0254,
        }
    }

    /// Infers the unit from a bounding-box diagonal given in file units: millimetres when it
    /// is above [`Units::INFER_MILLIMETRE_ABOVE`] (10), otherwise metres.
    pub fn infer(diagonal: f64) -> Self {
        if diagonal > Self::INFER_MILLIMETRE_ABOVE { Self::Millimetre } else { Self::Metre }
    }

    /// Short symbol: `m`, `cm`, `mm` or `in`.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::Metre => "m",
            Self::Centimetre => "cm",
            Self::Millimetre => "mm",
            Self::Inch => "in",
        }
    }

    /// Full name: `metre`, `centimetre`, `millimetre` or `inch`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Metre => "metre",
            Self::Centimetre => "centimetre",
            Self::Millimetre => "millimetre",
            Self::Inch => "inch",
        }
    }
}

impl fmt::Display for Units {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a unit name could not be parsed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum UnitsParseError {
    /// The text is none of the known names (`m`, `metre`, `meter`, `cm`, `mm`, `in`, `inch`, ...).
    #[error("unknown length unit {text:?} (expected m, cm, mm or in)")]
    Unknown {
        /// The text that was given.
        text: String,
    },
}

impl FromStr for Units {
    type Err = UnitsParseError;

    /// Parses a symbol or name, case-insensitively, British or American spelling, singular or
    /// plural: `m`, `metre`, `meters`, `cm`, `mm`, `millimetres`, `in`, `inch`, `inches`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let t = s.trim().to_ascii_lowercase();
        let t = t.strip_suffix("es").filter(|b| *b == "inch").unwrap_or(&t).to_string();
        let t = t.strip_suffix('s').filter(|b| b.len() > 2).unwrap_or(&t);
        match t {
            "m" | "metre" | "meter" => Ok(Self::Metre),
            "cm" | "centimetre" | "centimeter" => Ok(Self::Centimetre),
            "mm" | "millimetre" | "millimeter" => Ok(Self::Millimetre),
            "in" | "inch" => Ok(Self::Inch),
            _ => Err(UnitsParseError::Unknown { text: s.to_string() }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_parse_names_works() {
        for (s, u) in [
            ("m", Units::Metre),
            ("Metres", Units::Metre),
            ("meter", Units::Metre),
            ("cm", Units::Centimetre),
            ("mm", Units::Millimetre),
            ("millimeters", Units::Millimetre),
            ("in", Units::Inch),
            ("inches", Units::Inch),
            (" INCH ", Units::Inch),
        ] {
            assert_eq!(s.parse::<Units>(), Ok(u), "{s}");
        }
    }

    #[test]
    fn units_parse_unknown_fails() {
        assert!("furlong".parse::<Units>().is_err());
        assert!("".parse::<Units>().is_err());
        assert!("ms".parse::<Units>().is_err());
    }

    #[test]
    fn units_infer_rule_works() {
        assert_eq!(Units::infer(900.0), Units::Millimetre);
        assert_eq!(Units::infer(10.5), Units::Millimetre);
        assert_eq!(Units::infer(10.0), Units::Metre);
        assert_eq!(Units::infer(0.9), Units::Metre);
    }
}
