//! compute_view_matrix, compute_view_matrix_from_yaw_pitch, compute_projection_matrix:
//! PyBullet's formulas (Bullet's `b3ComputeViewMatrixFrom*` and `b3ComputeProjectionMatrixFOV`)
//! in f64, column-major, OpenGL conventions. PyBullet computes in f32; the results agree
//! within 1e-5 (tests/fixtures/camera_matrices.json holds pybullet 3.2.7's own numbers).

/// A 4×4 matrix, column-major: element (row r, column c) is `m[c * 4 + r]`.
pub type Mat4 = [f64; 16];

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = dot(a, a).sqrt();
    if n > 0.0 {
        [a[0] / n, a[1] / n, a[2] / n]
    } else {
        a
    }
}

/// Why a view cannot be computed from these vectors (eye at the target, up along the view).
pub fn view_problem(eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Option<&'static str> {
    let f = sub(target, eye);
    if dot(f, f) == 0.0 {
        return Some("camera_eye_position and camera_target_position must differ");
    }
    if dot(up, up) == 0.0 {
        return Some("camera_up_vector must not be zero");
    }
    let s = cross(normalize(f), normalize(up));
    if dot(s, s) < 1e-12 {
        return Some("camera_up_vector must not be parallel to the viewing direction");
    }
    None
}

/// gluLookAt, as PyBullet's computeViewMatrix.
pub fn view_matrix(eye: [f64; 3], target: [f64; 3], up: [f64; 3]) -> Mat4 {
    let f = normalize(sub(target, eye));
    let s = normalize(cross(f, normalize(up)));
    let u = cross(s, f);
    [
        s[0], u[0], -f[0], 0.0, //
        s[1], u[1], -f[1], 0.0, //
        s[2], u[2], -f[2], 0.0, //
        -dot(s, eye), -dot(u, eye), dot(f, eye), 1.0,
    ]
}

/// Rotation matrix (row-major 3×3) of Bullet's `setEulerZYX(z, y, x)`: Rz(z)·Ry(y)·Rx(x).
fn euler_zyx(z: f64, y: f64, x: f64) -> [[f64; 3]; 3] {
    let (sz, cz) = z.sin_cos();
    let (sy, cy) = y.sin_cos();
    let (sx, cx) = x.sin_cos();
    [
        [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
        [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
        [-sy, cy * sx, cy * cx],
    ]
}

fn mul(m: [[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// PyBullet's computeViewMatrixFromYawPitchRoll with roll 0 (angles in degrees; `up_axis` 1
/// = y up, 2 = z up).
pub fn view_matrix_from_yaw_pitch(target: [f64; 3], distance: f64, yaw: f64, pitch: f64, up_axis: u8) -> Mat4 {
    let (yaw, pitch) = (yaw.to_radians(), pitch.to_radians());
    let (rot, mut eye, up) = if up_axis == 1 {
        (euler_zyx(0.0, yaw, -pitch), [0.0, 0.0, -distance], [0.0, 1.0, 0.0])
    } else {
        (euler_zyx(yaw, 0.0, pitch), [0.0, -distance, 0.0], [0.0, 0.0, 1.0])
    };
    eye = mul(rot, eye);
    let eye = [eye[0] + target[0], eye[1] + target[1], eye[2] + target[2]];
    view_matrix(eye, target, mul(rot, up))
}

/// PyBullet's computeProjectionMatrixFOV (fov in degrees, vertical).
pub fn projection_matrix(fov: f64, aspect: f64, near: f64, far: f64) -> Mat4 {
    let y = 1.0 / (fov.to_radians() / 2.0).tan();
    let x = y / aspect;
    [
        x, 0.0, 0.0, 0.0, //
        0.0, y, 0.0, 0.0, //
        0.0, 0.0, (far + near) / (near - far), -1.0, //
        0.0, 0.0, 2.0 * far * near / (near - far), 0.0,
    ]
}

/// The lens of every image nobody gave a projection for (get_camera_image without one, the
/// `sim://…/image` resource, the web viewer): fov 60°, the image's aspect, near 0.01, far 100.
pub fn default_projection(width: u32, height: u32) -> Mat4 {
    projection_matrix(60.0, f64::from(width) / f64::from(height), 0.01, 100.0)
}
