//! MJCF mesh geoms, built from the event's blobs (the world reads no files).
//!
//! `rapier3d-mjcf` builds mesh geoms only by reading the files itself (its `stl`/`wavefront`
//! features), and without them it logs a warning and drops the geom. So the adapter hands it a
//! copy of the model where every mesh geom is a massless placeholder sphere at the geom's
//! pose, lets it build everything else (frames, joints, the other geoms' colliders and mass),
//! then swaps each placeholder collider's shape for the mesh's convex hull and adds the mesh's
//! mass to its body — as MuJoCo does: a mesh collides as its convex hull, and its mass and
//! inertia come from the mesh by the `<mesh inertia>` rule (`legacy` by default in MuJoCo 4,
//! `exact`, `convex` or `shell`), with `scale`, `refpos`/`refquat` applied to the vertices.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use rapier3d::glamx::{DMat3, DQuat, DVec3};
use rapier3d::prelude::*;
use rapier3d_mjcf::mjcf_rs::assets::{Mesh, MeshInertia};
use rapier3d_mjcf::mjcf_rs::body::{Geom, GeomType};
use rapier3d_mjcf::mjcf_rs::compiler::{Compiler, InertiaFromGeom};
use rapier3d_mjcf::mjcf_rs::model::BodyEntry;
use rapier3d_mjcf::mjcf_rs::Model;
use rapier3d_mjcf::MjcfRobot;

use crate::command::Blob;
use crate::value::Refusal;

/// One mesh geom, ready: its collision hull and its mass in its body's frame.
pub struct MeshGeom {
    /// MJCF body index (0 = the worldbody).
    body: usize,
    /// Index of the geom among its body's geoms.
    geom: usize,
    /// The convex hull it collides as (in the geom frame).
    hull: SharedShape,
    /// Its mass properties in the body frame (zero mass when it has none).
    mass: MassProperties,
}

/// The mesh files the model's mesh geoms need, each as written in its `<mesh file>` and
/// resolved against `dir` (the main file's folder) and `<compiler meshdir/assetdir>` as
/// MuJoCo does. The adapter reads them into the event; unparseable text gives none (the load
/// is refused later, naming the problem).
pub fn mesh_files(xml: &str, dir: &Path) -> Vec<(String, PathBuf)> {
    // Parsed as the world parses it: the parser itself reads nothing.
    let Ok(model) = super::mjcf::parse_model(xml) else { return Vec::new() };
    let mut out: Vec<(String, PathBuf)> = Vec::new();
    for entry in &model.bodies {
        for g in entry.body.geoms.iter().filter(|g| g.type_ == GeomType::Mesh) {
            let Some(mesh) = g.mesh.as_deref().and_then(|n| model.assets.mesh(n)) else { continue };
            let (Some(file), Some(path)) = (mesh.file.clone(), model.resolve_mesh_file(mesh, dir)) else { continue };
            if !out.iter().any(|(f, _)| *f == file) {
                out.push((file, path));
            }
        }
    }
    out
}

/// Whether a body's mass comes from its geoms (MuJoCo's `inertiafromgeom`).
fn mass_from_geoms(c: &Compiler, entry: &BodyEntry) -> bool {
    c.inertia_from_geom == InertiaFromGeom::True || (c.inertia_from_geom == InertiaFromGeom::Auto && entry.body.inertial.is_none())
}

fn geom_label(model: &Model, body: usize, gi: usize, g: &Geom) -> String {
    g.name.clone().unwrap_or_else(|| {
        let b = if body == 0 { "world".to_string() } else { model.bodies[body].body.name.clone().unwrap_or_else(|| format!("#{body}")) };
        format!("#{gi} of body {b}")
    })
}

