//! The adapter side of robots: reading a URDF and its meshes from the workspace (the world
//! never reads files), the built-in assets, and writing generated URDFs.
//!
//! A URDF's meshes are resolved against the URDF's folder: relative names directly,
//! `package://pkg/rest` by trying `rest` and `pkg/rest` in the URDF's folder and each folder
//! above it up to the workspace root, `file://` as a path. Every candidate goes through the
//! sandbox; a missing or unreadable mesh is an error, never a silently missing collider.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::command::{Blob, Command};
use crate::mcp::lenient::{NumList, Positive};
use crate::mcp::params;
use crate::value::{self, Refusal};
use crate::workspace::Sandbox;
use crate::world::urdf::mesh_names;

/// Largest URDF file read.
pub const MAX_URDF_BYTES: u64 = 8 << 20;
/// Largest total of a robot's mesh files.
pub const MAX_MESH_BYTES: u64 = 64 << 20;

/// Built into the binary, found by name when the workspace has no such file.
const BUILTIN: [(&str, &str); 3] = [
    ("plane.urdf", include_str!("../assets/plane.urdf")),
    ("cube.urdf", include_str!("../assets/cube.urdf")),
    ("sphere.urdf", include_str!("../assets/sphere.urdf")),
];

/// A built-in asset's text by its name.
pub fn builtin(name: &str) -> Option<&'static str> {
    BUILTIN.iter().find(|(n, _)| *n == name).map(|(_, text)| *text)
}

/// The file's bytes, refused (naming it) when over `limit` or unreadable; MJCF meshes use it too.
pub(crate) fn read_limited(path: &Path, shown: &str, limit: u64) -> Result<Vec<u8>, Refusal> {
    let size = std::fs::metadata(path).map(|m| m.len()).unwrap_or(u64::MAX);
    if size > limit {
        return Err(format!("{shown} is {size} bytes; the limit is {limit}"));
    }
    std::fs::read(path).map_err(|e| format!("could not read {shown}: {e}"))
}

/// Builds load_urdf's command from its arguments (as a loaded file's robot entry gives them).
pub fn decide_load_urdf(sandbox: &Sandbox, a: &value::Args) -> Result<Command, Refusal> {
    load_urdf_command(sandbox, &params::parse("load_urdf", a)?)
}

/// Builds load_urdf's command: the URDF text and every mesh it names, read now, travel in it.
pub fn load_urdf_command(sandbox: &Sandbox, p: &params::LoadUrdf) -> Result<Command, Refusal> {
    let user = p.file_path.0.clone();
    let position = p.position.as_ref().map_or([0.0; 3], |v| v.0);
    let orientation = p.orientation.as_ref().map_or([0.0, 0.0, 0.0, 1.0], |q| q.0);
    let fixed_base = p.use_fixed_base.as_ref().is_some_and(|b| b.0);
    let (text, dir) = match sandbox.existing(&user) {
        Ok(path) => {
            let bytes = read_limited(&path, &format!("file_path {user}"), MAX_URDF_BYTES)?;
            let dir = path.parent().map(Path::to_path_buf).unwrap_or_else(|| sandbox.workspace.clone());
            (bytes, dir)
        }
        Err(why) => match builtin(&user) {
            Some(text) => (text.as_bytes().to_vec(), sandbox.workspace.clone()),
            None => return Err(why),
        },
    };
    let utf8 = std::str::from_utf8(&text).map_err(|_| format!("file_path {user} is not a valid URDF: it is not UTF-8 text"))?;
    let mut meshes = BTreeMap::new();
    let mut total = 0u64;
    for name in mesh_names(utf8)? {
        let path = resolve_mesh(sandbox, &dir, &name, &user)?;
        let bytes = read_limited(&path, &format!("mesh {name}"), MAX_MESH_BYTES.saturating_sub(total))?;
        total += bytes.len() as u64;
        meshes.insert(name, Blob::new(bytes));
    }
    Ok(Command::LoadUrdf {
        file_path: user,
        urdf: Blob::new(text),
        meshes,
        position,
        orientation,
        fixed_base,
        continuous_limits_from_file: true,
        revolute_prismatic_limits_from_file: true,
    })
}

fn resolve_mesh(sandbox: &Sandbox, dir: &Path, name: &str, urdf: &str) -> Result<PathBuf, Refusal> {
    let candidates: Vec<PathBuf> = if let Some(rest) = name.strip_prefix("package://") {
        let rest = Path::new(rest);
        let without_package: PathBuf = rest.components().skip(1).collect();
        let mut c = Vec::new();
        for folder in dir.ancestors() {
            c.push(folder.join(&without_package));
            c.push(folder.join(rest));
            if folder == sandbox.workspace || !folder.starts_with(&sandbox.workspace) {
                break;
            }
        }
        c
    } else {
        vec![dir.join(name.strip_prefix("file://").unwrap_or(name))]
    };
    let mut refusal = None;
    for c in &candidates {
        let shown = c.display().to_string();
        match sandbox.existing(&shown) {
            Ok(p) => return Ok(p),
            Err(why) if c.exists() => refusal = refusal.or(Some(why)),
            Err(_) => {}
        }
    }
    Err(refusal.unwrap_or_else(|| format!("mesh {name} referenced by {urdf} was not found (looked in {})", dir.display())))
}

