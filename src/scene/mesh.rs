//! Triangle meshes: OBJ (tobj, with MTL colours), PLY (ply-rs-bw header and binary payloads, a fast
//! parallel reader for ASCII payloads, optional .gz), Mitsuba's `.serialized` meshes, and generated
//! quads, disks and boxes.
use crate::scene::SceneError;
use glam::{Mat4, Vec3};
use rayon::prelude::*;
use std::io::{BufReader, Read};
use std::path::Path;

/// An indexed triangle mesh in world space.
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals, when the file has them or `smooth = true`: unit length, but under an
    /// instance's uneven scale (`place_as_instance`); read interpolated and then made unit.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates (v = 0 at the top row of an image, as Mitsuba reads them; OBJ's
    /// bottom-up v is flipped on load), when the file has them; without them a hit's uv is its
    /// barycentric coordinates.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Per-vertex colours, when the file has them (a PLY's `red`/`green`/`blue` or `r`/`g`/`b`: floats as
    /// they are, 8- and 16-bit integers as sRGB-encoded values, decoded to linear; a `.serialized`
    /// mesh's), read by a `vertex_color` texture.
    pub colors: Option<Vec<Vec3>>,
    /// Per-triangle colours, when the file has them (a PLY face element's colours, read as vertex
    /// colours are; a polygon's colour goes to each triangle of its fan), read by a `face_color` texture.
    pub face_colors: Option<Vec<Vec3>>,
    /// The triangles' second and third corners swapped from the file's (an odd number of winding
    /// turns: a mirroring `transform`, `flip`). Without texture coordinates the uv and tangents are
    /// still the file's corners' barycentrics, as Mitsuba's (which keeps the winding): `uv_at` and
    /// `dp_duv` read them back.
    pub turned: bool,
    /// Triangles whose corners `face_vertex_normals` swapped on their own, each turned from the rest of
    /// the mesh (`turned_at`); empty where it swapped none, or every one (then `turned` says so).
    pub turned_alone: Vec<bool>,
    /// Rays pass the triangles' backs unseen (Mitsuba's curves, whose inside Embree culls): a ray
    /// meets a triangle only from in front of it, as its winding faces.
    pub cull_back: bool,
}

impl TriMesh {
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Texture coordinates at barycentrics `[u, v]` of triangle `i` (the point a·(1 − u − v) + b·u + c·v):
    /// the mesh's, interpolated, else the barycentrics themselves, of the file's corners (`turned`).
    pub fn uv_at(&self, i: usize, [u, v]: [f32; 2]) -> glam::Vec2 {
        match &self.uvs {
            Some(t) => {
                let [i0, i1, i2] = self.indices[i];
                let [ta, tb, tc] = [t[i0 as usize], t[i1 as usize], t[i2 as usize]];
                glam::Vec2::from(ta) * (1.0 - u - v) + glam::Vec2::from(tb) * u + glam::Vec2::from(tc) * v
            }
            None if self.turned_at(i) => glam::Vec2::new(v, u),
            None => glam::Vec2::new(u, v),
        }
    }

    /// Barycentric coordinates `[u, v]` of point `p` of triangle `i` (p = a·(1 − u − v) + b·u + c·v),
    /// from the areas `p` makes with the triangle's edges; None for a degenerate triangle.
    fn barycentrics(&self, i: usize, p: Vec3) -> Option<[f32; 2]> {
        let [a, b, c] = self.triangle(i);
        let n = (b - a).cross(c - a);
        let nn = n.length_squared();
        if nn == 0.0 || !nn.is_finite() {
            return None;
        }
        Some([(p - a).cross(c - a).dot(n) / nn, (b - a).cross(p - a).dot(n) / nn])
    }

    /// The vertex normals interpolated at point `p` of triangle `i`, unit length, as the mesh gives them
    /// (not turned towards the face's normal); None without vertex normals, or where they cancel.
    pub fn interpolated_normal(&self, i: usize, p: Vec3) -> Option<Vec3> {
        let ns = self.normals.as_ref()?;
        let [i0, i1, i2] = self.indices[i];
        let n = match self.barycentrics(i, p) {
            Some([u, v]) => ns[i0 as usize] * (1.0 - u - v) + ns[i1 as usize] * u + ns[i2 as usize] * v,
            None => ns[i0 as usize],
        };
        Some(n.normalize_or_zero()).filter(|n| *n != Vec3::ZERO)
    }

    /// The vertex colours interpolated at point `p` of triangle `i` (by its barycentric coordinates);
    /// black without colours.
    pub fn color_at(&self, i: usize, p: Vec3) -> Vec3 {
        let Some(c) = &self.colors else { return Vec3::ZERO };
        let [i0, i1, i2] = self.indices[i];
        let Some([u, v]) = self.barycentrics(i, p) else {
            return c[i0 as usize];
        };
        c[i0 as usize] * (1.0 - u - v) + c[i1 as usize] * u + c[i2 as usize] * v
    }

    /// Triangle `i`'s ∂p/∂u and ∂p/∂v from its texture coordinates where it has them and they span an
    /// area (Mitsuba's), else its two edges from the first vertex (b − a, c − a), along its barycentric
    /// u and v, as its uv are then its barycentrics (the file's corners' when `turned`: c − a, b − a).
    pub fn dp_duv(&self, i: usize) -> (Vec3, Vec3) {
        let [a, b, c] = self.triangle(i);
        if let Some(t) = &self.uvs {
            let [i0, i1, i2] = self.indices[i];
            let [ta, tb, tc] = [t[i0 as usize], t[i1 as usize], t[i2 as usize]];
            let (du1, dv1, du2, dv2) = (tb[0] - ta[0], tb[1] - ta[1], tc[0] - ta[0], tc[1] - ta[1]);
            let det = du1 * dv2 - dv1 * du2;
            if det != 0.0 && det.is_finite() {
                return (((b - a) * dv2 - (c - a) * dv1) / det, ((c - a) * du1 - (b - a) * du2) / det);
            }
        }
        if self.turned_at(i) {
            (c - a, b - a)
        } else {
            (b - a, c - a)
        }
    }

    /// Triangle `i`'s area, as `Geometry::point` reports it (`length_wide`: an area of 1e30, whose cross
    /// product squares past f32, is not read as infinite).
    pub fn area(&self, i: usize) -> f32 {
        let [a, b, c] = self.triangle(i);
        0.5 * crate::math::length_wide((b - a).cross(c - a))
    }

    pub fn total_area(&self) -> f32 {
        (0..self.indices.len()).map(|i| self.area(i)).sum()
    }

    /// Applies an affine transform to positions (and inverse-transpose to normals, made unit length).
    pub fn transform(&mut self, m: &Mat4) {
        self.transform_normals_unit(m, true);
    }

    /// Places the mesh as a Mitsuba `instance` does: `transform`, but the vertex normals transformed
    /// without making them unit length again, so that those interpolated across a triangle (then made
    /// unit) are the group's interpolated normals transformed as normals, which Mitsuba's instance
    /// shades with. Under an uneven scale unit lengths would weigh the corners otherwise and move a
    /// near-mirror's highlight.
    pub fn place_as_instance(&mut self, m: &Mat4) {
        self.transform_normals_unit(m, false);
    }

    fn transform_normals_unit(&mut self, m: &Mat4, unit: bool) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        if let Some(ns) = &mut self.normals {
            let nm = m.inverse().transpose();
            for n in ns.iter_mut() {
                *n = nm.transform_vector3(*n);
                if unit {
                    *n = n.normalize_or_zero();
                }
            }
        }
        if m.determinant() < 0.0 {
            for t in &mut self.indices {
                t.swap(1, 2);
            }
            self.turned = !self.turned;
        }
    }

    /// Whether triangle `i`'s second and third corners are swapped from the file's (`turned`, and
    /// `turned_alone`).
    pub fn turned_at(&self, i: usize) -> bool {
        self.turned != self.turned_alone.get(i).copied().unwrap_or(false)
    }

    /// Turns each triangle whose vertex normals point behind its face (their sum against the normal its
    /// winding gives) to face where they point, and returns how many it turned. Mitsuba, pbrt-v4 and
    /// the rest take a mesh's vertex normals for its outside: a one-sided surface is seen, glass is
    /// entered and a smooth emitter emits in front of them, whichever way the file winds its triangles
    /// (a mesh exported with its normals turned inward, or with some faces wound the other way). The
    /// geometric normal, which the rest of the renderer keeps on the shading normal's side, then follows
    /// them. Without vertex normals it turns nothing.
    pub fn face_vertex_normals(&mut self) -> usize {
        let Some(against) = self.against_vertex_normals() else { return 0 };
        let count = against.iter().filter(|x| **x).count();
        if count == 0 {
            return 0;
        }
        for (t, _) in self.indices.iter_mut().zip(&against).filter(|(_, a)| **a) {
            t.swap(1, 2);
        }
        if count == against.len() && self.turned_alone.is_empty() {
            self.turned = !self.turned;
        } else {
            let before = std::mem::take(&mut self.turned_alone);
            self.turned_alone =
                against.iter().enumerate().map(|(i, a)| *a != before.get(i).copied().unwrap_or(false)).collect();
        }
        count
    }

    /// Per triangle, whether its vertex normals point behind its face (their sum against the normal its
    /// winding gives); None without vertex normals.
    pub fn against_vertex_normals(&self) -> Option<Vec<bool>> {
        let ns = self.normals.as_ref()?;
        let p = &self.positions;
        let against = self.indices.iter().map(|t| {
            let [a, b, c] = t.map(|i| i as usize);
            (p[b] - p[a]).cross(p[c] - p[a]).dot(ns[a] + ns[b] + ns[c]) < 0.0
        });
        Some(against.collect())
    }

    /// Turns the surface inside out: every triangle's winding and every vertex normal reversed.
    pub fn flip(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
        self.turned = !self.turned;
        if let Some(ns) = &mut self.normals {
            ns.iter_mut().for_each(|n| *n = -*n);
        }
    }

    /// Vertex normals as Mitsuba computes them for a mesh without any (Thürmer & Wüthrich 1998): each
    /// face's unit normal weighted by the face's angle at the vertex. Call it on the mesh as placed in
    /// the scene (angles change under a non-uniform scale), as Mitsuba does after `to_world`.
    pub fn compute_smooth_normals(&mut self) {
        // The angle between unit vectors a and b, accurate near 0 and π (Mitsuba's `unit_angle`).
        let unit_angle = |a: Vec3, b: Vec3| {
            if a.dot(b) < 0.0 {
                std::f32::consts::PI - 2.0 * ((a + b).length() * 0.5).min(1.0).asin()
            } else {
                2.0 * ((a - b).length() * 0.5).min(1.0).asin()
            }
        };
        let mut ns = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.indices {
            let v = t.map(|i| self.positions[i as usize]);
            let Some(n) = (v[1] - v[0]).cross(v[2] - v[0]).try_normalize() else { continue };
            for k in 0..3 {
                let (e1, e2) = (v[(k + 1) % 3] - v[k], v[(k + 2) % 3] - v[k]);
                if let (Some(e1), Some(e2)) = (e1.try_normalize(), e2.try_normalize()) {
                    ns[t[k] as usize] += n * unit_angle(e1, e2);
                }
            }
        }
        for n in &mut ns {
            *n = n.normalize_or_zero();
        }
        self.normals = Some(ns);
    }

    /// Checks every vertex is finite and every index in range; returns the count of bad vertices.
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        if self.indices.is_empty() {
            return Err(SceneError::Mesh { file: file.into(), msg: "the mesh has no faces".into() });
        }
        let bad = self.positions.iter().filter(|p| !p.is_finite()).count();
        if bad > 0 {
            return Err(SceneError::Mesh {
                file: file.into(),
                msg: format!("{bad} vertices have NaN or infinite coordinates"),
            });
        }
        let n = self.positions.len() as u32;
        if let Some(t) = self.indices.iter().find(|t| t.iter().any(|&i| i >= n)) {
            return Err(SceneError::Mesh {
                file: file.into(),
                msg: format!("face {:?} refers past the {} vertices", t, n),
            });
        }
        Ok(())
    }

    pub fn bytes(&self) -> usize {
        self.positions.len() * 12
            + self.indices.len() * 12
            + self.normals.as_ref().map_or(0, |n| n.len() * 12)
            + self.uvs.as_ref().map_or(0, |t| t.len() * 8)
            + self.colors.as_ref().map_or(0, |c| c.len() * 12)
            + self.face_colors.as_ref().map_or(0, |c| c.len() * 12)
    }
}

