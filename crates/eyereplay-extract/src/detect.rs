//! BlazeFace short-range post-processing: SSD anchors, box decoding and
//! MediaPipe's weighted non-maximum suppression.

use crate::geom::Roi;
use crate::shapes::{DETECTOR_ANCHORS, DETECTOR_ANCHOR_VALUES};

pub const INPUT: usize = 128;
const SCORE_THRESHOLD: f32 = 0.5;
const NMS_IOU: f32 = 0.3;

/// A face found by the detector, in normalized letterbox coordinates
/// (0..1 across the square detector input).
#[derive(Clone, Debug, PartialEq)]
pub struct Detection {
    pub score: f32,
    pub cx: f32,
    pub cy: f32,
    pub w: f32,
    pub h: f32,
    /// Six keypoints; 0 and 1 are the eyes (image-left, image-right).
    pub kp: [[f32; 2]; 6],
}

/// The [`DETECTOR_ANCHORS`] (896) anchor centres: stride 8 -> 16x16 cells x 2 anchors, stride 16 ->
/// 8x8 cells x 6 anchors (MediaPipe's SsdAnchorsCalculator options for the
/// short-range model: 4 layers, strides 8/16/16/16, same-stride layers merged).
pub fn anchors() -> Vec<[f32; 2]> {
    let mut a = Vec::with_capacity(DETECTOR_ANCHORS);
    for (cells, per_cell) in [(16usize, 2usize), (8, 6)] {
        for y in 0..cells {
            for x in 0..cells {
                for _ in 0..per_cell {
                    a.push([
                        (x as f32 + 0.5) / cells as f32,
                        (y as f32 + 0.5) / cells as f32,
                    ]);
                }
            }
        }
    }
    a
}

fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + (-x.clamp(-100.0, 100.0)).exp())
}

/// Decodes raw outputs ([`DETECTOR_ANCHORS`] x [`DETECTOR_ANCHOR_VALUES`]
/// regressors, [`DETECTOR_ANCHORS`] logits) into detections
/// above the score threshold, merged by weighted NMS, best first.
pub fn decode(reg: &[f32], logits: &[f32], anchors: &[[f32; 2]]) -> Vec<Detection> {
    let s = INPUT as f32;
    let mut cands: Vec<Detection> = logits
        .iter()
        .enumerate()
        .filter_map(|(i, &l)| {
            let score = sigmoid(l);
            if score < SCORE_THRESHOLD {
                return None;
            }
            let r = &reg[i * DETECTOR_ANCHOR_VALUES..(i + 1) * DETECTOR_ANCHOR_VALUES];
            let a = anchors[i];
            let mut kp = [[0.0; 2]; 6];
            for (k, p) in kp.iter_mut().enumerate() {
                *p = [r[4 + 2 * k] / s + a[0], r[5 + 2 * k] / s + a[1]];
            }
            Some(Detection {
                score,
                cx: r[0] / s + a[0],
                cy: r[1] / s + a[1],
                w: r[2] / s,
                h: r[3] / s,
                kp,
            })
        })
        .collect();
    cands.sort_by(|a, b| b.score.total_cmp(&a.score));
    weighted_nms(cands)
}

fn iou(a: &Detection, b: &Detection) -> f32 {
    let (ax0, ay0, ax1, ay1) = (
        a.cx - a.w / 2.0,
        a.cy - a.h / 2.0,
        a.cx + a.w / 2.0,
        a.cy + a.h / 2.0,
    );
    let (bx0, by0, bx1, by1) = (
        b.cx - b.w / 2.0,
        b.cy - b.h / 2.0,
        b.cx + b.w / 2.0,
        b.cy + b.h / 2.0,
    );
    let iw = (ax1.min(bx1) - ax0.max(bx0)).max(0.0);
    let ih = (ay1.min(by1) - ay0.max(by0)).max(0.0);
    let inter = iw * ih;
    let union = a.w * a.h + b.w * b.h - inter;
    if union <= 0.0 {
        0.0
    } else {
        inter / union
    }
}

/// MediaPipe's WEIGHTED suppression: every group of boxes overlapping the
/// best remaining one (IoU >= 0.3) becomes their score-weighted average,
/// keeping the best score. `sorted` must be best first.
pub fn weighted_nms(sorted: Vec<Detection>) -> Vec<Detection> {
    let mut remaining = sorted;
    let mut out = vec![];
    while !remaining.is_empty() {
        let top = remaining[0].clone();
        let (group, rest): (Vec<Detection>, Vec<Detection>) =
            remaining.into_iter().partition(|d| iou(&top, d) >= NMS_IOU);
        remaining = rest;
        let total: f32 = group.iter().map(|d| d.score).sum();
        let mut m = Detection {
            score: top.score,
            cx: 0.0,
            cy: 0.0,
            w: 0.0,
            h: 0.0,
            kp: [[0.0; 2]; 6],
        };
        for d in &group {
            let wgt = d.score / total;
            m.cx += d.cx * wgt;
            m.cy += d.cy * wgt;
            m.w += d.w * wgt;
            m.h += d.h * wgt;
            for k in 0..6 {
                m.kp[k][0] += d.kp[k][0] * wgt;
                m.kp[k][1] += d.kp[k][1] * wgt;
            }
        }
        out.push(m);
    }
    out
}