/// Which `<asset><mesh>`s state their `inertia` (by name, or file stem when unnamed, as MuJoCo
/// names them), and whether any `<default>` class sets `inertia="convex"`. The parser reads a
/// missing `inertia` as `convex`, but MuJoCo 4's default is `legacy`: a `convex` neither the
/// mesh nor any default class states is taken as `legacy`. (A default class's `convex` is
/// honoured for every mesh, its class inheritance not followed.)
fn stated_inertia(xml: &str) -> (Vec<String>, bool) {
    use xml::reader::{EventReader, XmlEvent};
    let mut stated = Vec::new();
    let mut default_convex = false;
    let mut stack: Vec<String> = Vec::new();
    for event in EventReader::new(xml.as_bytes()).into_iter().flatten() {
        match event {
            XmlEvent::StartElement { name, attributes, .. } => {
                let tag = name.local_name;
                if tag == "mesh" {
                    let attr = |n: &str| attributes.iter().find(|a| a.name.local_name == n).map(|a| a.value.clone());
                    if let Some(inertia) = attr("inertia") {
                        if stack.iter().any(|t| t == "default") {
                            default_convex |= inertia == "convex";
                        } else {
                            let stem = attr("file").and_then(|f| Path::new(&f).file_stem().map(|s| s.to_string_lossy().into_owned()));
                            stated.extend(attr("name").or(stem));
                        }
                    }
                }
                stack.push(tag);
            }
            XmlEvent::EndElement { .. } => {
                stack.pop();
            }
            _ => {}
        }
    }
    (stated, default_convex)
}

/// Builds every mesh geom of the model from the blobs (keyed by `<mesh file>` as written), or
/// refuses naming the geom or the file: a geom fitted to a mesh, a mesh that is not declared,
/// missing, unreadable or without volume.
pub fn prepare(xml: &str, model: &Model, blobs: &BTreeMap<String, Blob>, ignored: &mut Vec<String>) -> Result<Vec<MeshGeom>, Refusal> {
    let mut out = Vec::new();
    let (stated, default_convex) = stated_inertia(xml);
    let mut note = |s: String| {
        if !ignored.contains(&s) {
            ignored.push(s);
        }
    };
    for (bi, entry) in model.bodies.iter().enumerate() {
        for (gi, g) in entry.body.geoms.iter().enumerate() {
            let label = geom_label(model, bi, gi, g);
            if g.type_ != GeomType::Mesh {
                if let Some(m) = &g.mesh {
                    return Err(format!("geom {label} fits a primitive to mesh {m}, which is not supported (use type=\"mesh\")"));
                }
                continue;
            }
            let name = g.mesh.as_deref().ok_or_else(|| format!("geom {label} is a mesh geom without a mesh attribute"))?;
            let mesh = model.assets.mesh(name).ok_or_else(|| format!("geom {label} names mesh {name}, which is not an <asset><mesh>"))?;
            if g.fromto.is_some() {
                return Err(format!("geom {label}: fromto is not allowed on a mesh geom"));
            }
            if mesh.max_hull_vert.is_some() {
                note(format!("<mesh maxhullvert> (mesh {name}): the full convex hull is used"));
            }
            let (points, triangles) = mesh_data(name, mesh, blobs)?;
            let pts: Vec<Vector> = points.iter().map(|p| Vector::new(p.x as f32, p.y as f32, p.z as f32)).collect();
            let hull = SharedShape::convex_hull(&pts).ok_or_else(|| format!("mesh {name} has no volume (its convex hull is degenerate)"))?;
            let inertia = match mesh.inertia {
                MeshInertia::Convex if !default_convex && !stated.iter().any(|s| s == name) => MeshInertia::Legacy,
                i => i,
            };
            let moments = match inertia {
                MeshInertia::Convex => hull_moments(&pts),
                MeshInertia::Exact => exact_moments(&points, &triangles),
                MeshInertia::Legacy => legacy_moments(&points, &triangles),
                MeshInertia::Shell => shell_moments(&points, &triangles),
            };
            let Some(moments) = moments.filter(|m| m.size > 1e-12 && m.size.is_finite()) else {
                let rule = format!("{inertia:?}").to_lowercase();
                return Err(format!("mesh {name} has no volume or surface for its mass (inertia=\"{rule}\"; check its faces' orientation)"));
            };
            let default_density = model.compiler.inertia_density;
            let density = match g.mass {
                Some(m) => m / moments.size,
                None => g.density.unwrap_or(default_density),
            };
            let mass = if density > 0.0 { moments.mass_properties(density) } else { MassProperties::default() };
            let pose: Pose = g.pose.into();
            out.push(MeshGeom { body: bi, geom: gi, hull, mass: mass.transform_by(&pose) });
        }
    }
    Ok(out)
}

