//! MediaPipe's canonical face mesh, read from its `binarypb`.
//!
//! The file is a serialized `mediapipe.face_geometry.GeometryPipelineMetadata`
//! (schema: `mediapipe/modules/face_geometry/protos/
//! geometry_pipeline_metadata.proto` and `mesh_3d.proto`):
//!
//! ```text
//! GeometryPipelineMetadata { 1: Mesh3d canonical_mesh,
//!                            2: repeated WeightedLandmarkRef procrustes_landmark_basis,
//!                            3: InputSource input_source }
//! Mesh3d { 1: VertexType, 2: PrimitiveType,
//!          3: repeated float vertex_buffer  (x y z u v per vertex, cm),
//!          4: repeated uint32 index_buffer  (3 per triangle) }
//! WeightedLandmarkRef { 1: uint32 landmark_id, 2: float weight }
//! ```
//!
//! Eight fields do not justify a protobuf code generator: [`parse`] is a
//! minimal wire-format reader that accepts repeated scalars both packed and
//! unpacked (proto2 writes them unpacked) and skips unknown fields.

use crate::error::{FaceError, Result};
use std::path::{Path, PathBuf};

/// Number of landmarks of MediaPipe's face mesh (without the iris points).
pub const MESH_VERTICES: usize = 468;

/// The subject's right eye's contour (image-left in a frontal view), in
/// order around the eye: outer corner 33, lower lid, inner corner 133,
/// upper lid. Same as `FACEMESH_RIGHT_EYE` in MediaPipe's
/// `face_mesh_connections.py`.
pub const RIGHT_EYE_CONTOUR: [u32; 16] = [
    33, 7, 163, 144, 145, 153, 154, 155, 133, 173, 157, 158, 159, 160, 161, 246,
];
/// The subject's left eye's contour: outer corner 263, lower lid, inner
/// corner 362, upper lid.
pub const LEFT_EYE_CONTOUR: [u32; 16] = [
    263, 249, 390, 373, 374, 380, 381, 382, 362, 398, 384, 385, 386, 387, 388, 466,
];
/// The inner lip line (the mouth is closed in the canonical mesh).
pub const INNER_LIPS: [u32; 20] = [
    78, 95, 88, 178, 87, 14, 317, 402, 318, 324, 308, 415, 310, 311, 312, 13, 82, 81, 80, 191,
];

/// Named landmarks used across the crate.
pub mod lm {
    /// Subject's right eye: outer and inner corner, upper and lower lid middle.
    pub const R_OUTER: usize = 33;
    pub const R_INNER: usize = 133;
    pub const R_UPPER: usize = 159;
    pub const R_LOWER: usize = 145;
    /// Subject's left eye.
    pub const L_OUTER: usize = 263;
    pub const L_INNER: usize = 362;
    pub const L_UPPER: usize = 386;
    pub const L_LOWER: usize = 374;
    pub const NOSE_TIP: usize = 4;
    pub const FOREHEAD: usize = 10;
    pub const CHIN: usize = 152;
}

/// MediaPipe's canonical face: 468 vertices in centimetres (+x the
/// subject's left, i.e. image right in a frontal view; +y up; +z toward the
/// camera), texture coordinates (v grows downward like image rows) and the
/// triangle list.
#[derive(Clone, Debug)]
pub struct CanonicalMesh {
    pub positions_cm: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
    /// Landmark id and weight of MediaPipe's Procrustes basis.
    pub procrustes: Vec<(u32, f32)>,
    /// `input_source` (1 = FACE_LANDMARK_PIPELINE).
    pub input_source: u32,
}

/// An installed package's own copy of the mesh and the bundled photos
/// (the Python wheel's `faces/`), set once at import.
static PACKAGE_FACES: std::sync::RwLock<Option<PathBuf>> = std::sync::RwLock::new(None);

/// Makes `dir`, an installed package's copy of the mesh and the bundled
/// photos, where they are found when `$EYEREPLAY_CACHE` does not hold
/// them: the Python package calls it at import, so the full-face mode
/// works from the wheel alone.
pub fn use_package_faces(dir: PathBuf) {
    *PACKAGE_FACES.write().unwrap_or_else(|p| p.into_inner()) = Some(dir);
}