/// A primitive link shape of generate_revolute_joint.
fn link_xml(name: &str, shape: &str, dims: &[f64], mass: f64, rgba: &str) -> Result<String, Refusal> {
    let (geometry, inertia) = match (shape, dims) {
        ("box", [hx, hy, hz]) => (
            format!("<box size=\"{} {} {}\"/>", 2.0 * hx, 2.0 * hy, 2.0 * hz),
            [mass / 3.0 * (hy * hy + hz * hz), mass / 3.0 * (hx * hx + hz * hz), mass / 3.0 * (hx * hx + hy * hy)],
        ),
        ("sphere", [r]) => (format!("<sphere radius=\"{r}\"/>"), [0.4 * mass * r * r; 3]),
        ("cylinder", [r, h]) => {
            let side = mass * (3.0 * r * r + h * h) / 12.0;
            (format!("<cylinder radius=\"{r}\" length=\"{h}\"/>"), [side, side, mass * r * r / 2.0])
        }
        ("box" | "sphere" | "cylinder", _) => {
            return Err(format!(
                "{name}_dimensions must be [hx, hy, hz] for a box, [radius] for a sphere, [radius, height] for a cylinder; got {dims:?}"
            ))
        }
        _ => return Err(format!("{name}_shape must be box, sphere or cylinder; got {shape}")),
    };
    Ok(format!(
        r#"  <link name="{name}_link">
    <inertial>
      <origin xyz="0 0 0" rpy="0 0 0"/>
      <mass value="{mass}"/>
      <inertia ixx="{}" ixy="0" ixz="0" iyy="{}" iyz="0" izz="{}"/>
    </inertial>
    <visual>
      <geometry>{geometry}</geometry>
      <material name="{name}_color"><color rgba="{rgba}"/></material>
    </visual>
    <collision>
      <geometry>{geometry}</geometry>
    </collision>
  </link>
"#,
        inertia[0], inertia[1], inertia[2]
    ))
}

fn dims<'a>(name: &str, list: &'a NumList) -> Result<&'a [f64], Refusal> {
    let list = &list.0;
    if list.is_empty() || list.iter().any(|x| *x <= 0.0) {
        return Err(format!("{name} must be positive numbers; got {list:?}"));
    }
    Ok(list)
}

/// generate_revolute_joint: writes a two-link URDF joined by a revolute joint and returns
/// where it went and what it holds. The parent link's frame is the robot's base; the child
/// link's frame is the joint frame (at `joint_origin` in the parent frame), with the child
/// shape centred on it.
pub fn generate_revolute_joint(sandbox: &Sandbox, p: &params::GenerateRevolute) -> Result<crate::outputs::GeneratedUrdf, Refusal> {
    let (parent_shape, child_shape) = (p.parent_shape.0.clone(), p.child_shape.0.clone());
    let mass = |m: &Option<Positive>| m.as_ref().map_or(1.0, |m| m.0) as f64;
    let parent = link_xml("parent", &parent_shape, dims("parent_dimensions", &p.parent_dimensions)?, mass(&p.parent_mass), "0.2 0.4 0.8 1")?;
    let child = link_xml("child", &child_shape, dims("child_dimensions", &p.child_dimensions)?, mass(&p.child_mass), "0.9 0.4 0.1 1")?;
    let axis = p.joint_axis.as_ref().map_or([0.0, 0.0, 1.0], |v| v.0);
    if axis.iter().all(|x| *x == 0.0) {
        return Err("joint_axis must be a non-zero vector [x, y, z]".into());
    }
    let origin = p.joint_origin.as_ref().map_or([0.0; 3], |v| v.0);
    let lower = p.joint_lower_limit.as_ref().map_or(-std::f32::consts::PI, |v| v.0);
    let upper = p.joint_upper_limit.as_ref().map_or(std::f32::consts::PI, |v| v.0);
    if lower > upper {
        return Err(format!("joint_lower_limit ({lower}) must not exceed joint_upper_limit ({upper})"));
    }
    let effort = p.max_effort.as_ref().map_or(100.0, |v| v.0);
    let velocity = p.max_velocity.as_ref().map_or(10.0, |v| v.0);
    let target = match &p.output_path {
        Some(path) => sandbox.writable(&path.0)?,
        None => {
            let free = (1..10_000)
                .map(|n| format!("generated/revolute_{n}.urdf"))
                .find(|p| !sandbox.workspace.join(p).exists())
                .ok_or("no free name under generated/ (10,000 files exist)")?;
            sandbox.writable(&free)?
        }
    };
    let r = value::r32;
    let xml = format!(
        r#"<?xml version="1.0"?>
<!-- Generated by physics-mcp generate_revolute_joint. -->
<robot name="revolute_pair">
{parent}{child}  <joint name="revolute_joint" type="revolute">
    <parent link="parent_link"/>
    <child link="child_link"/>
    <origin xyz="{} {} {}" rpy="0 0 0"/>
    <axis xyz="{} {} {}"/>
    <limit lower="{}" upper="{}" effort="{}" velocity="{}"/>
  </joint>
</robot>
"#,
        r(origin[0]), r(origin[1]), r(origin[2]), r(axis[0]), r(axis[1]), r(axis[2]), r(lower), r(upper), r(effort), r(velocity)
    );
    sandbox.write_atomic(&target, xml.as_bytes())?;
    Ok(crate::outputs::GeneratedUrdf {
        urdf_path: target.display().to_string(),
        parent_shape,
        child_shape,
        joint_type: "revolute".into(),
        joint_axis: value::r32s(axis),
        joint_limits: [r(lower), r(upper)],
    })
}
