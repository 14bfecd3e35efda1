//! The canonical mesh read from the real binarypb against the facts
//! measured independently with MediaPipe's own Python protobuf classes
//! (shared/research/face.md section 1).

mod common;

use eyereplay_face::{lm, INNER_LIPS, LEFT_EYE_CONTOUR, RIGHT_EYE_CONTOUR};

fn dist(a: [f32; 3], b: [f32; 3]) -> f32 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Shoelace area of a polygon in UV.
fn polygon_area(pts: &[[f32; 2]]) -> f32 {
    let n = pts.len();
    (0..n)
        .map(|i| {
            let (a, b) = (pts[i], pts[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum::<f32>()
        .abs()
        / 2.0
}

fn tri_area(a: [f32; 2], b: [f32; 2], c: [f32; 2]) -> f32 {
    ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs() / 2.0
}

#[test]
fn counts_units_and_ranges() {
    let Some(m) = common::mesh() else { return };
    assert_eq!(m.positions_cm.len(), 468);
    assert_eq!(m.triangles.len(), 898);
    assert_eq!(m.input_source, 1, "FACE_LANDMARK_PIPELINE");
    let mut used = [false; 468];
    m.triangles
        .iter()
        .flatten()
        .for_each(|&v| used[v as usize] = true);
    assert!(used.iter().all(|&u| u), "every vertex is used");

    let p = &m.positions_cm;
    let max = |k: usize| p.iter().map(|v| v[k]).fold(f32::MIN, f32::max);
    let min = |k: usize| p.iter().map(|v| v[k]).fold(f32::MAX, f32::min);
    assert!((max(0) - 7.74).abs() < 0.01 && (min(0) + 7.74).abs() < 0.01);
    assert!((p[lm::CHIN][1] + 9.40).abs() < 0.01 && (min(1) - p[lm::CHIN][1]).abs() < 1e-6);
    assert!((p[lm::FOREHEAD][1] - 8.26).abs() < 0.01 && (max(1) - p[lm::FOREHEAD][1]).abs() < 1e-6);
    assert!((p[lm::NOSE_TIP][2] - 7.59).abs() < 0.01 && (max(2) - p[lm::NOSE_TIP][2]).abs() < 1e-6);
    assert!(
        (p[lm::R_OUTER][0] + 4.45).abs() < 0.01,
        "33 is the subject's right"
    );

    let uv = &m.uvs;
    let umin = uv.iter().map(|t| t[0]).fold(f32::MAX, f32::min);
    let umax = uv.iter().map(|t| t[0]).fold(f32::MIN, f32::max);
    let vmin = uv.iter().map(|t| t[1]).fold(f32::MAX, f32::min);
    let vmax = uv.iter().map(|t| t[1]).fold(f32::MIN, f32::max);
    assert!((umin - 0.008).abs() < 0.001 && (umax - 0.992).abs() < 0.001);
    assert!((vmin - 0.107).abs() < 0.001 && (vmax - 0.954).abs() < 0.001);
    // v grows downward: the forehead is above the chin in UV.
    assert!(uv[lm::FOREHEAD][1] < uv[lm::CHIN][1]);
}

#[test]
fn distances_in_cm() {
    let Some(m) = common::mesh() else { return };
    let p = &m.positions_cm;
    let d = |a: usize, b: usize| dist(p[a], p[b]);
    assert!((d(33, 263) - 8.89).abs() < 0.005);
    assert!((d(133, 362) - 3.71).abs() < 0.005);
    assert!((d(33, 133) - 2.66).abs() < 0.005);
    assert!((d(159, 145) - 0.68).abs() < 0.005);
}

#[test]
fn mirror_symmetric() {
    let Some(m) = common::mesh() else { return };
    // Every vertex has a mirror twin (x -> -x) within 0.01 cm.
    for v in &m.positions_cm {
        let twin = m
            .positions_cm
            .iter()
            .map(|w| dist([-v[0], v[1], v[2]], *w))
            .fold(f32::MAX, f32::min);
        assert!(twin < 0.01, "{v:?} has no mirror twin ({twin} cm)");
    }
}

#[test]
fn one_boundary_loop_of_36_vertices() {
    let Some(m) = common::mesh() else { return };
    let loops = m.boundary_loops();
    assert_eq!(loops.len(), 1, "eyes and mouth are filled, not holes");
    assert_eq!(loops[0].len(), 36);
    assert!(loops[0].contains(&(lm::CHIN as u32)) && loops[0].contains(&(lm::FOREHEAD as u32)));
}

#[test]
fn eye_and_lip_fill_triangles() {
    let Some(m) = common::mesh() else { return };
    for contour in [&RIGHT_EYE_CONTOUR[..], &LEFT_EYE_CONTOUR[..]] {
        let fill = m.fill_triangles(&[contour]);
        assert_eq!(fill.len(), 14, "n - 2 triangles fill a 16-gon");
        // They tile the polygon exactly: no triangle outside it.
        let poly: Vec<[f32; 2]> = contour.iter().map(|&v| m.uvs[v as usize]).collect();
        let sum: f32 = fill
            .iter()
            .map(|&t| {
                let [a, b, c] = m.triangles[t].map(|v| m.uvs[v as usize]);
                tri_area(a, b, c)
            })
            .sum();
        assert!(
            (sum - polygon_area(&poly)).abs() < 1e-6 * 100.0,
            "{sum} vs polygon"
        );
    }
    assert_eq!(m.eye_fill_triangles().len(), 28);
    assert_eq!(m.fill_triangles(&[&INNER_LIPS]).len(), 18);
    // Eye UV ranges of face.md.
    let u: Vec<f32> = RIGHT_EYE_CONTOUR
        .iter()
        .map(|&v| m.uvs[v as usize][0])
        .collect();
    assert!((u.iter().cloned().fold(f32::MAX, f32::min) - 0.280).abs() < 0.001);
    assert!((u.iter().cloned().fold(f32::MIN, f32::max) - 0.419).abs() < 0.001);
}

#[test]
fn procrustes_basis_weights() {
    let Some(m) = common::mesh() else { return };
    assert_eq!(m.procrustes.len(), 33);
    let w = |id: u32| {
        m.procrustes
            .iter()
            .find(|p| p.0 == id)
            .map(|p| p.1)
            .unwrap()
    };
    for (id, want) in [
        (4, 0.0709),
        (6, 0.0321),
        (10, 0.0084),
        (33, 0.0587),
        (263, 0.0587),
    ] {
        assert!((w(id) - want).abs() < 5e-5, "weight of {id}: {}", w(id));
    }
    for (a, b, want) in [(129, 358, 0.1206), (136, 365, 0.0669), (205, 425, 0.0473)] {
        assert!((w(a) - want).abs() < 5e-5 && (w(b) - want).abs() < 5e-5);
    }
}

#[test]
fn bad_file_is_a_one_line_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("broken.binarypb");
    std::fs::write(&p, [0x0a, 0x40, 1, 2, 3]).unwrap();
    let e = eyereplay_face::CanonicalMesh::load(&p)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("broken.binarypb") && e.contains("not a face mesh"),
        "{e}"
    );
    assert!(!e.contains('\n'));
    let e = eyereplay_face::CanonicalMesh::load(&dir.path().join("absent")).unwrap_err();
    assert!(e.to_string().contains("absent: cannot read"), "{e}");
}