/// A mesh's vertices in the geom frame (`refpos`/`refquat` then `scale` applied, as MuJoCo
/// does) and its triangles (outward as in the file; flipped by a mirroring scale).
fn mesh_data(name: &str, mesh: &Mesh, blobs: &BTreeMap<String, Blob>) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), Refusal> {
    let (raw, mut triangles): (Vec<DVec3>, Vec<[u32; 3]>) = match (&mesh.file, &mesh.inline_vertices) {
        (Some(file), _) => {
            let blob = blobs.get(file).filter(|b| b.is_loaded()).ok_or_else(|| format!("mesh {file} was not provided"))?;
            let (p, t) = super::urdf::mesh_triangles(file, &blob.bytes)?;
            (p.iter().map(|v| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)).collect(), t)
        }
        (None, Some(v)) => {
            if v.len() < 12 || !v.len().is_multiple_of(3) || v.iter().any(|x| !x.is_finite()) {
                return Err(format!("mesh {name} needs at least 4 finite vertices (3 numbers each)"));
            }
            let pts: Vec<DVec3> = v.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect();
            let faces = mesh.inline_faces.clone().unwrap_or_default();
            if !faces.len().is_multiple_of(3) || faces.iter().any(|i| *i as usize >= pts.len()) {
                return Err(format!("mesh {name} has faces that are not triples of its vertex indices"));
            }
            (pts, faces.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        }
        (None, None) => return Err(format!("mesh {name} has neither a file nor vertex data")),
    };
    let s = DVec3::from_array(mesh.scale);
    if !s.is_finite() || s.x == 0.0 || s.y == 0.0 || s.z == 0.0 {
        return Err(format!("mesh {name} has an invalid scale"));
    }
    let refpos = mesh.refpose.translation;
    let refquat: DQuat = mesh.refpose.rotation;
    let points: Vec<DVec3> = raw.iter().map(|p| s * (refquat.inverse() * (*p - refpos))).collect();
    super::urdf::within_extent(name, points.iter().map(|p| p.to_array()))?;
    if s.x * s.y * s.z < 0.0 {
        for t in &mut triangles {
            t.swap(1, 2);
        }
    }
    if triangles.is_empty() {
        // MuJoCo makes the faces of a mesh given without any from its convex hull.
        let pts: Vec<Vector> = points.iter().map(|p| Vector::new(p.x as f32, p.y as f32, p.z as f32)).collect();
        let (hp, ht) = rapier3d::parry::transformation::convex_hull(&pts);
        let back: Vec<DVec3> = hp.iter().map(|p| DVec3::new(p.x as f64, p.y as f64, p.z as f64)).collect();
        return Ok((back, ht));
    }
    Ok((points, triangles))
}

/// A mesh's size (volume, or area for a shell), centre and second moment about that centre
/// (∫ r rᵀ per unit density).
#[derive(Clone, Copy, Debug)]
struct Moments {
    size: f64,
    com: DVec3,
    second: DMat3,
}

impl Moments {
    fn mass_properties(&self, density: f64) -> MassProperties {
        let c = self.second * density;
        let inertia = DMat3::from_diagonal(DVec3::splat(c.x_axis.x + c.y_axis.y + c.z_axis.z)) - c;
        let com = Vector::new(self.com.x as f32, self.com.y as f32, self.com.z as f32);
        let m = inertia.to_cols_array().map(|x| x as f32);
        MassProperties::with_inertia_matrix(com, (self.size * density) as f32, Matrix::from_cols_array(&m))
    }
}

fn outer(a: DVec3, b: DVec3) -> DMat3 {
    DMat3::from_cols(a * b.x, a * b.y, a * b.z)
}