/// A mesh read from a file, with the diffuse colour its MTL gave, if any.
pub struct LoadedMesh {
    pub mesh: TriMesh,
    pub mtl_diffuse: Option<[f32; 3]>,
    /// The MTL's `map_Kd` image, as written there (relative to the OBJ's folder).
    pub mtl_texture: Option<String>,
    /// Why the OBJ's MTL file could not be read, if it names one that could not.
    pub mtl_error: Option<String>,
}

/// The mesh file formats `load_mesh_file` reads, told by the file name's ending.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshFormat {
    Obj,
    /// `.ply` or gzip-compressed `.ply.gz`.
    Ply,
    /// Mitsuba's `.serialized`, which holds several meshes.
    Serialized,
}

impl MeshFormat {
    pub fn of(name: &str) -> Option<MeshFormat> {
        let name = name.to_lowercase();
        if name.ends_with(".serialized") {
            Some(MeshFormat::Serialized)
        } else if name.ends_with(".obj") {
            Some(MeshFormat::Obj)
        } else if name.ends_with(".ply") || name.ends_with(".ply.gz") {
            Some(MeshFormat::Ply)
        } else {
            None
        }
    }
}

/// Loads an OBJ, a PLY (optionally gzip-compressed) or mesh `shape_index` (0 unless given) of a Mitsuba
/// `.serialized` file. Vertex normals are read only when `normals` (smooth shading asked for); texture
/// coordinates and colours (of vertices and of faces) whenever the file has them; other properties
/// never are. Texture coordinates' v is read upside down (v → 1 − v) where `flip_tex_coords` says so,
/// Mitsuba's convention (an OBJ's by default, whose rows count from the bottom of the image; a PLY's
/// only when asked); a `.serialized` file's as stored (the caller refuses the option there).
pub fn load_mesh_file(
    path: &Path,
    shown: &str,
    normals: bool,
    shape_index: Option<u32>,
    flip_tex_coords: Option<bool>,
) -> Result<Vec<LoadedMesh>, SceneError> {
    let name = path.to_string_lossy().to_lowercase();
    let err = |msg: String| SceneError::Mesh { file: shown.into(), msg };
    if !path.exists() {
        return Err(SceneError::MissingFile { file: shown.into() });
    }
    crate::scene::regular_file(path).map_err(err)?;
    let format = MeshFormat::of(&name);
    if shape_index.is_some() && format != Some(MeshFormat::Serialized) {
        return Err(err("shape_index is for a Mitsuba `.serialized` file, which holds several meshes".into()));
    }
    if format == Some(MeshFormat::Serialized) {
        let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
        let mesh = parse_serialized(&bytes, shape_index.unwrap_or(0), normals).map_err(err)?;
        Ok(vec![LoadedMesh { mesh, mtl_diffuse: None, mtl_texture: None, mtl_error: None }])
    } else if format == Some(MeshFormat::Obj) {
        load_obj(path, normals, flip_tex_coords.unwrap_or(true)).map_err(err)
    } else if format == Some(MeshFormat::Ply) {
        let f = std::fs::File::open(path).map_err(|e| err(e.to_string()))?;
        let mut bytes = Vec::new();
        if name.ends_with(".gz") {
            flate2::read::GzDecoder::new(BufReader::new(f))
                .read_to_end(&mut bytes)
                .map_err(|e| err(format!("gzip: {e}")))?;
        } else {
            BufReader::new(f).read_to_end(&mut bytes).map_err(|e| err(e.to_string()))?;
        }
        let mut mesh = parse_ply(&bytes, normals).map_err(err)?;
        if flip_tex_coords == Some(true) {
            for uv in mesh.uvs.iter_mut().flatten() {
                uv[1] = 1.0 - uv[1];
            }
        }
        Ok(vec![LoadedMesh { mesh, mtl_diffuse: None, mtl_texture: None, mtl_error: None }])
    } else {
        Err(err("unknown mesh format (accepted: .obj, .ply, .ply.gz, .serialized)".into()))
    }
}

/// "line N: `…`" for line `i` (from 0) of a text file, at most 80 of its characters shown.
fn quoted_line(i: usize, line: &str) -> String {
    let shown: String = line.trim().chars().take(80).collect();
    let more = if line.trim().chars().count() > 80 { "…" } else { "" };
    format!("line {}: `{shown}{more}`", i + 1)
}

/// Where in an OBJ's `text` tobj's error `e` lies (tobj names none): "line N: `…`" for the first line
/// whose numbers do not parse (a `v` of other than 3, 4 or 6 numbers or with a w of 0, a `vt`, a `vn`,
/// a face's indices), a `usemtl` without a name or, for an index out of bounds,
/// the first face naming an element the file does not have (an index of 0, one past the file's
/// count, a relative one reaching before its first element). None if no line matches: the message then
/// stays tobj's alone.
fn obj_error_line(text: &str, e: &tobj::LoadError) -> Option<String> {
    use tobj::LoadError as E;
    // Which attribute of a face's `v/vt/vn` an out-of-bounds error is about.
    let slot = match e {
        E::FaceVertexOutOfBounds => Some(0),
        E::FaceTexCoordOutOfBounds => Some(1),
        E::FaceNormalOutOfBounds => Some(2),
        _ => None,
    };
    let floats =
        |words: std::str::SplitWhitespace, n: usize| words.take(n).filter(|w| w.parse::<f32>().is_ok()).count() == n;
    let totals = text.lines().fold([0usize; 3], |mut c, l| {
        match l.split_whitespace().next() {
            Some("v") => c[0] += 1,
            Some("vt") => c[1] += 1,
            Some("vn") => c[2] += 1,
            _ => {}
        }
        c
    });
    let mut counts = [0usize; 3];
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let bad = match (words.next(), e, slot) {
            (Some("v"), _, _) => {
                counts[0] += 1;
                // x y z, then nothing, a w (not 0) or a colour's three numbers.
                let rest: Vec<&str> = words.clone().skip(3).collect();
                let w = (rest.len() == 1).then(|| rest[0].parse::<f32>());
                match e {
                    E::PositionParseError => !floats(words, 3) || w.is_some_and(|w| w.is_err()),
                    E::ScalingByZeroError => w.is_some_and(|w| w == Ok(0.0)),
                    E::ColorParseError => rest.len() == 2 || rest.len() > 3,
                    _ => false,
                }
            }
            (Some("usemtl"), E::MaterialParseError, _) => words.next().is_none(),
            (Some("vt"), _, _) => {
                counts[1] += 1;
                matches!(e, E::TexcoordParseError) && !floats(words, 2)
            }
            (Some("vn"), _, _) => {
                counts[2] += 1;
                matches!(e, E::NormalParseError) && !floats(words, 3)
            }
            // tobj reads up to three parts, `v/vt/vn`: a fourth that is not empty is an error.
            (Some("f" | "l"), E::FaceParseError, _) => words.any(|w| {
                w.split('/').enumerate().any(|(k, x)| !x.is_empty() && (k > 2 || x.parse::<isize>().is_err()))
            }),
            (Some("f" | "l"), _, Some(k)) => {
                words.filter_map(|w| w.split('/').nth(k).and_then(|x| x.parse::<i128>().ok())).any(|x| {
                    let at = if x < 0 { counts[k] as i128 + x } else { x - 1 };
                    at < 0 || at >= totals[k] as i128
                })
            }
            _ => false,
        };
        if bad {
            let of = match slot {
                Some(k) => {
                    format!(" (the file has {} {})", totals[k], ["vertices", "texture coordinates", "normals"][k])
                }
                None => String::new(),
            };
            return Some(format!("{}{of}", quoted_line(i, line)));
        }
    }
    None
}

/// The first line of an MTL's `text` that tobj refuses, as "line N: `…`: what it needs", by tobj's own
/// rules: a colour (`Ka`, `Kd`, `Ks`, `Ke`) of three numbers, `Ns`, `Ni` and `d` of one, `illum` of a
/// whole number from 0 to 255, a name after `newmtl` and a file after a `map_…` or `bump`. None if
/// every line reads.
fn mtl_error_line(text: &str) -> Option<String> {
    let number = |w: Option<&str>| w.is_some_and(|w| w.parse::<f32>().is_ok());
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let needs = match words.next() {
            Some("Ka" | "Kd" | "Ks" | "Ke") if !(0..3).all(|_| number(words.next())) => "three numbers",
            Some("Ns" | "Ni" | "d") if !number(words.next()) => "a number",
            Some("illum") if words.next().is_none_or(|w| w.parse::<u8>().is_err()) => "a whole number from 0 to 255",
            Some("newmtl") if words.next().is_none() => "a name",
            Some(
                "map_Ka" | "map_Kd" | "map_Ks" | "map_Bump" | "map_bump" | "map_Ns" | "map_ns" | "map_NS" | "bump"
                | "map_d",
            ) if words.next().is_none() => "a file name",
            _ => continue,
        };
        return Some(format!("{}: needs {needs}", quoted_line(i, line)));
    }
    None
}

fn load_obj(path: &Path, want_normals: bool, flip_v: bool) -> Result<Vec<LoadedMesh>, String> {
    let opts = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let file = std::fs::File::open(path).map_err(|e| format!("OBJ: {e}"))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    // An MTL that is a device or a pipe is not read (`regular_file`): it would never end or block. One
    // with a line tobj cannot read is not handed to it (a colour of fewer than three numbers panics
    // there): its error names the line.
    let mtl_problem = std::cell::RefCell::new(None);
    let (models, mtls) = tobj::load_obj_buf(&mut BufReader::new(file), &opts, |mtl| {
        let full = dir.join(mtl);
        if let Err(e) = crate::scene::regular_file(&full) {
            *mtl_problem.borrow_mut() = Some(format!("{}: {e}", mtl.display()));
            return Err(tobj::LoadError::OpenFileFailed);
        }
        let bytes = std::fs::read(&full).map_err(|_| tobj::LoadError::OpenFileFailed)?;
        if let Some(at) = mtl_error_line(&String::from_utf8_lossy(&bytes)) {
            *mtl_problem.borrow_mut() = Some(format!("{}: {at}", mtl.display()));
            return Err(tobj::LoadError::MaterialParseError);
        }
        tobj::load_mtl_buf(&mut &bytes[..])
    })
    .map_err(|e| {
        match std::fs::read(path).ok().and_then(|b| obj_error_line(&String::from_utf8_lossy(&b), &e)) {
            Some(at) => format!("OBJ: {e}: {at}"),
            None => format!("OBJ: {e}"),
        }
    })?;
    // A missing or broken MTL is not fatal (the scene may give the material), but it is remembered.
    let (mtls, mtl_error) = match (mtls, mtl_problem.into_inner()) {
        (_, Some(why)) => (Vec::new(), Some(why)),
        (Ok(m), None) => (m, None),
        (Err(e), None) => {
            // tobj's error does not say which file: name the `mtllib` lines.
            let text = std::fs::read_to_string(path).unwrap_or_default();
            let libs: Vec<&str> =
                text.lines().filter_map(|l| l.trim().strip_prefix("mtllib ")).map(str::trim).collect();
            (Vec::new(), Some(format!("{}: {e}", libs.join(", "))))
        }
    };
    let mut out = Vec::new();
    for m in models {
        let mm = &m.mesh;
        let positions: Vec<Vec3> = mm.positions.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
        let indices: Vec<[u32; 3]> = mm.indices.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let normals = (want_normals && mm.normals.len() == mm.positions.len() && !mm.normals.is_empty())
            .then(|| mm.normals.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero()).collect());
        let mtl_diffuse = mm.material_id.and_then(|i| mtls.get(i)).and_then(|m| m.diffuse);
        let uvs = (mm.texcoords.len() * 3 == mm.positions.len() * 2 && !mm.texcoords.is_empty())
            .then(|| mm.texcoords.chunks_exact(2).map(|c| [c[0], if flip_v { 1.0 - c[1] } else { c[1] }]).collect());
        let mtl = mm.material_id.and_then(|i| mtls.get(i));
        let mtl_texture = mtl.and_then(|m| m.diffuse_texture.clone()).filter(|t| !t.is_empty());
        // An object with no faces (points, lines, an empty group) has nothing to render.
        if !indices.is_empty() {
            out.push(LoadedMesh {
                mesh: TriMesh { positions, indices, normals, uvs, ..TriMesh::default() },
                mtl_diffuse,
                mtl_texture,
                mtl_error: mtl_error.clone(),
            });
        }
    }
    if out.is_empty() {
        return Err("OBJ file has no faces".into());
    }
    Ok(out)
}

