//! Stages 4 and 5: per-source normalization and circular slicing.

use eyereplay_core::CanvasPos;

/// Shifts each source's mean onto `global` (paper eq. 5):
/// `x_i <- x_i + (mu_global - mu_v)`. Returns the shift applied.
pub fn normalize_to(points: &mut [CanvasPos], global: CanvasPos) -> [f64; 2] {
    let Some(m) = eyereplay_core::mean_of(points.iter().copied()) else {
        return [0.0, 0.0];
    };
    let d = [global.x_px - m.x_px, global.y_px - m.y_px];
    for p in points.iter_mut() {
        p.x_px += d[0];
        p.y_px += d[1];
    }
    d
}

/// `floor(T / N)`.
pub fn stride(pool_len: usize, sessions: usize) -> usize {
    pool_len / sessions
}

/// Index of frame `j` of session `i` (paper eq. 4):
/// `idx_j = (i floor(T/N) + j) mod T`.
#[inline]
pub fn slice_index(i: usize, j: usize, pool_len: usize, sessions: usize) -> usize {
    (i * stride(pool_len, sessions) + j) % pool_len
}

/// Cuts session `i` of `frames` frames out of the pool, wrapping around.
pub fn slice_session<T: Copy>(pool: &[T], i: usize, sessions: usize, frames: usize) -> Vec<T> {
    let t = pool.len();
    let start = i * stride(t, sessions);
    // Two contiguous copies per wrap instead of a modulo per frame.
    let mut out = Vec::with_capacity(frames);
    let mut pos = start % t;
    while out.len() < frames {
        let take = (frames - out.len()).min(t - pos);
        out.extend_from_slice(&pool[pos..pos + take]);
        pos = 0;
    }
    out
}

/// Average number of times each pool frame appears in the sessions: `N F / T`.
pub fn reuse_ratio(pool_len: usize, sessions: usize, frames: usize) -> f64 {
    (sessions * frames) as f64 / pool_len as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slicing_follows_formula_and_wraps() {
        let pool: Vec<usize> = (0..1000).collect();
        let (n, f) = (7, 400);
        assert_eq!(stride(1000, 7), 142);
        for i in 0..n {
            let s = slice_session(&pool, i, n, f);
            assert_eq!(s.len(), f);
            for (j, v) in s.iter().enumerate() {
                assert_eq!(*v, slice_index(i, j, 1000, n));
                assert_eq!(*v, (i * 142 + j) % 1000);
            }
        }
        // Session 6 starts at 852 and wraps after 148 frames.
        let s6 = slice_session(&pool, 6, n, f);
        assert_eq!((s6[0], s6[147], s6[148]), (852, 999, 0));
        // Sessions longer than the pool wrap more than once.
        let long = slice_session(&pool[..10], 1, 3, 25);
        assert_eq!(long[..4], [3, 4, 5, 6]);
        assert_eq!(long[24], (3 + 24) % 10);
    }

    #[test]
    fn normalization_moves_mean_onto_global() {
        let mut a = vec![
            CanvasPos {
                x_px: 0.0,
                y_px: 0.0,
            },
            CanvasPos {
                x_px: 2.0,
                y_px: 4.0,
            },
        ];
        let d = normalize_to(
            &mut a,
            CanvasPos {
                x_px: 640.0,
                y_px: 360.0,
            },
        );
        assert_eq!(d, [639.0, 358.0]);
        let m = eyereplay_core::mean_of(a.iter().copied()).unwrap();
        assert_eq!((m.x_px, m.y_px), (640.0, 360.0));
    }

    #[test]
    fn reuse_ratio_of_paper_reading_class() {
        // 72 sessions x 7500 frames from 33 min at 25 fps (49,500 frames).
        assert!((reuse_ratio(49_500, 72, 7500) - 10.909).abs() < 1e-3);
    }
}