/// Tetrahedron (apex `o`) over each triangle: summed volume, first moment and second moment
/// about `o`; `abs` counts each tetrahedron's volume unsigned (MuJoCo's legacy rule).
fn tetra_sums(points: &[DVec3], triangles: &[[u32; 3]], o: DVec3, abs: bool) -> (f64, DVec3, DMat3) {
    let (mut vol, mut first, mut second) = (0.0, DVec3::ZERO, DMat3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| points[i as usize] - o);
        let mut v = a.dot(b.cross(c)) / 6.0;
        if abs {
            v = v.abs();
        }
        let s = a + b + c;
        vol += v;
        first += s * (v / 4.0);
        second += (outer(a, a) + outer(b, b) + outer(c, c) + outer(s, s)) * (v / 20.0);
    }
    (vol, first, second)
}

/// The solid the triangles enclose (signed tetrahedra; MuJoCo's `exact`).
fn exact_moments(points: &[DVec3], triangles: &[[u32; 3]]) -> Option<Moments> {
    let (vol, first, second) = tetra_sums(points, triangles, DVec3::ZERO, false);
    if vol <= 0.0 {
        return None;
    }
    let com = first / vol;
    Some(Moments { size: vol, com, second: second - outer(com, com) * vol })
}

/// MuJoCo's `legacy` rule: unsigned tetrahedra from the area-weighted centre of the faces give
/// the centre; unsigned tetrahedra from that centre give the volume and inertia (equal to
/// `exact` for a convex mesh, more for a non-convex one).
fn legacy_moments(points: &[DVec3], triangles: &[[u32; 3]]) -> Option<Moments> {
    let (mut area, mut centre) = (0.0, DVec3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| points[i as usize]);
        let ar = (b - a).cross(c - a).length() / 2.0;
        area += ar;
        centre += (a + b + c) * (ar / 3.0);
    }
    if area <= 0.0 {
        return None;
    }
    let centre = centre / area;
    let (vol, first, _) = tetra_sums(points, triangles, centre, true);
    if vol <= 0.0 {
        return None;
    }
    let com = centre + first / vol;
    let (vol, _, second) = tetra_sums(points, triangles, com, true);
    Some(Moments { size: vol, com, second })
}

/// The convex hull's solid (MuJoCo's `convex`).
fn hull_moments(pts: &[Vector]) -> Option<Moments> {
    let (hp, ht) = rapier3d::parry::transformation::convex_hull(pts);
    let back: Vec<DVec3> = hp.iter().map(|p| DVec3::new(p.x as f64, p.y as f64, p.z as f64)).collect();
    exact_moments(&back, &ht)
}

/// Mass on the surface (MuJoCo's `shell`): size is the area.
fn shell_moments(points: &[DVec3], triangles: &[[u32; 3]]) -> Option<Moments> {
    let (mut area, mut first, mut second) = (0.0, DVec3::ZERO, DMat3::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| points[i as usize]);
        let ar = (b - a).cross(c - a).length() / 2.0;
        let s = a + b + c;
        area += ar;
        first += s * (ar / 3.0);
        second += (outer(a, a) + outer(b, b) + outer(c, c) + outer(s, s)) * (ar / 12.0);
    }
    if area <= 0.0 {
        return None;
    }
    let com = first / area;
    Some(Moments { size: area, com, second: second - outer(com, com) * area })
}

/// Whether any mesh geom carries mass into a body whose mass comes from its geoms (only then
/// does the crate's copy need the compiler's mass rules lifted; see `placeholders`).
fn adds_mass(model: &Model, meshes: &[MeshGeom]) -> bool {
    meshes.iter().any(|m| m.mass.mass() > 0.0 && m.body != 0 && mass_from_geoms(&model.compiler, &model.bodies[m.body]))
}

