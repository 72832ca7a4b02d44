//! Absolute ceilings on what a device may be asked to do, per device class.
//!
//! A device (or a plugin) reports its own limits in [`DeviceInfo`]; the haptics process never
//! uses more than the ceiling of the device's class, whatever it reports. The force ceiling is
//! the force a device holds continuously (a press is held for seconds), not its peak. The
//! Touch family's and the omega's figures are the vendors' data sheets (3D Systems Touch and
//! Touch X, Force Dimension omega.3: continuous force, and the stiffness of the device's
//! softest axis); the others are the device specifications of CHAI3D 3.2
//! (`src/devices/CPhantomDevices.cpp` and `src/devices/CDeltaDevices.cpp`, the values CHAI3D
//! itself renders with). The table with its sources is in `docs/haptics.md`. A device whose name matches no class gets
//! [`UNLISTED`], the ceilings of a Force Dimension omega.3 (CHAI3D's default for a device it
//! cannot identify).

use super::DeviceInfo;

/// A device class and the most any device of it may be asked to render.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceClass {
    /// The class as the operator knows it, e.g. `"PHANTOM Omni"`.
    pub name: &'static str,
    /// Lower-case fragments of a device name that put it in this class (any one matches).
    pub matches: &'static [&'static str],
    /// Largest force norm, N.
    pub max_force_n: f64,
    /// Largest stiffness rendered, N/m.
    pub max_stiffness_n_per_m: f64,
    /// Largest viscous damping rendered, N s/m.
    pub max_damping_n_s_per_m: f64,
    /// Largest workspace radius, m: a pose farther from the centre is a fault.
    pub workspace_radius_m: f64,
}

/// The classes Lamina knows, first match wins (more specific names first).
pub const DEVICE_CLASSES: &[DeviceClass] = &[
    DeviceClass {
        name: "PHANTOM Desktop / Touch X",
        matches: &["touch x", "phantom desktop"],
        // Data sheet: 7.9 N peak, 1.75 N continuous; stiffness 1.86 / 2.35 / 1.48 N/mm (x, y, z).
        max_force_n: 1.75,
        max_stiffness_n_per_m: 1480.0,
        max_damping_n_s_per_m: 5.0,
        workspace_radius_m: 0.10,
    },
    DeviceClass {
        name: "PHANTOM Omni",
        matches: &["omni"],
        // The Touch's mechanism: 3.3 N peak, 0.88 N continuous; 1.26 / 2.31 / 1.02 N/mm.
        max_force_n: 0.88,
        max_stiffness_n_per_m: 1020.0,
        max_damping_n_s_per_m: 5.0,
        workspace_radius_m: 0.10,
    },
    DeviceClass {
        name: "Touch",
        matches: &["touch"],
        // Data sheet: 3.3 N peak, 0.88 N continuous; stiffness 1.26 / 2.31 / 1.02 N/mm.
        max_force_n: 0.88,
        max_stiffness_n_per_m: 1020.0,
        max_damping_n_s_per_m: 4.0,
        workspace_radius_m: 0.075,
    },
    DeviceClass {
        name: "PHANTOM Premium 1.5",
        matches: &["premium 1.5"],
        max_force_n: 8.5,
        max_stiffness_n_per_m: 800.0,
        max_damping_n_s_per_m: 5.0,
        workspace_radius_m: 0.12,
    },
    DeviceClass {
        name: "PHANTOM Premium 3.0",
        matches: &["premium 3.0"],
        max_force_n: 22.0,
        max_stiffness_n_per_m: 1000.0,
        max_damping_n_s_per_m: 5.0,
        workspace_radius_m: 0.25,
    },
    DeviceClass {
        name: "Novint Falcon",
        matches: &["falcon"],
        max_force_n: 8.0,
        max_stiffness_n_per_m: 3000.0,
        max_damping_n_s_per_m: 20.0,
        workspace_radius_m: 0.04,
    },
    DeviceClass {
        name: "Force Dimension delta.3",
        matches: &["delta.3"],
        max_force_n: 20.0,
        max_stiffness_n_per_m: 5000.0,
        max_damping_n_s_per_m: 30.0,
        workspace_radius_m: 0.15,
    },
    DeviceClass {
        name: "Force Dimension omega.x",
        matches: &["omega"],
        // Data sheet (omega.3): 12 N continuous; closed-loop stiffness 14.5 N/mm.
        max_force_n: 12.0,
        max_stiffness_n_per_m: 14_500.0,
        max_damping_n_s_per_m: 30.0,
        workspace_radius_m: 0.075,
    },
    DeviceClass {
        name: "Force Dimension sigma.7",
        matches: &["sigma"],
        max_force_n: 12.0,
        max_stiffness_n_per_m: 4000.0,
        max_damping_n_s_per_m: 30.0,
        workspace_radius_m: 0.075,
    },
];

/// The class of a device whose name matches none of [`DEVICE_CLASSES`] (the null and
/// scripted devices among them): an omega.3's figures, with the workspace of the largest
/// listed device (0.25 m).
pub const UNLISTED: DeviceClass = DeviceClass {
    name: "unlisted device",
    matches: &[],
    max_force_n: 12.0,
    max_stiffness_n_per_m: 5000.0,
    max_damping_n_s_per_m: 30.0,
    workspace_radius_m: 0.25,
};

