//! From the device frame to the model frame and back.

/// Maps the device frame (x toward the operator, y right, z up; origin at the workspace
/// centre) onto the model frame: `model = origin + position_scale · R · device`, and model
/// forces back onto the device: `device = force_scale · Rᵀ · model`.
///
/// # Examples
///
/// ```
/// use lamina_haptics::DeviceMapping;
///
/// // Lamina's scenes are y-up: the device's "up" (z) becomes the model's y.
/// let m = DeviceMapping::y_up_model([0.1, 0.05, 0.0]);
/// assert_eq!(m.to_model([0.0, 0.0, 0.01]), [0.1, 0.060000000000000005, 0.0]);
/// assert_eq!(m.force_to_device([0.0, 2.0, 0.0]), [0.0, 0.0, 2.0]);
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DeviceMapping {
    /// Model position of the device's workspace centre, m.
    pub origin_m: [f64; 3],
    /// Rotation from device to model axes, row-major (`model_i = Σ_j R[i][j] device_j`).
    pub rotation: [[f64; 3]; 3],
    /// Model metres per device metre. Default 1.
    pub position_scale: f64,
    /// Device newtons per model newton. Default 1.
    pub force_scale: f64,
}

impl DeviceMapping {
    /// The mapping for a y-up model: device x (toward the operator) → model z, device y
    /// (right) → model x, device z (up) → model y; scales 1.
    pub fn y_up_model(origin_m: [f64; 3]) -> Self {
        Self {
            origin_m,
            rotation: [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
            position_scale: 1.0,
            force_scale: 1.0,
        }
    }

    /// The mapping the core's topology message carries (the scene's `device_origin`,
    /// `device_scale` and `force_scale`, and the model's axes).
    ///
    /// # Examples
    ///
    /// ```
    /// use lamina_bridge::WireTool;
    /// use lamina_haptics::DeviceMapping;
    ///
    /// let tool = WireTool {
    ///     device_origin_m: [0.0, 0.25, 0.0],
    ///     device_rotation: [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0]],
    ///     position_scale: 2.0,
    ///     force_scale: 1.0,
    ///     ..WireTool::default()
    /// };
    /// // 12.5 cm up on the device is 25 cm up (model y) in the model.
    /// assert_eq!(DeviceMapping::from_wire(&tool).to_model([0.0, 0.0, 0.125]), [0.0, 0.5, 0.0]);
    /// ```
    pub fn from_wire(tool: &lamina_bridge::WireTool) -> Self {
        Self {
            origin_m: tool.device_origin_m,
            rotation: tool.device_rotation,
            position_scale: tool.position_scale,
            force_scale: tool.force_scale,
        }
    }

    fn rotate(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        [0, 1, 2].map(|i| r[i][0] * v[0] + r[i][1] * v[1] + r[i][2] * v[2])
    }

    fn rotate_back(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        [0, 1, 2].map(|j| r[0][j] * v[0] + r[1][j] * v[1] + r[2][j] * v[2])
    }

    /// Device position (m) → model position (m).
    pub fn to_model(&self, p: [f64; 3]) -> [f64; 3] {
        let q = self.rotate(p);
        [0, 1, 2].map(|i| self.origin_m[i] + self.position_scale * q[i])
    }

    /// Model position (m) → device position (m).
    pub fn to_device(&self, p: [f64; 3]) -> [f64; 3] {
        let d = [0, 1, 2].map(|i| (p[i] - self.origin_m[i]) / self.position_scale);
        self.rotate_back(d)
    }

    /// Model force (N) → device force (N).
    pub fn force_to_device(&self, f: [f64; 3]) -> [f64; 3] {
        self.rotate_back(f).map(|c| self.force_scale * c)
    }

    /// Model stiffness `∂F/∂x` (N/m) → the device's `∂F_dev/∂x_dev` (N/m):
    /// `force_scale · position_scale · Rᵀ K R`.
    pub fn stiffness_to_device(&self, k: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let r = &self.rotation;
        let s = self.force_scale * self.position_scale;
        let mut out = [[0.0; 3]; 3];
        for (a, row) in out.iter_mut().enumerate() {
            for (b, cell) in row.iter_mut().enumerate() {
                let mut sum = 0.0;
                for i in 0..3 {
                    for j in 0..3 {
                        sum += r[i][a] * k[i][j] * r[j][b];
                    }
                }
                *cell = s * sum;
            }
        }
        out
    }

    /// Device orientation (unit quaternion `[x, y, z, w]`, the stylus's rotation from its rest
    /// pose) → the same rotation in the model frame, `R q R⁻¹`: the stylus at rest is the
    /// identity in both, so a scalpel at rest has its edge straight up in the model (the wire's
    /// convention, docs/wire-protocol.md), and a turn about a device axis is the turn about
    /// that axis mapped into the model.
    pub fn orientation_to_model(&self, q: [f64; 4]) -> [f64; 4] {
        let r = rotation_quat(&self.rotation);
        quat_mul(quat_mul(r, q), [-r[0], -r[1], -r[2], r[3]])
    }
}

/// Hamilton product `a ⊗ b` of `[x, y, z, w]` quaternions.
fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// The unit quaternion `[x, y, z, w]` of a rotation matrix (Shepperd's method).
fn rotation_quat(r: &[[f64; 3]; 3]) -> [f64; 4] {
    let trace = r[0][0] + r[1][1] + r[2][2];
    if trace > 0.0 {
        let s = (trace + 1.0).sqrt() * 2.0;
        [(r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, 0.25 * s]
    } else if r[0][0] > r[1][1] && r[0][0] > r[2][2] {
        let s = (1.0 + r[0][0] - r[1][1] - r[2][2]).sqrt() * 2.0;
        [0.25 * s, (r[0][1] + r[1][0]) / s, (r[0][2] + r[2][0]) / s, (r[2][1] - r[1][2]) / s]
    } else if r[1][1] > r[2][2] {
        let s = (1.0 + r[1][1] - r[0][0] - r[2][2]).sqrt() * 2.0;
        [(r[0][1] + r[1][0]) / s, 0.25 * s, (r[1][2] + r[2][1]) / s, (r[0][2] - r[2][0]) / s]
    } else {
        let s = (1.0 + r[2][2] - r[0][0] - r[1][1]).sqrt() * 2.0;
        [(r[0][2] + r[2][0]) / s, (r[1][2] + r[2][1]) / s, 0.25 * s, (r[1][0] - r[0][1]) / s]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12)
    }

    #[test]
    fn mapping_y_up_is_a_proper_rotation_works() {
        let r = DeviceMapping::y_up_model([0.0; 3]).rotation;
        let det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) - r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0])
            + r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
        assert_eq!(det, 1.0, "right-handed frames map onto right-handed frames");
        let m = DeviceMapping::y_up_model([0.0; 3]);
        assert!(close(m.to_model([1.0, 0.0, 0.0]), [0.0, 0.0, 1.0]), "toward the operator is model +z");
        assert!(close(m.to_model([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0]), "right is model +x");
        assert!(close(m.to_model([0.0, 0.0, 1.0]), [0.0, 1.0, 0.0]), "up is model +y");
    }

    #[test]
    fn mapping_round_trips_and_preserves_work_works() {
        let m = DeviceMapping { position_scale: 2.0, force_scale: 0.5, ..DeviceMapping::y_up_model([0.1, 0.2, 0.3]) };
        let p = [0.01, -0.02, 0.03];
        assert!(close(m.to_device(m.to_model(p)), p));
        // Stiffness maps as Rᵀ K R times both scales: a model spring -k along y seen as a
        // device spring along z of -k · position_scale · force_scale.
        let mut k = [[0.0; 3]; 3];
        k[1][1] = -100.0;
        let kd = m.stiffness_to_device(&k);
        assert_eq!(kd[2][2], -100.0);
        assert_eq!(kd[0][0] + kd[1][1], 0.0);
        // Linear model evaluated in either frame gives the same device force.
        let dx_dev = [0.0, 0.0, 0.001];
        let dx_model = [0, 1, 2].map(|i| m.to_model(dx_dev)[i] - m.to_model([0.0; 3])[i]);
        let f_model = [0, 1, 2].map(|i| (0..3).map(|j| k[i][j] * dx_model[j]).sum::<f64>());
        let via_model = m.force_to_device(f_model);
        let via_device = [0, 1, 2].map(|i| (0..3).map(|j| kd[i][j] * dx_dev[j]).sum::<f64>());
        assert!(close(via_model, via_device));
    }

    #[test]
    fn mapping_orientation_matches_rotation_works() {
        let m = DeviceMapping::y_up_model([0.0; 3]);
        // The stylus at rest is the identity in the model too.
        let q = m.orientation_to_model([0.0, 0.0, 0.0, 1.0]);
        assert!(close([q[0], q[1], q[2]], [0.0; 3]) && (q[3] - 1.0).abs() < 1e-12);
        // A quarter turn about the device's up axis (z) is a quarter turn about the model's
        // up axis (y): it takes model z (device x) to model x (device y).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let q = m.orientation_to_model([0.0, 0.0, h, h]);
        let rotate = |v: [f64; 3]| {
            let qv = quat_mul(quat_mul(q, [v[0], v[1], v[2], 0.0]), [-q[0], -q[1], -q[2], q[3]]);
            [qv[0], qv[1], qv[2]]
        };
        assert!(close(rotate([0.0, 1.0, 0.0]), [0.0, 1.0, 0.0]), "the up axis stays");
        let device_y_in_model = m.to_model([0.0, 1.0, 0.0]);
        let origin = m.to_model([0.0; 3]);
        let expected = [0, 1, 2].map(|c| device_y_in_model[c] - origin[c]);
        assert!(close(rotate([0.0, 0.0, 1.0]), expected), "{:?} vs {expected:?}", rotate([0.0, 0.0, 1.0]));
        let norm = q.iter().map(|c| c * c).sum::<f64>();
        assert!((norm - 1.0).abs() < 1e-12);
    }
}