/// Where the mesh and the bundled photos are: `$EYEREPLAY_CACHE/faces`
/// when it holds the mesh (where the setup script puts them with that
/// variable set); else an installed package's own ([`use_package_faces`]);
/// else `$EYEREPLAY_CACHE/faces` when that is set (an error then names the
/// folder the user gave); else the nearest `.cache/faces` above the
/// current directory or the executable.
pub fn default_faces_dir() -> PathBuf {
    let cache = std::env::var_os("EYEREPLAY_CACHE").map(|d| PathBuf::from(d).join("faces"));
    if let Some(d) = cache.as_ref().filter(|d| d.join(MESH_FILE).is_file()) {
        return d.clone();
    }
    if let Some(d) = PACKAGE_FACES
        .read()
        .unwrap_or_else(|p| p.into_inner())
        .clone()
    {
        return d;
    }
    if let Some(d) = cache {
        return d;
    }
    if let Some(marker) = eyereplay_core::find_upwards(&Path::new(".cache/faces").join(MESH_FILE)) {
        return marker.parent().expect("a file has a folder").to_path_buf();
    }
    PathBuf::from(".cache/faces")
}

/// The face photos `scripts/face-assets.sh` bundles (sources and licenses
/// in NOTICE): the identities of the full-face mode when a config names
/// none.
pub const BUNDLED_FACES: [&str; 6] = [
    "astronaut.png",
    "grace_hopper.jpg",
    "psychopy_face01.jpg",
    "psychopy_face.jpg",
    "giunchedi.jpg",
    "kphotoalbum_jesper.jpg",
];

/// The bundled photos' paths in [`default_faces_dir`].
pub fn bundled_faces() -> Vec<PathBuf> {
    let dir = default_faces_dir();
    BUNDLED_FACES.iter().map(|n| dir.join(n)).collect()
}

/// File name of the mesh in the faces folder.
pub const MESH_FILE: &str = "canonical_face_mesh.binarypb";

impl CanonicalMesh {
    /// The head pose that puts a face of shape `shape_cm` (one point per
    /// landmark, head frame: an identity's own shape, or this mesh's for an
    /// unknown person) onto `landmarks_px` (the extractor's 468, pixels)
    /// seen by `camera`, fitted on this mesh's weighted Procrustes basis
    /// ([`crate::solve_pose`]).
    pub fn head_pose(
        &self,
        camera: &crate::Camera,
        shape_cm: &[[f32; 3]],
        landmarks_px: &[[f64; 2]],
    ) -> crate::HeadPose {
        let model: Vec<nalgebra::Vector3<f64>> = self
            .procrustes
            .iter()
            .map(|&(i, _)| nalgebra::Vector3::from(shape_cm[i as usize].map(f64::from)))
            .collect();
        let obs: Vec<[f64; 2]> = self
            .procrustes
            .iter()
            .map(|&(i, _)| landmarks_px[i as usize])
            .collect();
        let w: Vec<f64> = self.procrustes.iter().map(|&(_, w)| w as f64).collect();
        crate::solve_pose(camera, &model, &obs, &w, 20)
    }

    /// Reads and checks the mesh file.
    pub fn load(path: &Path) -> Result<CanonicalMesh> {
        let bytes = std::fs::read(path).map_err(|source| FaceError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        parse(&bytes).map_err(|e| FaceError::Mesh {
            path: path.to_path_buf(),
            message: e.to_string(),
        })
    }

    /// The mesh at [`default_faces_dir`].
    pub fn load_default() -> Result<CanonicalMesh> {
        CanonicalMesh::load(&default_faces_dir().join(MESH_FILE))
    }

    /// Indices into `triangles` of the triangles that fill the two eye
    /// openings: those whose three vertices all lie on one eye's contour.
    /// Dropping them opens the lids so that an eyeball drawn behind shows.
    pub fn eye_fill_triangles(&self) -> Vec<usize> {
        self.fill_triangles(&[&RIGHT_EYE_CONTOUR, &LEFT_EYE_CONTOUR])
    }

    /// Triangles whose three vertices all lie on one of `loops`.
    pub fn fill_triangles(&self, loops: &[&[u32]]) -> Vec<usize> {
        self.triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| loops.iter().any(|l| t.iter().all(|v| l.contains(v))))
            .map(|(i, _)| i)
            .collect()
    }

    /// Boundary edges (used by one triangle only), as (a, b) pairs.
    pub fn boundary_edges(&self) -> Vec<(u32, u32)> {
        let mut count = std::collections::BTreeMap::<(u32, u32), u32>::new();
        for t in &self.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        count
            .into_iter()
            .filter(|&(_, c)| c == 1)
            .map(|(e, _)| e)
            .collect()
    }