impl DeviceClass {
    /// The class of a device called `name` (case-insensitive), [`UNLISTED`] when none matches.
    ///
    /// # Examples
    ///
    /// ```
    /// use lamina_haptics::device::DeviceClass;
    ///
    /// assert_eq!(DeviceClass::of("SensAble PHANTOM Omni").max_force_n, 0.88);
    /// assert_eq!(DeviceClass::of("3D Systems Touch X").max_force_n, 1.75);
    /// assert_eq!(DeviceClass::of("my bench rig").name, "unlisted device");
    /// ```
    pub fn of(name: &str) -> &'static DeviceClass {
        let lower = name.to_lowercase();
        DEVICE_CLASSES.iter().find(|c| c.matches.iter().any(|m| lower.contains(m))).unwrap_or(&UNLISTED)
    }
}

/// One reported limit above its class ceiling, and the ceiling used instead.
#[derive(Debug, Clone, PartialEq)]
pub struct LimitClamp {
    /// Which limit: `max force`, `max stiffness`, `max damping` or `workspace radius`.
    pub limit: &'static str,
    /// Its unit: `N`, `N/m`, `N s/m` or `m`.
    pub unit: &'static str,
    /// What the device reported.
    pub reported: f64,
    /// The class ceiling used.
    pub ceiling: f64,
    /// The class.
    pub class: &'static str,
}

impl core::fmt::Display for LimitClamp {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(
            f,
            "{} {} {} reported, above the {} ceiling: {} {} used",
            self.limit,
            show_number(self.reported),
            self.unit,
            self.class,
            show_number(self.ceiling),
            self.unit
        )
    }
}

/// `info` held to its class ceilings, and each limit that was lowered.
///
/// # Examples
///
/// ```
/// use lamina_haptics::device::{DeviceInfo, within_ceilings};
///
/// let lying = DeviceInfo {
///     name: "PHANTOM Omni".into(),
///     max_force_n: 1e308,
///     max_stiffness_n_per_m: 500.0,
///     max_damping_n_s_per_m: 2.0,
///     workspace_radius_m: 0.08,
/// };
/// let (held, clamps) = within_ceilings(&lying);
/// assert_eq!(held.max_force_n, 0.88);
/// assert_eq!((clamps.len(), clamps[0].limit), (1, "max force"));
/// ```
pub fn within_ceilings(info: &DeviceInfo) -> (DeviceInfo, Vec<LimitClamp>) {
    let class = DeviceClass::of(&info.name);
    let mut held = info.clone();
    let mut clamps = Vec::new();
    let fields: [(&'static str, &'static str, &mut f64, f64); 4] = [
        ("max force", "N", &mut held.max_force_n, class.max_force_n),
        ("max stiffness", "N/m", &mut held.max_stiffness_n_per_m, class.max_stiffness_n_per_m),
        ("max damping", "N s/m", &mut held.max_damping_n_s_per_m, class.max_damping_n_s_per_m),
        ("workspace radius", "m", &mut held.workspace_radius_m, class.workspace_radius_m),
    ];
    for (limit, unit, value, ceiling) in fields {
        // A NaN limit is no limit: it is replaced too.
        if value.is_nan() || *value > ceiling {
            clamps.push(LimitClamp { limit, unit, reported: *value, ceiling, class: class.name });
            *value = ceiling;
        }
    }
    (held, clamps)
}

/// `v` as a user reads it in a message: plain up to six digits before or after the point,
/// scientific notation beyond (`1e300`, never 301 digits).
///
/// # Examples
///
/// ```
/// use lamina_haptics::device::show_number;
///
/// assert_eq!(show_number(8.5), "8.5");
/// assert_eq!(show_number(1e300), "1e300");
/// assert_eq!(show_number(-5.0), "-5");
/// assert_eq!(show_number(f64::NAN), "NaN");
/// ```
pub fn show_number(v: f64) -> String {
    let a = v.abs();
    if a.is_finite() && a != 0.0 && !(1e-6..1e6).contains(&a) { format!("{v:e}") } else { format!("{v}") }
}

/// Norm of a 3-vector without overflow: components up to `f64::MAX` give their finite norm
/// when it fits (the naive square overflows to infinity). NaN when a component is NaN.
pub(crate) fn norm3(v: [f64; 3]) -> f64 {
    if v.iter().any(|c| c.is_nan()) {
        return f64::NAN;
    }
    let m = v.iter().fold(0.0f64, |a, c| a.max(c.abs()));
    if m == 0.0 || !m.is_finite() {
        return m;
    }
    let s = v.map(|c| c / m);
    m * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norm3_does_not_overflow_works() {
        assert_eq!(norm3([3.0, 4.0, 0.0]), 5.0);
        assert_eq!(norm3([0.0; 3]), 0.0);
        let big = norm3([1e308, 0.0, 0.0]);
        assert_eq!(big, 1e308, "the naive sqrt(x^2) is infinite here");
        assert_eq!(norm3([f64::INFINITY, 0.0, 0.0]), f64::INFINITY);
        assert!(norm3([f64::NAN, 1.0, 0.0]).is_nan(), "a NaN never passes for a small force");
    }
}