#[derive(Default)]
struct PlyVertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
    c: [f32; 3],
}

/// PLY vertex property names and their slot: 0–2 position, 3–5 normal, 6–7 texture coordinates, 8–10
/// colour.
const PLY_SLOTS: [(&str, usize); 18] = [
    ("x", 0),
    ("y", 1),
    ("z", 2),
    ("nx", 3),
    ("ny", 4),
    ("nz", 5),
    ("u", 6),
    ("v", 7),
    ("s", 6),
    ("t", 7),
    ("texture_u", 6),
    ("texture_v", 7),
    ("red", 8),
    ("green", 9),
    ("blue", 10),
    ("r", 8),
    ("g", 9),
    ("b", 10),
];

impl PlyVertex {
    fn set(&mut self, slot: usize, x: f32) {
        match slot {
            0..=2 => self.p[slot] = x,
            3..=5 => self.n[slot - 3] = x,
            6..=7 => self.uv[slot - 6] = x,
            _ => self.c[slot - 8] = x,
        }
    }
}

impl ply_rs_bw::ply::PropertyAccess for PlyVertex {
    fn new() -> Self {
        PlyVertex::default()
    }
    fn set_property(&mut self, key: &String, prop: ply_rs_bw::ply::Property) {
        let Some(v) = ply_number(prop) else { return };
        if let Some(&(_, slot)) = PLY_SLOTS.iter().find(|(k, _)| k == key) {
            self.set(slot, v);
        }
    }
}

/// A PLY scalar caustica reads, as a number: a float or a double, or a colour's 8- or 16-bit integer
/// (decoded once the mesh is read, `PlyColour`); None for another type.
fn ply_number(prop: ply_rs_bw::ply::Property) -> Option<f32> {
    use ply_rs_bw::ply::Property as P;
    match prop {
        P::Float(v) => Some(v),
        P::Double(v) => Some(v as f32),
        P::UChar(v) => Some(v as f32),
        P::UShort(v) => Some(v as f32),
        _ => None,
    }
}

/// A PLY face: its vertex indices and its colour (slots as a vertex's 8–10; zero without one).
#[derive(Default)]
struct PlyFace {
    idx: Vec<u32>,
    c: [f32; 3],
}

/// Where a colour property of a PLY element goes: 0–2 for red, green, blue.
fn ply_colour_slot(key: &str) -> Option<usize> {
    PLY_SLOTS.iter().find(|(k, s)| *k == key && *s >= 8).map(|&(_, s)| s - 8)
}

impl ply_rs_bw::ply::PropertyAccess for PlyFace {
    fn new() -> Self {
        PlyFace::default()
    }
    fn set_property(&mut self, key: &String, prop: ply_rs_bw::ply::Property) {
        use ply_rs_bw::ply::Property as P;
        if let Some(slot) = ply_colour_slot(key) {
            if let Some(v) = ply_number(prop) {
                self.c[slot] = v;
            }
            return;
        }
        if key != "vertex_indices" && key != "vertex_index" {
            return;
        }
        self.idx = match prop {
            P::ListInt(v) => v.into_iter().map(|i| i as u32).collect(),
            P::ListUInt(v) => v,
            P::ListUChar(v) => v.into_iter().map(u32::from).collect(),
            P::ListUShort(v) => v.into_iter().map(u32::from).collect(),
            P::ListShort(v) => v.into_iter().map(|i| i as u32).collect(),
            _ => return,
        };
    }
}

/// Parses a PLY file held in memory: triangles and polygons (fan-triangulated), optional normals.
pub fn parse_ply(bytes: &[u8], want_normals: bool) -> Result<TriMesh, String> {
    use ply_rs_bw::parser::Parser;
    use ply_rs_bw::ply::Encoding;
    let mut reader = std::io::Cursor::new(bytes);
    let vparser = Parser::<PlyVertex>::new();
    let header = vparser.read_header(&mut reader).map_err(|e| format!("PLY header: {e}"))?;
    let vdef = header.elements.get("vertex").ok_or("PLY has no `vertex` element")?;
    let has_normals = want_normals && vdef.properties.contains_key("nx");
    let has_uvs = ["u", "s", "texture_u"].iter().any(|k| vdef.properties.contains_key(*k));
    let vertex_colours = ply_colours(vdef, "vertex")?;
    let face_colours = match header.elements.get("face") {
        Some(fdef) => ply_colours(fdef, "face")?,
        None => None,
    };
    for k in ["x", "y", "z"] {
        if !vdef.properties.contains_key(k) {
            return Err(format!("PLY vertex element has no `{k}` property"));
        }
    }
    let (verts, faces): (Vec<PlyVertex>, Vec<PlyFace>) = if header.encoding == Encoding::Ascii {
        let rest = &bytes[reader.position() as usize..];
        parse_ascii_payload(rest, &header, has_normals)?
    } else {
        let fparser = Parser::<PlyFace>::new();
        let mut verts = Vec::new();
        let mut faces = Vec::new();
        // The parser reserves room for the count the header gives: refuse a count the file cannot hold
        // before it does (a header claiming billions of vertices would otherwise abort on allocation).
        let body = bytes.len().saturating_sub(reader.position() as usize) as u128;
        let mut needed = 0u128;
        for (name, def) in &header.elements {
            needed += def.count as u128 * min_record_bytes(def).max(1) as u128;
            if needed > body {
                return Err(format!(
                    "PLY element `{name}`: the header says {} of them, more than the {body} bytes after the header can hold",
                    def.count
                ));
            }
        }
        for (name, def) in &header.elements {
            if name == "vertex" {
                verts = vparser
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| format!("PLY vertices: {e}"))?;
            } else if name == "face" {
                faces = fparser
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| format!("PLY faces: {e}"))?;
            } else {
                // Skip other elements by reading them as faces (ignored properties).
                fparser
                    .read_payload_for_element(&mut reader, def, &header)
                    .map_err(|e| format!("PLY element {name}: {e}"))?;
            }
        }
        (verts, faces)
    };
    let positions: Vec<Vec3> = verts.iter().map(|v| Vec3::from_array(v.p)).collect();
    let normals = has_normals.then(|| verts.iter().map(|v| Vec3::from_array(v.n).normalize_or_zero()).collect());
    let uvs = has_uvs.then(|| verts.iter().map(|v| v.uv).collect());
    let colors = vertex_colours.map(|k| verts.iter().map(|v| k.decode(v.c)).collect());
    let mut indices = Vec::with_capacity(faces.len());
    let mut face_colors = face_colours.map(|_| Vec::with_capacity(faces.len()));
    for f in &faces {
        if f.idx.len() < 3 {
            return Err(format!("PLY face with {} vertices (need at least 3)", f.idx.len()));
        }
        for k in 1..f.idx.len() - 1 {
            indices.push([f.idx[0], f.idx[k], f.idx[k + 1]]);
        }
        if let (Some(out), Some(k)) = (&mut face_colors, face_colours) {
            out.extend(std::iter::repeat_n(k.decode(f.c), f.idx.len() - 2));
        }
    }
    Ok(TriMesh { positions, indices, normals, uvs, colors, face_colors, ..TriMesh::default() })
}

/// How a PLY's colour properties encode a colour: floats as they are (linear), or integers up to
/// `max` holding sRGB-encoded values. (Mitsuba 3.9.1's loader marks integer properties as normalised
/// and gamma-encoded: it decodes 16-bit colours so, though it keeps 8-bit ones as 0 to 255 with a
/// warning that it expects [0, 1]; caustica decodes both.)
#[derive(Clone, Copy, Debug, PartialEq)]
enum PlyColour {
    Linear,
    Srgb { max: f32 },
}

impl PlyColour {
    fn decode(self, c: [f32; 3]) -> Vec3 {
        match self {
            PlyColour::Linear => Vec3::from_array(c),
            PlyColour::Srgb { max } => Vec3::from_array(c.map(|x| crate::color::srgb_decode(x / max))),
        }
    }
}

/// Whether a PLY element (`what`: its vertices or faces) has colours, and how they are encoded: all
/// three of red, green and blue (or r, g, b) or none, one type for the three (uchar and ushort read as
/// sRGB, float and double as linear); another type is refused.
fn ply_colours(def: &ply_rs_bw::ply::ElementDef, what: &str) -> Result<Option<PlyColour>, String> {
    use ply_rs_bw::ply::{PropertyType, ScalarType};
    let names = [["red", "green", "blue"], ["r", "g", "b"]];
    let Some(set) = names.iter().find(|set| set.iter().any(|k| def.properties.contains_key(*k))) else {
        return Ok(None);
    };
    let mut kind = None;
    for k in set {
        let p = def.properties.get(*k).ok_or_else(|| format!("PLY {what} colour has `{}` but no `{k}`", set[0]))?;
        let this = match &p.data_type {
            PropertyType::Scalar(ScalarType::UChar) => PlyColour::Srgb { max: 255.0 },
            PropertyType::Scalar(ScalarType::UShort) => PlyColour::Srgb { max: 65535.0 },
            PropertyType::Scalar(ScalarType::Float | ScalarType::Double) => PlyColour::Linear,
            t => return Err(format!("PLY {what} colour `{k}` is {t:?} (read: uchar, ushort, float, double)")),
        };
        if kind.is_some_and(|x| x != this) {
            return Err(format!("PLY {what} colours {set:?} are not all of one type"));
        }
        kind = Some(this);
    }
    Ok(kind)
}

/// A `.serialized` file's mark and the versions read (Mitsuba 0.4 to 3 write 4; 3 lacks the mesh name).
const SERIALIZED_MARK: u16 = 0x041C;