    /// The face oval: the boundary edges chained into loops of vertex ids.
    pub fn boundary_loops(&self) -> Vec<Vec<u32>> {
        let edges = self.boundary_edges();
        let mut next = std::collections::BTreeMap::<u32, Vec<u32>>::new();
        for &(a, b) in &edges {
            next.entry(a).or_default().push(b);
            next.entry(b).or_default().push(a);
        }
        let mut seen = std::collections::BTreeSet::new();
        let mut loops = vec![];
        for &start in next.keys() {
            if seen.contains(&start) {
                continue;
            }
            let mut lp = vec![start];
            seen.insert(start);
            let mut cur = start;
            while let Some(&n) = next[&cur].iter().find(|n| !seen.contains(n)) {
                seen.insert(n);
                lp.push(n);
                cur = n;
            }
            loops.push(lp);
        }
        loops
    }
}

/// Parses a serialized `GeometryPipelineMetadata`; the error
/// ([`FaceError::MeshFormat`]) says what is wrong (the caller adds the
/// path).
pub fn parse(bytes: &[u8]) -> Result<CanonicalMesh> {
    let mut mesh_bytes: Option<&[u8]> = None;
    let mut procrustes = vec![];
    let mut input_source = 0u32;
    let mut r = Reader::new(bytes);
    while !r.done() {
        let (field, wire) = r.key()?;
        match (field, wire) {
            (1, WIRE_LEN) => mesh_bytes = Some(r.len_delimited()?),
            (2, WIRE_LEN) => {
                let mut w = Reader::new(r.len_delimited()?);
                let (mut id, mut weight) = (None, None);
                while !w.done() {
                    match w.key()? {
                        (1, WIRE_VARINT) => id = Some(w.varint()? as u32),
                        (2, WIRE_I32) => weight = Some(w.f32()?),
                        (_, wt) => w.skip(wt)?,
                    }
                }
                match (id, weight) {
                    (Some(i), Some(wt)) => procrustes.push((i, wt)),
                    _ => {
                        return Err(FaceError::MeshFormat(
                            "a Procrustes landmark lacks its id or weight".into(),
                        ))
                    }
                }
            }
            (3, WIRE_VARINT) => input_source = r.varint()? as u32,
            (_, wt) => r.skip(wt)?,
        }
    }
    let mesh_bytes =
        mesh_bytes.ok_or_else(|| FaceError::MeshFormat("no canonical_mesh (field 1)".into()))?;
    let mut floats = vec![];
    let mut indices = vec![];
    let mut r = Reader::new(mesh_bytes);
    while !r.done() {
        match r.key()? {
            (1 | 2, WIRE_VARINT) => {
                // VERTEX_PT and TRIANGLE are the only values the schema has.
                if r.varint()? != 0 {
                    return Err(FaceError::MeshFormat(
                        "vertex or primitive type other than VERTEX_PT/TRIANGLE".into(),
                    ));
                }
            }
            (3, WIRE_I32) => floats.push(r.f32()?),
            (3, WIRE_LEN) => {
                let mut p = Reader::new(r.len_delimited()?);
                while !p.done() {
                    floats.push(p.f32()?);
                }
            }
            (4, WIRE_VARINT) => indices.push(r.varint()? as u32),
            (4, WIRE_LEN) => {
                let mut p = Reader::new(r.len_delimited()?);
                while !p.done() {
                    indices.push(p.varint()? as u32);
                }
            }
            (_, wt) => r.skip(wt)?,
        }
    }
    if floats.len() != MESH_VERTICES * 5 {
        return Err(FaceError::MeshFormat(format!(
            "{} vertex floats, expected {} (468 vertices x 5)",
            floats.len(),
            MESH_VERTICES * 5
        )));
    }
    if indices.is_empty() || indices.len() % 3 != 0 {
        return Err(FaceError::MeshFormat(format!(
            "{} triangle indices, expected a positive multiple of 3",
            indices.len()
        )));
    }
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= MESH_VERTICES) {
        return Err(FaceError::MeshFormat(format!(
            "triangle index {bad} out of range"
        )));
    }
    let positions_cm = floats.chunks_exact(5).map(|v| [v[0], v[1], v[2]]).collect();
    let uvs = floats.chunks_exact(5).map(|v| [v[3], v[4]]).collect();
    let triangles = indices
        .chunks_exact(3)
        .map(|t| [t[0], t[1], t[2]])
        .collect();
    Ok(CanonicalMesh {
        positions_cm,
        uvs,
        triangles,
        procrustes,
        input_source,
    })
}

