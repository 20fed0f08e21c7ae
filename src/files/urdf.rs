//! The adapter side of robots: reading a URDF and its meshes from the workspace or the
//! built-in library (the world never reads files), and writing generated URDFs.
//!
//! A URDF's meshes are resolved against the URDF's folder: relative names directly,
//! `package://pkg/rest` by trying `rest` and `pkg/rest` in the URDF's folder and each folder
//! above it up to the workspace root (the library's top for a built-in), `file://` as a path.
//! Every candidate goes through the sandbox (or the library); a missing or unreadable mesh is
//! an error, never a silently missing collider.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::command::{Blob, Command};
use crate::params::lenient::{NumList, Positive};
use crate::params;
use crate::files::write::{self, write_owned, Owned};
use crate::files::library::Format;
use crate::files::model_files::ModelFiles;
use crate::files::{Reader, Sandbox};
use crate::value::{self, Refusal};
use crate::world::urdf::mesh_names;

/// Largest URDF file read.
pub const MAX_URDF_BYTES: u64 = 8 << 20;
/// Largest total of a robot's mesh files.
pub const MAX_MESH_BYTES: u64 = 64 << 20;

/// Builds load_urdf's command from its arguments (as a loaded file's robot entry gives them).
pub fn decide_load_urdf(reader: &mut Reader, a: &value::Args) -> Result<Command, Refusal> {
    load_urdf_command(reader, &params::parse("load_urdf", a)?)
}

/// Builds load_urdf's command: the URDF text and every mesh it names, read now through
/// `reader` (once per request), travel in it. The URDF is the workspace's file of that name,
/// else the built-in model of that name (`library`).
pub fn load_urdf_command(reader: &mut Reader, p: &params::LoadUrdf) -> Result<Command, Refusal> {
    let user = p.file_path.0.clone();
    let (files, at) = ModelFiles::locate(reader, &user, Format::Urdf)?;
    let mut command = urdf_command(files, at, &user)?;
    if let Command::LoadUrdf { position, orientation, fixed_base, .. } = &mut command {
        *position = p.position.as_ref().map_or([0.0; 3], |v| v.0);
        *orientation = p.orientation.as_ref().map_or([0.0, 0.0, 0.0, 1.0], |q| q.0);
        *fixed_base = p.use_fixed_base.as_ref().is_some_and(|b| b.0);
    }
    Ok(command)
}

/// load_urdf's command for built-in model `name` at the origin, its base as the file says
/// (what list_models describes), read from the library alone.
pub fn builtin_command(name: &str) -> Result<Command, Refusal> {
    urdf_command(ModelFiles::Builtin(None), PathBuf::from(name), name)
}

/// The command loading the URDF at `at` among `files` (at the origin), its meshes read from
/// the same files; `user` is the path as given.
fn urdf_command(mut files: ModelFiles, at: PathBuf, user: &str) -> Result<Command, Refusal> {
    let dir = files.folder(&at);
    let text = files.read(at, &format!("file_path {user}"), MAX_URDF_BYTES)?;
    let utf8 = std::str::from_utf8(&text).map_err(|_| format!("file_path {user} is not a valid URDF: it is not UTF-8 text"))?;
    let mut meshes = BTreeMap::new();
    let mut total = 0u64;
    for name in mesh_names(utf8)? {
        let path = resolve_mesh(&files, &dir, &name, user)?;
        let bytes = files.read(path, &format!("mesh {name}"), MAX_MESH_BYTES.saturating_sub(total))?;
        total += bytes.len() as u64;
        meshes.insert(name, Blob::from_shared(bytes));
    }
    Ok(Command::LoadUrdf {
        file_path: user.to_string(),
        urdf: Blob::from_shared(text),
        meshes,
        position: [0.0; 3],
        orientation: [0.0, 0.0, 0.0, 1.0],
        fixed_base: false,
        continuous_limits_from_file: true,
        revolute_prismatic_limits_from_file: true,
        inertials_as_pybullet: true,
        parsed: Default::default(),
    })
}

fn resolve_mesh(files: &ModelFiles, dir: &Path, name: &str, urdf: &str) -> Result<PathBuf, Refusal> {
    let root = files.root();
    let candidates: Vec<PathBuf> = if let Some(rest) = name.strip_prefix("package://") {
        let rest = Path::new(rest);
        let without_package: PathBuf = rest.components().skip(1).collect();
        let mut c = Vec::new();
        for folder in dir.ancestors() {
            c.push(folder.join(&without_package));
            c.push(folder.join(rest));
            if folder == root || !folder.starts_with(&root) {
                break;
            }
        }
        c
    } else {
        vec![dir.join(name.strip_prefix("file://").unwrap_or(name))]
    };
    let mut refusal = None;
    for c in &candidates {
        match files.probe(c) {
            Ok(Some(p)) => return Ok(p),
            Ok(None) => {}
            Err(why) => refusal = refusal.or(Some(why)),
        }
    }
    Err(refusal.unwrap_or_else(|| format!("mesh {name} referenced by {urdf} was not found (looked in {})", dir.display())))
}

/// The comment every URDF generate_revolute_joint writes: how it recognises one of its own
/// files, which it may replace without `overwrite`.
const GENERATOR_COMMENT: &str = "<!-- Generated by physics-mcp generate_revolute_joint. -->";

/// generate_revolute_joint's files: URDFs carrying its comment.
const GENERATED_URDF: Owned = Owned {
    ours: |head| String::from_utf8_lossy(head).contains(GENERATOR_COMMENT),
    what: "a URDF written by generate_revolute_joint",
};

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
    let r = value::r32;
    let xml = format!(
        r#"<?xml version="1.0"?>
{GENERATOR_COMMENT}
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
    let target = match &p.output_path {
        Some(path) => {
            let target = sandbox.writable(&path.0)?;
            let overwrite = p.overwrite.as_ref().is_some_and(|b| b.0);
            write_owned(sandbox, &target, &path.0, xml.as_bytes(), &GENERATED_URDF, overwrite)?;
            target
        }
        // A name of its own: the first free one, never another call's.
        None => write::create_first_free(sandbox, (1..10_000).map(|n| format!("generated/revolute_{n}.urdf")), xml.as_bytes())
            .map_err(|why| format!("no free name under generated/: {why}"))?,
    };
    Ok(crate::outputs::GeneratedUrdf {
        urdf_path: sandbox.shown(&target),
        parent_shape,
        child_shape,
        joint_type: "revolute".into(),
        joint_axis: value::r32s(axis),
        joint_limits: [r(lower), r(upper)],
    })
}