/// Mesh `index` of a Mitsuba `.serialized` file (little-endian): each mesh is a 2-byte mark 0x041C, a
/// 2-byte version (3 or 4) and a zlib stream of flags (u32: 1 vertex normals, 2 texture coordinates,
/// 8 vertex colours, 0x2000 double precision), the mesh's name (version 4, NUL-terminated), vertex and
/// triangle counts (u64), positions, then normals, texture coordinates and colours as the flags say,
/// then u32 vertex indices; the file ends with each mesh's offset (u64; u32 in version 3) and their
/// count (u32). As Mitsuba 3 reads it: texture coordinates and colours as stored, the face-normals flag
/// ignored (the `face_normals` parameter decides).
pub fn parse_serialized(bytes: &[u8], index: u32, want_normals: bool) -> Result<TriMesh, String> {
    let u32_at = |at: usize| bytes.get(at..at + 4).map(|b| u32::from_le_bytes(b.try_into().unwrap()));
    let version_at = |at: usize| -> Result<u16, String> {
        let head = bytes.get(at..at + 4).ok_or("the file ends before a mesh's header")?;
        let (mark, version) = (u16::from_le_bytes([head[0], head[1]]), u16::from_le_bytes([head[2], head[3]]));
        if mark != SERIALIZED_MARK {
            return Err(format!("not a Mitsuba serialized mesh (mark {mark:#06x} at byte {at}, expected 0x041c)"));
        }
        if version != 3 && version != 4 {
            return Err(format!("serialized format version {version} (read: 3, 4)"));
        }
        Ok(version)
    };
    let version = version_at(0)?;
    let start = if index == 0 {
        0
    } else {
        // The end-of-file dictionary: each mesh's offset, then their count.
        let count = bytes.len().checked_sub(4).and_then(u32_at).ok_or("the file is too short for its mesh count")?;
        if index >= count {
            return Err(format!("shape_index {index}: the file holds {count} meshes (0 to {})", count.max(1) - 1));
        }
        let back = (count - index) as usize;
        let offset = if version == 4 {
            let at = bytes.len().checked_sub(4 + 8 * back).ok_or("the file is too short for its mesh offsets")?;
            u64::from_le_bytes(bytes[at..at + 8].try_into().unwrap())
        } else {
            let at = bytes.len().checked_sub(4 + 4 * back).ok_or("the file is too short for its mesh offsets")?;
            u32_at(at).unwrap() as u64
        };
        let offset = usize::try_from(offset)
            .ok()
            .filter(|&o| o < bytes.len())
            .ok_or(format!("mesh {index} starts at byte {offset}, past the file's {} bytes", bytes.len()))?;
        if version_at(offset)? != version {
            return Err(format!("mesh {index} has another format version than the file's first"));
        }
        offset
    };
    let mut z = flate2::read::ZlibDecoder::new(&bytes[start + 4..]);
    // Reads exactly n bytes, growing the buffer as data arrives (a count the stream cannot back is an
    // error, not an allocation).
    let mut take = |n: u64, what: &str| -> Result<Vec<u8>, String> {
        let mut out = Vec::new();
        (&mut z).take(n).read_to_end(&mut out).map_err(|e| format!("mesh {index}: {what}: {e}"))?;
        if (out.len() as u64) < n {
            return Err(format!("mesh {index}: the data ends inside its {what}"));
        }
        Ok(out)
    };
    let flags = u32::from_le_bytes(take(4, "flags")?.try_into().unwrap());
    if version == 4 {
        let mut name = 0;
        while take(1, "name")?[0] != 0 {
            name += 1;
            if name > 1 << 16 {
                return Err(format!("mesh {index}: its name runs past 65,536 bytes"));
            }
        }
    }
    let counts = take(16, "vertex and triangle counts")?;
    let nv = u64::from_le_bytes(counts[..8].try_into().unwrap());
    let nf = u64::from_le_bytes(counts[8..].try_into().unwrap());
    if nv > u32::MAX as u64 || nf > u32::MAX as u64 {
        return Err(format!("mesh {index}: {nv} vertices and {nf} triangles (at most {} of each)", u32::MAX));
    }
    let size = if flags & 0x2000 != 0 { 8 } else { 4 };
    let mut floats = |dim: u64, what: &str| -> Result<Vec<f32>, String> {
        let raw = take(nv * dim * size, what)?;
        Ok(if size == 8 {
            raw.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap()) as f32).collect()
        } else {
            raw.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
        })
    };
    let vec3s = |v: Vec<f32>| v.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect::<Vec<Vec3>>();
    let positions = vec3s(floats(3, "positions")?);
    let normals = if flags & 1 != 0 { Some(vec3s(floats(3, "normals")?)) } else { None };
    let uvs = if flags & 2 != 0 {
        Some(floats(2, "texture coordinates")?.chunks_exact(2).map(|c| [c[0], c[1]]).collect())
    } else {
        None
    };
    let colors = if flags & 8 != 0 { Some(vec3s(floats(3, "vertex colours")?)) } else { None };
    let raw = take(nf * 12, "triangles")?;
    let indices = raw
        .chunks_exact(12)
        .map(|c| std::array::from_fn(|k| u32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap())))
        .collect();
    let normals = normals.filter(|_| want_normals).map(|ns| ns.into_iter().map(|n| n.normalize_or_zero()).collect());
    Ok(TriMesh { positions, indices, normals, uvs, colors, ..TriMesh::default() })
}

/// The fewest bytes one binary record of `def` can take: its scalars, and the count of each list.
fn min_record_bytes(def: &ply_rs_bw::ply::ElementDef) -> usize {
    use ply_rs_bw::ply::{PropertyType, ScalarType};
    let size = |t: &ScalarType| match t {
        ScalarType::Char | ScalarType::UChar => 1,
        ScalarType::Short | ScalarType::UShort => 2,
        ScalarType::Int | ScalarType::UInt | ScalarType::Float => 4,
        ScalarType::Double => 8,
    };
    def.properties
        .values()
        .map(|p| match &p.data_type {
            PropertyType::Scalar(t) | PropertyType::List(t, _) => size(t),
        })
        .sum()
}

/// Fast ASCII payload reader: the file is split into lines and parsed in parallel, one allocation per
/// element vector (ply-rs-bw's ASCII path runs a grammar per line, which is several times slower).
fn parse_ascii_payload(
    rest: &[u8],
    header: &ply_rs_bw::ply::Header,
    normals: bool,
) -> Result<(Vec<PlyVertex>, Vec<PlyFace>), String> {
    use ply_rs_bw::ply::PropertyType;
    let text = std::str::from_utf8(rest).map_err(|_| "PLY ASCII payload is not text".to_string())?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let mut verts = Vec::new();
    let mut faces = Vec::new();
    for (name, def) in &header.elements {
        let chunk: Vec<&str> = lines.by_ref().take(def.count).collect();
        if chunk.len() != def.count {
            return Err(format!("PLY element `{name}`: header says {} lines, file has {}", def.count, chunk.len()));
        }
        if name == "vertex" {
            // Unused properties (normals when shading is flat, confidence, intensity …) are skipped unparsed.
            let slot_of = |k: &String| {
                PLY_SLOTS.iter().find(|(name, _)| name == k).map(|&(_, s)| s).filter(|s| normals || !(3..6).contains(s))
            };
            let slots: Vec<Option<usize>> = def.properties.keys().map(slot_of).collect();
            if def.properties.values().any(|p| matches!(p.data_type, PropertyType::List(..))) {
                return Err("PLY vertex element with list properties is not supported".into());
            }
            verts = chunk
                .par_iter()
                .enumerate()
                .map(|(i, line)| {
                    let mut v = PlyVertex::default();
                    let mut toks = line.split_ascii_whitespace();
                    for slot in &slots {
                        let tok = toks.next().ok_or_else(|| format!("vertex {i}: too few values"))?;
                        if let Some(s) = slot {
                            let x: f32 = tok.parse().map_err(|_| format!("vertex {i}: bad number `{tok}`"))?;
                            v.set(*s, x);
                        }
                    }
                    Ok(v)
                })
                .collect::<Result<_, String>>()?;
        } else if name == "face" {
            // What each property of a face's line is: its index list (`vertex_indices` or `vertex_index`,
            // else the first list), another list (skipped), a colour channel, or a number skipped.
            enum Field {
                Indices,
                List,
                Colour(usize),
                Skip,
            }
            let named = def.properties.keys().position(|k| k == "vertex_indices" || k == "vertex_index");
            let first_list = def.properties.values().position(|p| matches!(p.data_type, PropertyType::List(..)));
            let fields: Vec<Field> = def
                .properties
                .iter()
                .enumerate()
                .map(|(k, (key, p))| match p.data_type {
                    PropertyType::List(..) if Some(k) == named.or(first_list) => Field::Indices,
                    PropertyType::List(..) => Field::List,
                    _ => ply_colour_slot(key).map_or(Field::Skip, Field::Colour),
                })
                .collect();
            faces = chunk
                .par_iter()
                .enumerate()
                .map(|(i, line)| {
                    let mut toks = line.split_ascii_whitespace();
                    let mut f = PlyFace::default();
                    let mut next = |what: &str| toks.next().ok_or_else(|| format!("face {i}: no {what}"));
                    for field in &fields {
                        match field {
                            Field::Indices | Field::List => {
                                let t = next("count")?;
                                let n: usize = t.parse().map_err(|_| format!("face {i}: bad count `{t}`"))?;
                                // The count is the file's word: the line's own tokens bound what is read.
                                let mut idx = Vec::with_capacity(n.min(16));
                                for _ in 0..n {
                                    let t = next("index")?;
                                    idx.push(t.parse::<u32>().map_err(|_| format!("face {i}: bad index `{t}`"))?);
                                }
                                if let Field::Indices = field {
                                    f.idx = idx;
                                }
                            }
                            Field::Colour(c) => {
                                let t = next("colour")?;
                                f.c[*c] = t.parse().map_err(|_| format!("face {i}: bad colour `{t}`"))?;
                            }
                            Field::Skip => {
                                next("value")?;
                            }
                        }
                    }
                    Ok(f)
                })
                .collect::<Result<_, String>>()?;
        }
    }
    Ok((verts, faces))
}

/// Parallelogram with front side edge_u × edge_v.
pub fn quad(corner: Vec3, eu: Vec3, ev: Vec3) -> TriMesh {
    TriMesh {
        positions: vec![corner, corner + eu, corner + eu + ev, corner + ev],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
        ..TriMesh::default()
    }
}

/// Disk as a triangle fan, front side along `normal`, with Mitsuba's `disk` texture coordinates: u the
/// distance from the centre over the radius, v the angle from the frame's first axis (+x for a normal
/// along +z, as Mitsuba's disk lies in its local xy plane) over 2π, in [0, 1). Each triangle has its
/// own three vertices, so that v runs from i/n to (i + 1)/n across triangle i (the last one ends at 1,
/// not 0) and the centre takes the triangle's middle angle: v is then off by at most half a triangle's
/// angle (1/(2n)) near the centre and exact along the rim.
pub fn disk(center: Vec3, normal: Vec3, radius: f32, segments: u32) -> TriMesh {
    let f = crate::math::Frame::from_normal(normal.normalize());
    let rim = |i: u32| {
        let phi = std::f32::consts::TAU * i as f32 / segments as f32;
        center + radius * (f.s * phi.cos() + f.t * phi.sin())
    };
    let n = segments as f32;
    let mut m = TriMesh { uvs: Some(Vec::new()), ..TriMesh::default() };
    for i in 0..segments {
        let base = m.positions.len() as u32;
        m.positions.extend([center, rim(i), rim((i + 1) % segments)]);
        let (v0, v1) = (i as f32 / n, (i + 1) as f32 / n);
        m.uvs.as_mut().unwrap().extend([[0.0, (v0 + v1) / 2.0], [1.0, v0], [1.0, v1]]);
        m.indices.push([base, base + 1, base + 2]);
    }
    m
}

/// Mitsuba's `cylinder` in its own axes: the open tube of radius 1 about z from z = 0 to z = 1 with
/// `segments` sides and outward radial normals (smooth shading), and Mitsuba's texture coordinates: u the
/// angle from +x towards +y over 2π, v = z. The seam's vertices are there twice, at u = 0 and u = 1, in
/// the same place (the surface stays closed).
pub fn cylinder(segments: u32) -> TriMesh {
    let mut m = TriMesh { uvs: Some(Vec::new()), normals: Some(Vec::new()), ..TriMesh::default() };
    for j in 0..=segments {
        let phi = std::f32::consts::TAU * (j % segments) as f32 / segments as f32;
        let (sin, cos) = phi.sin_cos();
        let u = j as f32 / segments as f32;
        for z in [0.0, 1.0] {
            m.positions.push(Vec3::new(cos, sin, z));
            m.normals.as_mut().unwrap().push(Vec3::new(cos, sin, 0.0));
            m.uvs.as_mut().unwrap().push([u, z]);
        }
    }
    for j in 0..segments {
        // a, b: this column's bottom and top; c, d: the next one's (the angle grows from a to c).
        let (a, b, c, d) = (2 * j, 2 * j + 1, 2 * j + 2, 2 * j + 3);
        m.indices.push([a, c, b]);
        m.indices.push([c, d, b]);
    }
    m
}