const WIRE_VARINT: u8 = 0;
const WIRE_I64: u8 = 1;
const WIRE_LEN: u8 = 2;
const WIRE_I32: u8 = 5;

/// Protobuf wire-format cursor.
struct Reader<'a> {
    b: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    fn new(b: &'a [u8]) -> Self {
        Reader { b, pos: 0 }
    }
    fn done(&self) -> bool {
        self.pos >= self.b.len()
    }
    fn varint(&mut self) -> Result<u64> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let byte = *self.b.get(self.pos).ok_or_else(|| {
                FaceError::MeshFormat(format!("truncated varint at byte {}", self.pos))
            })?;
            self.pos += 1;
            v |= ((byte & 0x7f) as u64) << shift;
            if byte & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(FaceError::MeshFormat(format!(
            "varint longer than 10 bytes at byte {}",
            self.pos
        )))
    }
    fn key(&mut self) -> Result<(u64, u8)> {
        let k = self.varint()?;
        Ok((k >> 3, (k & 7) as u8))
    }
    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|&e| e <= self.b.len())
            .ok_or_else(|| {
                FaceError::MeshFormat(format!(
                    "field of {n} bytes runs past the end at byte {}",
                    self.pos
                ))
            })?;
        let s = &self.b[self.pos..end];
        self.pos = end;
        Ok(s)
    }
    fn len_delimited(&mut self) -> Result<&'a [u8]> {
        let n = self.varint()? as usize;
        self.take(n)
    }
    fn f32(&mut self) -> Result<f32> {
        let s = self.take(4)?;
        Ok(f32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }
    fn skip(&mut self, wire: u8) -> Result<()> {
        match wire {
            WIRE_VARINT => self.varint().map(|_| ()),
            WIRE_I64 => self.take(8).map(|_| ()),
            WIRE_LEN => self.len_delimited().map(|_| ()),
            WIRE_I32 => self.take(4).map(|_| ()),
            w => Err(FaceError::MeshFormat(format!(
                "unsupported wire type {w} at byte {}",
                self.pos
            ))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand-encoded message: one packed and one unpacked repeated field,
    /// an unknown field to skip, a Procrustes entry.
    #[test]
    fn reads_packed_and_unpacked_fields() {
        let mut mesh = vec![];
        // vertex_buffer, packed: 468*5 floats = 9360 bytes, varint length.
        let n = MESH_VERTICES * 5 * 4;
        mesh.push((3 << 3) | 2);
        mesh.extend([(n & 0x7f) as u8 | 0x80, (n >> 7) as u8]);
        for i in 0..MESH_VERTICES * 5 {
            mesh.extend((i as f32 * 0.5).to_le_bytes());
        }
        // index_buffer, unpacked: 0 1 300 (300 = 0xac 0x02).
        for idx in [[0u8].as_slice(), &[1], &[0xac, 0x02]] {
            mesh.push(4 << 3);
            mesh.extend(idx);
        }
        let mut msg = vec![(1 << 3) | 2];
        msg.extend([(mesh.len() & 0x7f) as u8 | 0x80, (mesh.len() >> 7) as u8]);
        msg.extend(&mesh);
        // Unknown field 9 (fixed64), then procrustes {id 33, weight 0.25}.
        msg.push((9 << 3) | 1);
        msg.extend([0u8; 8]);
        msg.extend([(2 << 3) | 2, 7, 1 << 3, 33, (2 << 3) | 5]);
        msg.extend(0.25f32.to_le_bytes());
        msg.extend([3 << 3, 1]);
        let m = parse(&msg).unwrap();
        assert_eq!(m.positions_cm[1], [2.5, 3.0, 3.5]);
        assert_eq!(m.uvs[1], [4.0, 4.5]);
        assert_eq!(m.triangles, vec![[0, 1, 300]]);
        assert_eq!(m.procrustes, vec![(33, 0.25)]);
        assert_eq!(m.input_source, 1);
    }

    #[test]
    fn rejects_truncation_and_bad_indices() {
        assert!(parse(&[(1 << 3) | 2, 50, 1, 2])
            .unwrap_err()
            .to_string()
            .contains("past the end"));
        assert!(parse(&[])
            .unwrap_err()
            .to_string()
            .contains("no canonical_mesh"));
        let msg = [(1 << 3) | 2, 2, 4 << 3, 1];
        assert!(parse(&msg)
            .unwrap_err()
            .to_string()
            .contains("0 vertex floats"));
    }
}