/// The model the crate builds from: each mesh geom a massless sphere at its pose (so the
/// crate keeps it, in order, as a collider slot we fill). When meshes add mass, the
/// compiler's mass rules (`boundmass`, `boundinertia`, `balanceinertia`, `settotalmass`) are
/// lifted here and applied by `finish` to the full masses, and an `<inertial>` that
/// `inertiafromgeom="true"` overrides is dropped.
pub fn placeholders(model: &Model, meshes: &[MeshGeom]) -> Model {
    let mut copy = model.clone();
    for m in meshes {
        let g = &mut copy.bodies[m.body].body.geoms[m.geom];
        g.type_ = GeomType::Sphere;
        g.size = [0.01, 0.0, 0.0];
        g.mass = Some(0.0);
        g.density = None;
        g.mesh = None;
    }
    if adds_mass(model, meshes) {
        let c = &mut copy.compiler;
        c.bound_mass = 0.0;
        c.bound_inertia = 0.0;
        c.balance_inertia = false;
        c.set_total_mass = 0.0;
        if c.inertia_from_geom == InertiaFromGeom::True {
            for m in meshes.iter().filter(|m| m.mass.mass() > 0.0) {
                copy.bodies[m.body].body.inertial = None;
            }
        }
    }
    copy
}

/// Puts the meshes into what the crate built from `placeholders(model, meshes)`: each
/// placeholder collider takes its mesh's hull, each body its meshes' mass (with the compiler's
/// mass rules then applied as the crate would have).
pub fn finish(robot: &mut MjcfRobot, model: &Model, meshes: &[MeshGeom]) {
    if meshes.is_empty() {
        return;
    }
    let adds = adds_mass(model, meshes);
    let c = &model.compiler;
    for b in robot.bodies.iter_mut().filter(|b| !b.is_intermediate) {
        let id = b.mjcf_body_id;
        let entry = &model.bodies[id];
        // The k-th collider is the k-th geom the crate builds one for (not a plane, not visual).
        let slots = entry.body.geoms.iter().enumerate().filter(|(_, g)| g.type_ != GeomType::Plane && !(g.contype == 0 && g.conaffinity == 0));
        for (k, (gi, _)) in slots.enumerate() {
            if let (Some(m), Some(col)) = (meshes.iter().find(|m| m.body == id && m.geom == gi), b.colliders.get_mut(k)) {
                col.set_shape(m.hull.clone());
            }
        }
        if !adds || id == 0 {
            continue;
        }
        let had = b.body.mass_properties().additional_local_mprops.is_some();
        let mut mp = super::mjcf::body_mprops(&b.body);
        let mut added = false;
        if mass_from_geoms(c, entry) {
            for m in meshes.iter().filter(|m| m.body == id && m.mass.mass() > 0.0) {
                mp += m.mass;
                added = true;
            }
        }
        if had || added {
            let mp = clamp(mp, c);
            b.body.set_additional_mass_properties(mp, false);
            b.mass = mp.mass();
        }
    }
    if adds && c.set_total_mass > 0.0 {
        let total: f32 = robot.bodies.iter().map(|b| b.mass).filter(|m| *m > 0.0).sum();
        if total > 0.0 {
            let factor = c.set_total_mass as f32 / total;
            for b in robot.bodies.iter_mut().filter(|b| b.mass > 0.0) {
                let mp = super::mjcf::body_mprops(&b.body);
                let scaled = MassProperties::with_principal_inertia_frame(mp.local_com, mp.mass() * factor, mp.principal_inertia() * factor, mp.principal_inertia_local_frame);
                b.body.set_additional_mass_properties(scaled, false);
                b.mass = scaled.mass();
            }
        }
    }
}

/// MuJoCo's `boundmass`/`boundinertia`/`balanceinertia` on a body's mass, as the crate applies
/// them (its helper is private to it).
fn clamp(mp: MassProperties, c: &Compiler) -> MassProperties {
    let bm = c.bound_mass as f32;
    let mass = if bm > 0.0 && mp.mass() < bm { bm } else { mp.mass() };
    let mut p = mp.principal_inertia();
    let bi = c.bound_inertia as f32;
    if bi > 0.0 {
        p = p.max(Vector::splat(bi));
    }
    if c.balance_inertia {
        p.x = p.x.max((p.y - p.z).abs());
        p.y = p.y.max((p.x - p.z).abs());
        p.z = p.z.max((p.x - p.y).abs());
    }
    MassProperties::with_principal_inertia_frame(mp.local_com, mass, p, mp.principal_inertia_local_frame)
}