/// Mitsuba's `sphere` in its own axes as a mesh: the unit sphere about the origin with `columns` steps of
/// longitude and `rows` of polar angle, its exact outward normals at the vertices (smooth shading) and
/// Mitsuba's texture coordinates (u the longitude from +x towards +y over 2π, v the polar angle from
/// +z over π). The seam's vertices are there twice, at u = 0 and u = 1; the triangles that collapse at
/// the poles are left out. For a sphere an uneven transform turns into an ellipsoid.
pub fn uv_sphere(rows: u32, columns: u32) -> TriMesh {
    let mut m = TriMesh { uvs: Some(Vec::new()), normals: Some(Vec::new()), ..TriMesh::default() };
    for i in 0..=rows {
        let v = i as f32 / rows as f32;
        let (sin_t, cos_t) = (std::f32::consts::PI * v).sin_cos();
        // Exactly on the poles, whatever the rounding of sin(π).
        let (sin_t, cos_t) = match i {
            0 => (0.0, 1.0),
            _ if i == rows => (0.0, -1.0),
            _ => (sin_t, cos_t),
        };
        for j in 0..=columns {
            let u = j as f32 / columns as f32;
            let (sin_p, cos_p) = (std::f32::consts::TAU * (j % columns) as f32 / columns as f32).sin_cos();
            let q = Vec3::new(sin_t * cos_p, sin_t * sin_p, cos_t);
            m.positions.push(q);
            m.normals.as_mut().unwrap().push(q);
            m.uvs.as_mut().unwrap().push([u, v]);
        }
    }
    // Longitude grows along a row, the polar angle (away from +z) down the rows: the quads face out.
    grid_quads(&mut m, rows as usize, columns, |i, j| i as u32 * (columns + 1) + j);
    m
}

/// Two triangles for each quad of a grid of `rows` × `columns` cells whose corner (i, j) is vertex
/// `idx(i, j)` (i up to `rows`, j up to `columns`), wound (i, j), (i + 1, j), (i, j + 1) and (i, j + 1),
/// (i + 1, j), (i + 1, j + 1); the triangles that collapse (a pole, a point on an axis) are left out.
fn grid_quads(m: &mut TriMesh, rows: usize, columns: u32, idx: impl Fn(usize, u32) -> u32) {
    for i in 0..rows {
        for j in 0..columns {
            let (a, b, c, d) = (idx(i, j), idx(i, j + 1), idx(i + 1, j), idx(i + 1, j + 1));
            for t in [[a, c, b], [b, c, d]] {
                let [p, q, r] = t.map(|k| m.positions[k as usize]);
                if (q - p).cross(r - p).length_squared() > 0.0 {
                    m.indices.push(t);
                }
            }
        }
    }
}

/// Surface of revolution about the y axis; profile points [r, y] bottom to top give outward normals.
/// Triangles that collapse on the axis (r = 0) are left out.
pub fn lathe(profile: &[[f32; 2]], segments: u32) -> TriMesh {
    let mut m = TriMesh::default();
    for &[r, y] in profile {
        for j in 0..segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            m.positions.push(Vec3::new(r * phi.cos(), y, r * phi.sin()));
        }
    }
    grid_quads(&mut m, profile.len().saturating_sub(1), segments, |i, j| (i as u32) * segments + (j % segments));
    m
}

/// Regular grid y = f(x, z) over [−sx/2, sx/2] × [−sz/2, sz/2], upward-facing triangles.
pub fn heightfield(size: [f32; 2], res: [u32; 2], f: impl Fn(f32, f32) -> f32) -> TriMesh {
    let (nx, nz) = (res[0].max(1), res[1].max(1));
    let mut m = TriMesh::default();
    for k in 0..=nz {
        for i in 0..=nx {
            let x = (i as f32 / nx as f32 - 0.5) * size[0];
            let z = (k as f32 / nz as f32 - 0.5) * size[1];
            m.positions.push(Vec3::new(x, f(x, z), z));
        }
    }
    let v = |i: u32, k: u32| k * (nx + 1) + i;
    for k in 0..nz {
        for i in 0..nx {
            m.indices.push([v(i, k), v(i, k + 1), v(i + 1, k)]);
            m.indices.push([v(i + 1, k), v(i, k + 1), v(i + 1, k + 1)]);
        }
    }
    m
}

/// Axis-aligned box with outward-facing triangles. Each face maps the whole of [0, 1]² in uv, turned as
/// Mitsuba's `cube` turns it (its 24 vertices' texture coordinates, as functions of the position
/// scaled to [−1, 1]³), so that an image on a `cube` reads the same in both.
pub fn cuboid(min: Vec3, max: Vec3) -> TriMesh {
    let s = max - min;
    let (x, y, z) = (Vec3::X * s.x, Vec3::Y * s.y, Vec3::Z * s.z);
    // Corner, edges, and the face's (u, v) at a point q of the box scaled to [−1, 1]³.
    type Uv = fn(Vec3) -> [f32; 2];
    let faces: [(Vec3, Vec3, Vec3, Uv); 6] = [
        (min, z, y, |q| [(q.y + 1.0) / 2.0, (q.z + 1.0) / 2.0]),     // -x
        (min + x, y, z, |q| [(q.y + 1.0) / 2.0, (1.0 - q.z) / 2.0]), // +x
        (min, x, z, |q| [(q.z + 1.0) / 2.0, (q.x + 1.0) / 2.0]),     // -y
        (min + y, z, x, |q| [(1.0 - q.x) / 2.0, (1.0 - q.z) / 2.0]), // +y
        (min, y, x, |q| [(1.0 - q.y) / 2.0, (q.x + 1.0) / 2.0]),     // -z
        (min + z, x, y, |q| [(q.y + 1.0) / 2.0, (q.x + 1.0) / 2.0]), // +z
    ];
    let unit = |p: Vec3| (p - min) / s * 2.0 - Vec3::ONE;
    let mut m = TriMesh { uvs: Some(Vec::new()), ..TriMesh::default() };
    for (c, u, v, uv) in faces {
        let q = quad(c, u, v);
        let base = m.positions.len() as u32;
        m.uvs.as_mut().unwrap().extend(q.positions.iter().map(|&p| uv(unit(p))));
        m.positions.extend(q.positions);
        m.indices.extend(q.indices.iter().map(|t| [t[0] + base, t[1] + base, t[2] + base]));
    }
    m
}

/// One curve of a curve file: its control points, each a centre and a radius.
pub type Curve = Vec<(Vec3, f32)>;

/// Reads a curve file as Mitsuba's `linearcurve` reads it: one control point a line, `x y z radius`
/// (numbers after the fourth ignored), a blank line between two curves, each curve of at least
/// `least` points (Mitsuba's: two for `linearcurve`, four for `bsplinecurve`). Refused, naming the line:
/// a line that does not start with four numbers, a point or a radius that is not finite, a negative
/// radius, a curve of fewer points, a file without any point.
pub fn read_curves(path: &Path, shown: &str, least: usize) -> Result<Vec<Curve>, SceneError> {
    let err = |msg: String| SceneError::Mesh { file: shown.into(), msg };
    if !path.exists() {
        return Err(SceneError::MissingFile { file: shown.into() });
    }
    let text = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    let text = String::from_utf8_lossy(&text);
    let mut curves: Vec<Curve> = Vec::new();
    let mut current: Curve = Vec::new();
    let mut first_line = 0;
    let mut end = |current: &mut Curve, first_line: usize| -> Result<(), SceneError> {
        match current.len() {
            0 => Ok(()),
            n if n < least => {
                Err(err(format!("line {first_line}: a curve needs at least {least} control points, this one has {n}")))
            }
            _ => {
                curves.push(std::mem::take(current));
                Ok(())
            }
        }
    };
    for (i, line) in text.split('\n').enumerate() {
        let line_no = i + 1;
        let mut words = line.split_whitespace();
        if line.trim().is_empty() {
            end(&mut current, first_line)?;
            continue;
        }
        let mut v = [0.0f32; 4];
        for (k, slot) in v.iter_mut().enumerate() {
            let word = words.next().unwrap_or("");
            *slot = word.parse().map_err(|_| {
                err(format!("line {line_no}: expected four numbers `x y z radius`, number {} is `{word}`", k + 1))
            })?;
        }
        if !v.iter().all(|x| x.is_finite()) {
            return Err(err(format!("line {line_no}: a control point must be finite, got {v:?}")));
        }
        if v[3] < 0.0 {
            return Err(err(format!("line {line_no}: a radius must be ≥ 0, got {}", v[3])));
        }
        if current.is_empty() {
            first_line = line_no;
        }
        current.push((Vec3::new(v[0], v[1], v[2]), v[3]));
    }
    end(&mut current, first_line)?;
    if curves.is_empty() {
        return Err(err("the file holds no control point".into()));
    }
    Ok(curves)
}

/// Mitsuba's frame round a curve's unit tangent `t` (its `local_frame`): the rotation axis, +z made
/// orthogonal to `t` (+y where `t` is ±z), and the radial direction, that axis × `t`. u = 0 lies along
/// the radial direction and a quarter turn along the rotation axis.
fn curve_frame(t: Vec3) -> (Vec3, Vec3) {
    let rot = if t.z.abs() == 1.0 { Vec3::Y } else { (Vec3::Z - t * t.z).normalize() };
    (rot, rot.cross(t))
}

/// Appends one vertex of a curve's mesh: its position, unit normal and texture coordinates.
fn curve_vertex(m: &mut TriMesh, p: Vec3, n: Vec3, uv: [f32; 2]) {
    m.positions.push(p);
    m.normals.get_or_insert_with(Vec::new).push(n);
    m.uvs.get_or_insert_with(Vec::new).push(uv);
}

/// Mitsuba's `linearcurve` (Embree's round linear curves) as a closed mesh: along each segment the cone
/// that touches the spheres round its two control points, and those spheres beyond where it touches
/// them (the first point's only on a curve's first segment; a later segment starts inside the sphere
/// that ends the one before). `around` steps round each ring; the spheres' caps take `around / 4`
/// rings. Exact outward normals at the vertices, and Mitsuba's texture coordinates: u the angle round
/// the segment's axis from its frame's radial direction (Mitsuba's frame, built on +z) over 2π, v
/// (t + k) / n along segment k of all n segments of the file, t going 0 → 1 along the cone and held at 0
/// on the start sphere and at 1 on the end sphere, as Embree reports it.
pub fn round_linear_curves(curves: &[Curve], around: u32) -> TriMesh {
    let mut m = TriMesh { uvs: Some(Vec::new()), normals: Some(Vec::new()), cull_back: true, ..TriMesh::default() };
    let total = curves.iter().map(|c| c.len() - 1).sum::<usize>().max(1) as f32;
    let rings = (around / 4).max(2);
    let mut k = 0usize;
    for c in curves {
        for (s, w) in c.windows(2).enumerate() {
            let [(p0, r0), (p1, r1)] = [w[0], w[1]];
            let d = p1 - p0;
            let len = d.length();
            let axis = if len > 0.0 { d / len } else { Vec3::Z };
            let (rot, rad) = curve_frame(axis);
            // The cone's normal leans back by sin α = (r1 − r0) / length; none where one sphere holds
            // the other.
            let sin_a = if len > 0.0 { (r1 - r0) / len } else { 2.0 };
            let cone = sin_a.abs() < 1.0;
            let (v0, v1) = ((k as f32) / total, (k as f32 + 1.0) / total);
            let normal = |phi: f32, cos_t: f32, sin_t: f32, pole: Vec3| {
                let (sp, cp) = phi.sin_cos();
                pole * cos_t + (rad * cp + rot * sp) * sin_t
            };
            // A sphere's cap about `pole` out to polar angle `theta`, its rings from the pole.
            let cap = |m: &mut TriMesh, centre: Vec3, r: f32, pole: Vec3, theta: f32, v: f32, turn: bool| {
                let base = m.positions.len() as u32;
                for i in 0..=rings {
                    let t = theta * i as f32 / rings as f32;
                    let (sin_t, cos_t) = if i == 0 { (0.0, 1.0) } else { t.sin_cos() };
                    for j in 0..=around {
                        let phi = std::f32::consts::TAU * (j % around) as f32 / around as f32;
                        let n = normal(phi, cos_t, sin_t, pole);
                        curve_vertex(m, centre + n * r, n, [j as f32 / around as f32, v]);
                    }
                }
                let from = m.indices.len();
                grid_quads(m, rings as usize, around, |i, j| base + i as u32 * (around + 1) + j);
                if turn {
                    for t in &mut m.indices[from..] {
                        t.swap(1, 2);
                    }
                }
            };
            let full = std::f32::consts::PI;
            if s == 0 {
                // About −axis out to where the cone touches (n·axis = −sin α), all of it without a cone.
                let theta = if cone { sin_a.acos() } else { full };
                cap(&mut m, p0, r0, -axis, theta, v0, true);
            }
            let theta = if cone { (-sin_a).acos() } else { full };
            cap(&mut m, p1, r1, axis, theta, v1, false);
            if cone {
                let cos_a = (1.0 - sin_a * sin_a).sqrt();
                let base = m.positions.len() as u32;
                for j in 0..=around {
                    let phi = std::f32::consts::TAU * (j % around) as f32 / around as f32;
                    let n = normal(phi, -sin_a, cos_a, axis);
                    for (p, r, v) in [(p0, r0, v0), (p1, r1, v1)] {
                        curve_vertex(&mut m, p + n * r, n, [j as f32 / around as f32, v]);
                    }
                }
                grid_quads(&mut m, around as usize, 1, |i, j| base + 2 * i as u32 + j);
            }
            k += 1;
        }
    }
    m
}