/// The face ROI for the landmark model from a detection, given the
/// letterbox square the detector saw (`letterbox` as an image-pixel ROI):
/// rotation from eye keypoint 0 to 1, side 1.5 x the longer box side.
pub fn face_roi(d: &Detection, letterbox: &Roi) -> Roi {
    let c = letterbox.to_image(d.cx, d.cy);
    let e0 = letterbox.to_image(d.kp[0][0], d.kp[0][1]);
    let e1 = letterbox.to_image(d.kp[1][0], d.kp[1][1]);
    let side = (d.w * letterbox.w).max(d.h * letterbox.h) * 1.5;
    Roi {
        cx: c.x,
        cy: c.y,
        w: side,
        h: side,
        angle_rad: (e1.y - e0.y).atan2(e1.x - e0.x),
    }
}

/// Area of a detection in image pixels squared (to pick the largest face).
pub fn area_px(d: &Detection, letterbox: &Roi) -> f32 {
    d.w * letterbox.w * d.h * letterbox.h
}

/// The detector's letterbox for a `w` x `h` image: the centred square with
/// side max(w, h); the parts outside the image are black.
pub fn letterbox(w: usize, h: usize) -> Roi {
    let side = w.max(h) as f32;
    Roi {
        cx: w as f32 / 2.0,
        cy: h as f32 / 2.0,
        w: side,
        h: side,
        angle_rad: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn anchor_layout_matches_the_ssd_options() {
        let a = anchors();
        assert_eq!(a.len(), 896);
        assert_eq!(a[0], [0.5 / 16.0, 0.5 / 16.0]);
        assert_eq!(a[1], a[0]); // two anchors per 16x16 cell
        assert_eq!(a[2], [1.5 / 16.0, 0.5 / 16.0]);
        assert_eq!(a[512], [0.5 / 8.0, 0.5 / 8.0]); // first of the 8x8 grid
        assert_eq!(a[895], [7.5 / 8.0, 7.5 / 8.0]);
    }

    #[test]
    fn decode_offsets_by_anchor_and_weighted_nms_averages() {
        let a = anchors();
        let mut reg = vec![0.0f32; 896 * 16];
        let mut logits = vec![-10.0f32; 896];
        // Two overlapping boxes on anchors 0 and 1 (same centre), scores
        // sigmoid(2)=0.881 and sigmoid(0)=0.5; one far away on anchor 895.
        for (i, dx, l) in [(0usize, 0.0f32, 2.0f32), (1, 12.8, 0.0)] {
            reg[i * 16] = dx; // +0.1 in normalized units for the second
            reg[i * 16 + 2] = 25.6; // w = 0.2
            reg[i * 16 + 3] = 25.6;
            logits[i] = l;
        }
        reg[895 * 16 + 2] = 12.8;
        reg[895 * 16 + 3] = 12.8;
        logits[895] = 1.0;
        let d = decode(&reg, &logits, &a);
        assert_eq!(d.len(), 2);
        let (s1, s2) = (sigmoid(2.0), sigmoid(0.0));
        // IoU of two 0.2 boxes shifted by 0.1 is 1/3 >= 0.3: merged.
        let want_cx = a[0][0] + 0.1 * s2 / (s1 + s2);
        assert!((d[0].cx - want_cx).abs() < 1e-6, "{} vs {want_cx}", d[0].cx);
        assert_eq!(d[0].score, s1);
        assert!((d[1].cx - 7.5 / 8.0).abs() < 1e-6 && (d[1].w - 0.1).abs() < 1e-6);
    }

    #[test]
    fn face_roi_is_rotated_along_the_eyes_and_enlarged() {
        let lb = letterbox(200, 100);
        let d = Detection {
            score: 0.9,
            cx: 0.5,
            cy: 0.5,
            w: 0.2,
            h: 0.1,
            kp: [
                [0.4, 0.4],
                [0.6, 0.6],
                [0.0; 2],
                [0.0; 2],
                [0.0; 2],
                [0.0; 2],
            ],
        };
        let r = face_roi(&d, &lb);
        assert!((r.cx - 100.0).abs() < 1e-4 && (r.cy - 50.0).abs() < 1e-4);
        assert!((r.w - 60.0).abs() < 1e-4); // 0.2 * 200 * 1.5
        assert!((r.angle_rad - std::f32::consts::FRAC_PI_4).abs() < 1e-6);
    }
}