/// Mitsuba's `bsplinecurve` (Embree's round B-spline curves) as a mesh: round each segment's centre
/// line c(u), the uniform cubic B-spline of four consecutive control points (u from 0 to 1), the circle
/// of radius r(u) (the same spline of their radii) in the plane across c′(u), which is the surface
/// Mitsuba 3.9.1 reports hits on; open at both ends, as Mitsuba's (whose inside, seen through them, it
/// culls). `around` steps round each ring, `steps` along each segment. Exact normals at the vertices
/// ((|c′|² − (p − c)·c″)(p − c) − r r′ c′, Mitsuba's), and its texture coordinates: u round the centre
/// line from its frame's radial direction (built on +z) over 2π, v (u + k) / n along segment k of the
/// file's n.
pub fn round_bspline_curves(curves: &[Curve], around: u32, steps: u32) -> TriMesh {
    let mut m = TriMesh { uvs: Some(Vec::new()), normals: Some(Vec::new()), cull_back: true, ..TriMesh::default() };
    let total = curves.iter().map(|c| c.len().saturating_sub(3)).sum::<usize>().max(1) as f32;
    let mut k = 0usize;
    for c in curves {
        for w in c.windows(4) {
            let base = m.positions.len() as u32;
            for i in 0..=steps {
                let u = i as f32 / steps as f32;
                let (u2, u3) = (u * u, u * u * u);
                let b = [
                    -u3 + 3.0 * u2 - 3.0 * u + 1.0,
                    3.0 * u3 - 6.0 * u2 + 4.0,
                    -3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0,
                    u3,
                ];
                let db = [-3.0 * u2 + 6.0 * u - 3.0, 9.0 * u2 - 12.0 * u, -9.0 * u2 + 6.0 * u + 3.0, 3.0 * u2];
                let ddb = [6.0 * (1.0 - u), 6.0 * (3.0 * u - 2.0), 6.0 * (1.0 - 3.0 * u), 6.0 * u];
                let sum = |f: &[f32; 4]| {
                    w.iter().zip(f).fold((Vec3::ZERO, 0.0), |(p, r), ((q, s), f)| (p + *q * *f, r + s * f))
                };
                let ((centre, radius), (dc, dr), (ddc, _)) = (sum(&b), sum(&db), sum(&ddb));
                let (centre, radius, dc, dr, ddc) = (centre / 6.0, radius / 6.0, dc / 6.0, dr / 6.0, ddc / 6.0);
                let (rot, rad) = curve_frame(dc.normalize_or(Vec3::X));
                for j in 0..=around {
                    let phi = std::f32::consts::TAU * (j % around) as f32 / around as f32;
                    let (sp, cp) = phi.sin_cos();
                    let d = rad * cp + rot * sp;
                    let n = (dc.length_squared() - radius * d.dot(ddc)) * d - dr * dc;
                    curve_vertex(
                        &mut m,
                        centre + d * radius,
                        n.normalize_or(d),
                        [j as f32 / around as f32, (u + k as f32) / total],
                    );
                }
            }
            // Rows round the ring, columns along the segment: the quads face out (as the cone's).
            grid_quads(&mut m, around as usize, steps, |i, j| base + j * (around + 1) + i as u32);
            k += 1;
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A mesh without texture coordinates keeps Mitsuba's barycentric uv and tangents (u along the
    /// file's second corner, v along its third) when a mirroring transform or `flip` turns its winding:
    /// at the same point, uv and ∂p/∂u, ∂p/∂v are the unturned triangle's (random scene 2555: an
    /// anisotropic rough glass on a mirrored ball differed from Mitsuba by 3.6% in a block, its
    /// roughness's axes swapped on every triangle).
    #[test]
    fn turned_winding_keeps_the_files_barycentric_uv_and_tangents() {
        let (a, b, c) = (Vec3::new(0.1, 0.2, 0.0), Vec3::new(1.3, 0.1, 0.2), Vec3::new(0.4, 0.9, -0.1));
        let mesh = TriMesh { positions: vec![a, b, c], indices: vec![[0, 1, 2]], ..TriMesh::default() };
        let mirror = Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0));
        let (mut mirrored, mut flipped, mut both) = (mesh.clone(), mesh.clone(), mesh.clone());
        mirrored.transform(&mirror);
        flipped.flip();
        both.transform(&mirror);
        both.flip();
        for (name, m, map) in
            [("mirrored", &mirrored, mirror), ("flipped", &flipped, Mat4::IDENTITY), ("both", &both, mirror)]
        {
            let [p0, p1, p2] = m.triangle(0);
            let [q0, q1, q2] = [a, b, c].map(|p| map.transform_point3(p));
            let (du, dv) = m.dp_duv(0);
            assert!((du - (q1 - q0)).length() < 1e-6 && (dv - (q2 - q0)).length() < 1e-6, "{name}: {du} {dv}");
            for bary in [[0.2f32, 0.3], [0.6, 0.1], [0.0, 1.0]] {
                // The point at the stored corners' barycentrics, and its uv: the file's corners' weights.
                let p = p0 * (1.0 - bary[0] - bary[1]) + p1 * bary[0] + p2 * bary[1];
                let uv = m.uv_at(0, bary);
                let back = q0 * (1.0 - uv.x - uv.y) + q1 * uv.x + q2 * uv.y;
                assert!((p - back).length() < 1e-6, "{name}: {bary:?} read as {uv}");
            }
        }
    }

    /// `face_vertex_normals` turns the triangles whose vertex normals point behind them, each on its
    /// own, and keeps their uv and tangents the file's corners' barycentrics, as a mirror does: here the
    /// second of two copies of one triangle, its normals against its winding.
    #[test]
    fn facing_its_vertex_normals_turns_only_those_against_and_keeps_their_uv() {
        let (a, b, c) = (Vec3::new(0.1, 0.2, 0.0), Vec3::new(1.3, 0.1, 0.2), Vec3::new(0.4, 0.9, -0.1));
        let n = (b - a).cross(c - a).normalize();
        let mut m = TriMesh {
            positions: vec![a, b, c, a, b, c],
            indices: vec![[0, 1, 2], [3, 4, 5]],
            normals: Some(vec![n, n, n, -n, -n * 0.5 + Vec3::X * 0.1, -n]),
            ..TriMesh::default()
        };
        assert_eq!(m.face_vertex_normals(), 1);
        assert_eq!(m.indices, vec![[0, 1, 2], [3, 5, 4]]);
        assert!(!m.turned_at(0) && m.turned_at(1));
        let [p0, p1, p2] = m.triangle(1);
        assert!((p1 - p0).cross(p2 - p0).dot(n) < 0.0, "the second triangle faces its normals");
        assert_eq!(m.dp_duv(1), (b - a, c - a));
        for bary in [[0.2f32, 0.3], [0.6, 0.1], [0.0, 1.0]] {
            let p = p0 * (1.0 - bary[0] - bary[1]) + p1 * bary[0] + p2 * bary[1];
            let uv = m.uv_at(1, bary);
            let back = a * (1.0 - uv.x - uv.y) + b * uv.x + c * uv.y;
            assert!((p - back).length() < 1e-6, "{bary:?} read as {uv}");
        }
        // Turning every triangle turns the mesh.
        let mut all = TriMesh { normals: Some(vec![-n; 6]), ..m.clone() };
        all.indices = vec![[0, 1, 2], [3, 4, 5]];
        all.turned_alone.clear();
        assert_eq!(all.face_vertex_normals(), 2);
        assert!(all.turned && all.turned_alone.is_empty() && all.turned_at(0) && all.turned_at(1));
        // Without vertex normals nothing turns.
        let mut bare = TriMesh { normals: None, ..all.clone() };
        assert_eq!(bare.face_vertex_normals(), 0);
    }

    /// One mesh of a `.serialized` file: header, then the zlib stream (version 3 has no name).
    fn serialized_mesh(version: u16, flags: u32, positions: &[f64], extra: &[f64], tris: &[u32]) -> Vec<u8> {
        serialized_record(version, &serialized_body(version, flags, positions, extra, tris))
    }

    /// A mesh's uncompressed stream: flags, name (version 4), counts, the floats, the indices.
    fn serialized_body(version: u16, flags: u32, positions: &[f64], extra: &[f64], tris: &[u32]) -> Vec<u8> {
        let mut body = flags.to_le_bytes().to_vec();
        if version == 4 {
            body.extend_from_slice(b"part\0");
        }
        body.extend_from_slice(&(positions.len() as u64 / 3).to_le_bytes());
        body.extend_from_slice(&(tris.len() as u64 / 3).to_le_bytes());
        for &v in positions.iter().chain(extra) {
            if flags & 0x2000 != 0 {
                body.extend_from_slice(&v.to_le_bytes());
            } else {
                body.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        for &i in tris {
            body.extend_from_slice(&i.to_le_bytes());
        }
        body
    }

    /// The mark, the version and the zlib-compressed `body`.
    fn serialized_record(version: u16, body: &[u8]) -> Vec<u8> {
        use std::io::Write;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(body).unwrap();
        let mut out = 0x041Cu16.to_le_bytes().to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        out.extend(z.finish().unwrap());
        out
    }

    /// Both versions of Mitsuba's serialized format, single and double precision, several meshes found
    /// through the end-of-file offsets (u32 in version 3, u64 in 4); normals kept only when asked for and
    /// normalised, texture coordinates and colours as stored; damaged files refused with what is
    /// wrong, a count the data cannot back refused without allocating for it.
    #[test]
    fn serialized_meshes_read_as_mitsuba_writes_them() {
        let tri = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0];
        let quad = [0.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 1.0, 1.0];
        for version in [3u16, 4] {
            let a = serialized_mesh(version, 0x1000, &tri, &[], &[0, 1, 2]);
            // Normals (unnormalised in the file), uvs and colours, in double precision.
            let mut extra = [0.0, 0.0, 2.0].repeat(4);
            extra.extend([0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0]);
            extra.extend([0.5, 0.25, 0.125].repeat(4));
            let b = serialized_mesh(version, 0x2000 | 1 | 2 | 8, &quad, &extra, &[0, 1, 2, 0, 2, 3]);
            let mut file = a.clone();
            file.extend(&b);
            if version == 4 {
                file.extend(0u64.to_le_bytes());
                file.extend((a.len() as u64).to_le_bytes());
            } else {
                file.extend(0u32.to_le_bytes());
                file.extend((a.len() as u32).to_le_bytes());
            }
            file.extend(2u32.to_le_bytes());
            let m0 = parse_serialized(&file, 0, true).unwrap();
            assert_eq!(m0.positions, vec![Vec3::ZERO, Vec3::X, Vec3::new(0.0, 2.0, 0.0)]);
            assert_eq!((m0.indices.clone(), m0.normals.is_none(), m0.uvs.is_none()), (vec![[0, 1, 2]], true, true));
            let m1 = parse_serialized(&file, 1, true).unwrap();
            assert_eq!(m1.indices, vec![[0, 1, 2], [0, 2, 3]]);
            assert_eq!(m1.positions[2], Vec3::new(1.0, 1.0, 1.0));
            assert_eq!(m1.normals.as_ref().unwrap()[3], Vec3::Z);
            assert_eq!(m1.uvs.as_ref().unwrap()[2], [1.0, 1.0]);
            assert_eq!(m1.colors.as_ref().unwrap()[3], Vec3::new(0.5, 0.25, 0.125));
            assert!(m0.colors.is_none());
            assert!(parse_serialized(&file, 1, false).unwrap().normals.is_none());
            let past = parse_serialized(&file, 2, true).unwrap_err();
            assert!(past.contains("holds 2 meshes"), "{past}");
            // Truncated inside the second mesh's triangles.
            let cut = parse_serialized(&b[..b.len() - 6], 0, true).unwrap_err();
            assert!(cut.contains("triangles") || cut.contains("mesh 0"), "{cut}");
        }
        let mut wrong = serialized_mesh(4, 0, &tri, &[], &[0, 1, 2]);
        wrong[0] = 0x1D;
        assert!(parse_serialized(&wrong, 0, true).unwrap_err().contains("not a Mitsuba serialized mesh"));
        let mut v5 = serialized_mesh(4, 0, &tri, &[], &[0, 1, 2]);
        v5[2] = 5;
        assert!(parse_serialized(&v5, 0, true).unwrap_err().contains("version 5"));
        // A header claiming four billion triangles over a few bytes of data (after the flags and the
        // name "part\0", the vertex count, then the triangle count).
        let mut body = serialized_body(4, 0, &tri, &[], &[0, 1, 2]);
        body[4 + 5 + 8..4 + 5 + 16].copy_from_slice(&(u32::MAX as u64).to_le_bytes());
        let e = parse_serialized(&serialized_record(4, &body), 0, true).unwrap_err();
        assert!(e.contains("ends inside its triangles"), "{e}");
    }

    #[test]
    fn cuboid_normals_point_outward_and_area_is_right() {
        let m = cuboid(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        let c = Vec3::new(0.5, 1.0, 1.5);
        for i in 0..m.indices.len() {
            let [a, b, cc] = m.triangle(i);
            let n = (b - a).cross(cc - a);
            assert!(n.dot((a + b + cc) / 3.0 - c) > 0.0, "triangle {i} faces inward");
        }
        assert!((m.total_area() - 2.0 * (2.0 + 3.0 + 6.0)).abs() < 1e-4);
    }

    /// Every corner of Mitsuba 3's `cube` (its 24 vertices: position, face normal, texture coordinates,
    /// copied from its source) has the same texture coordinates on caustica's box [−1, 1]³.
    #[test]
    fn cuboid_texture_coordinates_are_mitsubas() {
        #[rustfmt::skip]
        let mitsuba: [([f32; 3], [f32; 3], [f32; 2]); 24] = [
            ([1., -1., -1.], [0., -1., 0.], [0., 1.]), ([1., -1., 1.], [0., -1., 0.], [1., 1.]),
            ([-1., -1., 1.], [0., -1., 0.], [1., 0.]), ([-1., -1., -1.], [0., -1., 0.], [0., 0.]),
            ([1., 1., -1.], [0., 1., 0.], [0., 1.]), ([-1., 1., -1.], [0., 1., 0.], [1., 1.]),
            ([-1., 1., 1.], [0., 1., 0.], [1., 0.]), ([1., 1., 1.], [0., 1., 0.], [0., 0.]),
            ([1., -1., -1.], [1., 0., 0.], [0., 1.]), ([1., 1., -1.], [1., 0., 0.], [1., 1.]),
            ([1., 1., 1.], [1., 0., 0.], [1., 0.]), ([1., -1., 1.], [1., 0., 0.], [0., 0.]),
            ([1., -1., 1.], [0., 0., 1.], [0., 1.]), ([1., 1., 1.], [0., 0., 1.], [1., 1.]),
            ([-1., 1., 1.], [0., 0., 1.], [1., 0.]), ([-1., -1., 1.], [0., 0., 1.], [0., 0.]),
            ([-1., -1., 1.], [-1., 0., 0.], [0., 1.]), ([-1., 1., 1.], [-1., 0., 0.], [1., 1.]),
            ([-1., 1., -1.], [-1., 0., 0.], [1., 0.]), ([-1., -1., -1.], [-1., 0., 0.], [0., 0.]),
            ([1., 1., -1.], [0., 0., -1.], [0., 1.]), ([1., -1., -1.], [0., 0., -1.], [1., 1.]),
            ([-1., -1., -1.], [0., 0., -1.], [1., 0.]), ([-1., 1., -1.], [0., 0., -1.], [0., 0.]),
        ];
        let m = cuboid(Vec3::splat(-1.0), Vec3::ONE);
        let uvs = m.uvs.as_ref().expect("a box has texture coordinates");
        for (p, n, uv) in mitsuba {
            let (p, n) = (Vec3::from_array(p), Vec3::from_array(n));
            let mut found = 0;
            for (i, t) in m.indices.iter().enumerate() {
                let [a, b, c] = m.triangle(i);
                if (b - a).cross(c - a).normalize().dot(n) < 0.999 {
                    continue;
                }
                for &k in t {
                    if (m.positions[k as usize] - p).length() < 1e-6 {
                        assert_eq!(uvs[k as usize], uv, "corner {p} of the face facing {n}");
                        found += 1;
                    }
                }
            }
            assert!(found > 0, "no corner {p} on the face facing {n}");
        }
    }

    #[test]
    fn lathe_cylinder_faces_outward_and_has_the_right_area() {
        let m = lathe(&[[1.0, 0.0], [1.0, 2.0]], 256);
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            let n = (b - a).cross(c - a);
            let centre = (a + b + c) / 3.0;
            assert!(n.dot(Vec3::new(centre.x, 0.0, centre.z)) > 0.0);
        }
        let expect = std::f32::consts::TAU * 2.0;
        assert!((m.total_area() - expect).abs() < 1e-3 * expect, "{}", m.total_area());
    }

    /// The tube faces outward with its radial normals, covers 2π r h (to the polygon's area), keeps its
    /// seam closed, and its ∂p/∂u runs around the axis as Mitsuba's (2π along growing angle).
    #[test]
    fn cylinder_faces_outward_with_mitsubas_texture_coordinates() {
        let m = cylinder(256);
        let ns = m.normals.as_ref().unwrap();
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            let n = (b - a).cross(c - a);
            let centre = (a + b + c) / 3.0;
            assert!(n.dot(Vec3::new(centre.x, centre.y, 0.0)) > 0.0, "triangle {i} faces inward");
            for k in m.indices[i] {
                let p = m.positions[k as usize];
                assert!((ns[k as usize] - Vec3::new(p.x, p.y, 0.0)).length() < 1e-6);
            }
            let du = m.dp_duv(i).0;
            let around = Vec3::new(-centre.y, centre.x, 0.0).normalize();
            assert!(du.normalize().dot(around) > 0.9999, "triangle {i}: ∂p/∂u {du}");
            assert!((du.length() / std::f32::consts::TAU - 1.0).abs() < 1e-3, "triangle {i}: |∂p/∂u| {}", du.length());
        }
        // 256 flat sides of width 2 sin(π/256) and height 1.
        let sides = 256.0 * 2.0 * (std::f32::consts::PI / 256.0).sin();
        assert!((m.total_area() / sides - 1.0).abs() < 1e-4, "{} against {sides}", m.total_area());
        // The seam's two columns share their places.
        let last = m.positions.len() - 2;
        assert_eq!(m.positions[0], m.positions[last]);
        assert_eq!(m.uvs.as_ref().unwrap()[last], [1.0, 0.0]);
    }

    #[test]
    fn heightfield_faces_up() {
        let m = heightfield([2.0, 1.0], [8, 4], |x, z| 0.1 * x + 0.05 * z);
        assert_eq!(m.indices.len(), 64);
        for i in 0..m.indices.len() {
            let [a, b, c] = m.triangle(i);
            assert!((b - a).cross(c - a).y > 0.0);
        }
    }

    /// A triangle's area is the one its sampled points report, bit for bit (a light's pdf divides by the
    /// one, its samples by the other), also where the cross product squares past f32 (edges of 1e30).
    #[test]
    fn a_triangles_area_is_its_sampled_points_area_even_beyond_f32() {
        for s in [1e-3f32, 1.0, 7.3, 1e30] {
            let positions = vec![Vec3::ZERO, Vec3::new(2.0 * s, 0.0, 0.0), Vec3::new(0.0, 3.0, 0.0)];
            let m = TriMesh { positions, indices: vec![[0, 1, 2]], ..Default::default() };
            let p = crate::scene::Geometry::Mesh(m.clone()).point(0, [0.3, 0.6]);
            assert_eq!(m.area(0).to_bits(), p.area.to_bits(), "edge {s}");
            assert!((m.area(0) / (3.0 * s) - 1.0).abs() < 1e-6, "edge {s}: area {}", m.area(0));
            assert!((p.n - Vec3::Z).length() < 1e-6, "edge {s}: normal {}", p.n);
        }
    }

    #[test]
    fn ascii_ply_with_quads_and_extra_properties() {
        let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty float confidence\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n4 0 1 2 3\n";
        let m = parse_ply(text.as_bytes(), true).unwrap();
        assert_eq!(m.positions.len(), 4);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert!((m.total_area() - 1.0).abs() < 1e-6);
    }

    /// Vertex colours: 8-bit (ASCII) and 16-bit (binary) integers read as sRGB-encoded values (scaled to
    /// [0, 1], then decoded to linear), floats kept, both naming conventions; `color_at` interpolates by
    /// the point's barycentric coordinates (the centroid reads the mean, a corner its own colour).
    #[test]
    fn ply_vertex_colours_are_read_and_interpolated() {
        let head = |fmt: &str, props: &str| {
            format!("ply\nformat {fmt} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n{props}element face 1\nproperty list uchar int vertex_indices\nend_header\n")
        };
        let rgb8 = "property uchar red\nproperty uchar green\nproperty uchar blue\n";
        let text = head("ascii", rgb8) + "0 0 0 255 0 51\n1 0 0 0 255 0\n0 1 0 0 0 204\n3 0 1 2\n";
        let m = parse_ply(text.as_bytes(), false).unwrap();
        let c = m.colors.as_ref().expect("colours");
        let (dec02, dec08) = (crate::color::srgb_decode(0.2), crate::color::srgb_decode(0.8));
        assert!((c[0] - Vec3::new(1.0, 0.0, dec02)).abs().max_element() < 1e-6, "{c:?}");
        let mid = m.color_at(0, Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.0));
        let mean = Vec3::new(1.0, 1.0, dec02 + dec08) / 3.0;
        assert!((mid - mean).abs().max_element() < 1e-5, "{mid:?}");
        assert!((m.color_at(0, Vec3::new(0.0, 1.0, 0.0)) - Vec3::new(0.0, 0.0, dec08)).abs().max_element() < 1e-5);
        let rgb16 = "property ushort r\nproperty ushort g\nproperty ushort b\n";
        let mut bin = head("binary_little_endian", rgb16).into_bytes();
        for (p, c) in
            [([0f32, 0.0, 0.0], [65535u16, 0, 0]), ([1.0, 0.0, 0.0], [0, 65535, 0]), ([0.0, 1.0, 0.0], [0, 0, 13107])]
        {
            p.iter().for_each(|x| bin.extend(x.to_le_bytes()));
            c.iter().for_each(|x| bin.extend(x.to_le_bytes()));
        }
        bin.push(3);
        [0i32, 1, 2].iter().for_each(|i| bin.extend(i.to_le_bytes()));
        let m = parse_ply(&bin, false).unwrap();
        assert!((m.colors.as_ref().unwrap()[2] - Vec3::new(0.0, 0.0, dec02)).abs().max_element() < 1e-6);
        let floats = "property float r\nproperty float g\nproperty float b\n";
        let text = head("ascii", floats) + "0 0 0 0.5 2 0\n1 0 0 0 0 0\n0 1 0 0 0 0\n3 0 1 2\n";
        assert_eq!(parse_ply(text.as_bytes(), false).unwrap().colors.unwrap()[0], Vec3::new(0.5, 2.0, 0.0));
        let none = head("ascii", "") + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert!(parse_ply(none.as_bytes(), false).unwrap().colors.is_none());
    }

    /// Integer colours as Mitsuba 3.9.1 reads them where it decodes them (its PLY loader marks integer
    /// properties `Normalized | Gamma`; 16-bit ones come out decoded, 8-bit ones it keeps as 0 to 255):
    /// its `vertex_color` and `face_color` buffers for a binary PLY of 16-bit colours, the vertices'
    /// being 8-bit values × 257, so that they are also what caustica reads for those 8-bit values.
    #[test]
    fn integer_colours_decode_as_mitsubas() {
        let props = |t: &str| format!("property {t} red\nproperty {t} green\nproperty {t} blue\n");
        let head = |t: &str| {
            format!(
                "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n{}element face 1\nproperty list uchar int vertex_indices\n{}end_header\n",
                props(t),
                props(t)
            )
        };
        let verts: [[u16; 3]; 3] = [[255, 0, 0], [0, 128, 255], [64, 192, 4]];
        let face = [13107u16, 1, 65534];
        let theirs_v = [[1.0, 0.0, 0.0], [0.0, 0.21586037, 1.0], [0.051269423, 0.5271154, 0.0012141078]];
        let theirs_f = [0.033104725, 1.1810389e-06, 0.99996525];
        for sixteen in [true, false] {
            let mut bin = head(if sixteen { "ushort" } else { "uchar" }).into_bytes();
            for (i, c) in verts.iter().enumerate() {
                [[-1f32, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0]][i]
                    .iter()
                    .for_each(|x| bin.extend(x.to_le_bytes()));
                for &x in c {
                    if sixteen {
                        bin.extend((x * 257).to_le_bytes());
                    } else {
                        bin.push(x as u8);
                    }
                }
            }
            bin.push(3);
            [0i32, 1, 2].iter().for_each(|i| bin.extend(i.to_le_bytes()));
            for x in face {
                if sixteen {
                    bin.extend(x.to_le_bytes());
                } else {
                    bin.push((x / 257) as u8);
                }
            }
            let m = parse_ply(&bin, false).unwrap();
            for (got, want) in m.colors.as_ref().unwrap().iter().zip(theirs_v) {
                assert!((*got - Vec3::from(want)).abs().max_element() < 1e-6, "{got} against Mitsuba's {want:?}");
            }
            let f = m.face_colors.as_ref().expect("face colours")[0];
            let eight = Vec3::from_array(face.map(|x| crate::color::srgb_decode((x / 257) as f32 / 255.0)));
            let want = if sixteen { Vec3::from(theirs_f) } else { eight };
            assert!((f - want).abs().max_element() < 1e-6, "{f} against {want}");
        }
    }

    /// Face colours (a PLY face element's `red`/`green`/`blue` or `r`/`g`/`b`) in ASCII, given before
    /// and after the index list, beside properties caustica does not read: a polygon's colour goes to
    /// each triangle of its fan; a face element without them leaves none.
    #[test]
    fn ply_face_colours_follow_their_polygons() {
        let text = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\nproperty float z\nelement face 2\nproperty float r\nproperty uchar flags\nproperty list uchar int vertex_indices\nproperty float g\nproperty float b\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 2 0\n0.5 7 4 0 1 2 3 0.25 0.125\n1 0 3 1 4 2 0 1\n";
        let m = parse_ply(text.as_bytes(), false).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3], [1, 4, 2]]);
        let f = m.face_colors.as_ref().expect("face colours");
        assert_eq!(f, &vec![Vec3::new(0.5, 0.25, 0.125), Vec3::new(0.5, 0.25, 0.125), Vec3::new(1.0, 0.0, 1.0)]);
        assert!(m.colors.is_none());
        let plain = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nproperty int material\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2 5\n";
        let m = parse_ply(plain.as_bytes(), false).unwrap();
        assert!(m.face_colors.is_none());
        assert_eq!(m.indices, vec![[0, 1, 2]]);
    }

    #[test]
    fn normals_are_read_only_for_smooth_shading() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n3 0 1 2\n";
        let smooth = parse_ply(text.as_bytes(), true).unwrap();
        assert_eq!(smooth.normals.as_deref(), Some(&[Vec3::Z; 3][..]));
        let flat = parse_ply(text.as_bytes(), false).unwrap();
        assert!(flat.normals.is_none());
        assert_eq!(flat.positions, smooth.positions);
    }

    #[test]
    fn a_binary_ply_header_counting_more_than_the_file_holds_is_an_error_not_an_abort() {
        // Seen aborting the process (a 128 GB allocation) before the count was checked.
        for (element, count) in [("vertex", 4_000_000_000u64), ("face", 4_000_000_000), ("junk", 1 << 40)] {
            let mut text = "ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n".to_string();
            match element {
                "vertex" => text = text.replace("element vertex 1", &format!("element vertex {count}")),
                "face" => text += &format!("element face {count}\nproperty list uchar int vertex_indices\n"),
                _ => text += &format!("element junk {count}\n"),
            }
            text += "end_header\n";
            let mut bytes = text.into_bytes();
            bytes.extend_from_slice(&[0u8; 12]);
            let err = parse_ply(&bytes, false).err().unwrap_or_else(|| panic!("{element}: accepted"));
            assert!(err.contains(&format!("`{element}`")) && err.contains(&count.to_string()), "{err}");
        }
    }

    #[test]
    fn a_mesh_without_faces_is_refused_by_name() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n";
        let m = parse_ply(text.as_bytes(), false).unwrap();
        let err = m.validate("points.ply").unwrap_err().to_string();
        assert!(err.contains("points.ply") && err.contains("no faces"), "{err}");
    }

    #[test]
    fn ascii_ply_truncated_is_an_error() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n";
        assert!(parse_ply(text.as_bytes(), true).is_err());
        // A face whose count is far beyond its line (and beyond memory): an error, not an abort.
        let huge = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty uchar flags\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n1 4000000000000000000 0 1 2\n";
        let e = parse_ply(huge.as_bytes(), true).unwrap_err();
        assert!(e.contains("face 0: no index"), "{e}");
    }

    /// tobj names no line; the error does (it said only "face vertex index out of bounds" before). Each
    /// file below is read by `load_obj` itself, so the message is the one a scene's user sees.
    #[test]
    fn an_obj_error_names_its_line() {
        let dir = std::env::temp_dir().join(format!("caustica-obj-lines-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        for (name, text, wants) in [
            (
                "far",
                format!("{tri}f 1 2 3\nf 1 2 99999999999\n"),
                "line 5: `f 1 2 99999999999` (the file has 3 vertices)",
            ),
            ("zero", format!("{tri}f 1 2 3\n# fine\nf 0 1 2\n"), "line 6: `f 0 1 2`"),
            (
                "relative",
                format!("{tri}f -3 -2 -1\nf -4 -2 -1\nv 1 1 0\n"),
                "line 5: `f -4 -2 -1` (the file has 4 vertices)",
            ),
            ("later", format!("{tri}f 1 2 4\nv 1 1 0\nf 2 4 5\n"), "line 6: `f 2 4 5`"),
            (
                "uv",
                format!("{tri}vt 0 0\nf 1/1 2/1 3/2\n"),
                "line 5: `f 1/1 2/1 3/2` (the file has 1 texture coordinates)",
            ),
            (
                "normal",
                format!("{tri}vn 0 0 1\nf 1//1 2//1 3//7\n"),
                "line 5: `f 1//1 2//1 3//7` (the file has 1 normals)",
            ),
            ("word", format!("{tri}f 1 2 x\n"), "face parse error: line 4: `f 1 2 x`"),
            ("slash", format!("{tri}f 1// 2// 3///\nf 1 2 3/1/1/1\n"), "face parse error: line 5: `f 1 2 3/1/1/1`"),
            ("position", "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n".to_string(), "line 2: `v 1 zero 0`"),
            ("texcoord", format!("{tri}vt 0.5\nf 1 2 3\n"), "line 4: `vt 0.5`"),
            ("w", format!("{tri}v 1 1 1 w\nf 1 2 3\n"), "line 4: `v 1 1 1 w`"),
            ("w0", format!("{tri}v 1 1 1 0\nf 1 2 3\n"), "line 4: `v 1 1 1 0`"),
            ("colour", format!("v 0 0 0 1 0 0\n{tri}v 1 1 1 0.5 0.5\nf 1 2 3\n"), "line 5: `v 1 1 1 0.5 0.5`"),
            ("usemtl", format!("{tri}usemtl\nf 1 2 3\n"), "line 4: `usemtl`"),
        ] {
            let path = dir.join(format!("{name}.obj"));
            std::fs::write(&path, text).unwrap();
            let e = load_obj(&path, true, false).err().unwrap_or_else(|| panic!("{name}: loaded"));
            assert!(e.starts_with("OBJ: ") && e.contains(wants), "{name}: {e}");
        }
        // A face that names a vertex the file has, after it: loaded, as tobj loads it.
        let path = dir.join("ahead.obj");
        std::fs::write(&path, "v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n").unwrap();
        assert_eq!(load_obj(&path, true, false).unwrap()[0].mesh.indices.len(), 1);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// An MTL line that tobj cannot read is the mesh's MTL error, naming the line, and not a panic:
    /// `Kd 1 0` (two numbers of three) panicked inside tobj (`parse_float3` unwraps), from a TOML scene
    /// and from a Mitsuba one alike (whose `obj` reads no MTL at all). The mesh itself still loads.
    #[test]
    fn a_broken_mtl_names_its_line_and_does_not_panic() {
        let dir = std::env::temp_dir().join(format!("caustica-mtl-lines-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = dir.join("tile.obj");
        std::fs::write(&obj, "mtllib tile.mtl\nusemtl x\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        for (mtl, wants) in [
            ("newmtl x\nKd 1 0\n", "line 2: `Kd 1 0`"),
            ("newmtl x\nKd 1 1 1\nKs 0.5\n", "line 3: `Ks 0.5`"),
            ("newmtl x\nKe\n", "line 2: `Ke`"),
            ("newmtl x\nKa 1 1 one\n", "line 2: `Ka 1 1 one`"),
            ("# a colour\nnewmtl x\nNs shiny\n", "line 3: `Ns shiny`"),
            ("newmtl x\nillum 2.5\n", "line 2: `illum 2.5`"),
            ("newmtl x\nmap_Kd\n", "line 2: `map_Kd`"),
        ] {
            std::fs::write(dir.join("tile.mtl"), mtl).unwrap();
            let loaded = load_obj(&obj, true, false).unwrap_or_else(|e| panic!("{mtl:?}: {e}"));
            let why = loaded[0].mtl_error.clone().unwrap_or_else(|| panic!("{mtl:?}: read"));
            assert!(why.contains("tile.mtl") && why.contains(wants), "{mtl:?}: {why}");
            assert_eq!(loaded[0].mesh.indices.len(), 1);
        }
        std::fs::write(dir.join("tile.mtl"), "newmtl x\nKd 0.25 0.5 1\n").unwrap();
        let loaded = load_obj(&obj, true, false).unwrap();
        assert_eq!((loaded[0].mtl_diffuse, loaded[0].mtl_error.clone()), (Some([0.25, 0.5, 1.0]), None));
        std::fs::remove_dir_all(&dir).ok();
    }
}
