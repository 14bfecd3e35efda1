//! Decoded carrier frames as packed RGB, and reading the frames a session
//! needs in the order it needs them.

use crate::error::Result;
use eyereplay_core::RgbImage;
use eyereplay_extract::{Decoder, ImageView, Planes, Rotation};
use std::ops::ControlFlow;
use std::path::Path;

/// A frame as packed 8-bit RGB, upright: eyereplay-core's [`RgbImage`].
pub type RgbFrame = RgbImage;

/// A carrier frame to and from the extractor's image type (the image type
/// lives in eyereplay-core, which does not know the extractor's).
pub trait FrameView {
    /// The decoded frame in RGB, cropped to even width and height (the
    /// encoder's yuv420p needs them).
    fn from_view(img: &ImageView) -> Self;
    /// The frame as the extractor's image type (to read it back).
    fn view(&self) -> ImageView<'_>;
}

impl FrameView for RgbFrame {
    fn from_view(img: &ImageView) -> RgbFrame {
        let (w, h) = img.size();
        let (ew, eh) = (w & !1, h & !1);
        let mut data = Vec::with_capacity(ew * eh * 3);
        match img.planes {
            // The decoders' usual output, upright: a direct conversion (the
            // general path samples through the rotation per pixel).
            Planes::Yuv420 {
                y,
                u,
                v,
                y_stride,
                c_stride,
                matrix,
            } if img.rotation == Rotation::None => {
                for row in 0..eh {
                    let yr = &y[row * y_stride..];
                    let cr = (row >> 1) * c_stride;
                    for (col, &luma) in yr[..ew].iter().enumerate() {
                        let ci = cr + (col >> 1);
                        let p = matrix.rgb(luma as f32, u[ci] as f32, v[ci] as f32);
                        data.extend(p.iter().map(|c| (c + 0.5) as u8));
                    }
                }
            }
            _ => {
                let (_, _, full) = img.to_rgb8(1);
                for row in 0..eh {
                    data.extend_from_slice(&full[row * w * 3..(row * w + ew) * 3]);
                }
            }
        }
        RgbFrame {
            width: ew,
            height: eh,
            data,
        }
    }

    fn view(&self) -> ImageView<'_> {
        ImageView {
            planes: Planes::Rgb24 {
                data: &self.data,
                stride: self.width * 3,
            },
            raw_w: self.width,
            raw_h: self.height,
            rotation: Rotation::None,
        }
    }
}

/// Index of the frame whose time is nearest `t_s` (`times_s` ascending).
pub fn nearest_frame(times_s: &[f64], t_s: f64) -> usize {
    let i = times_s.partition_point(|&t| t < t_s);
    if i == 0 {
        0
    } else if i == times_s.len() {
        times_s.len() - 1
    } else if t_s - times_s[i - 1] <= times_s[i] - t_s {
        i - 1
    } else {
        i
    }
}

/// Frames decoded per backward chunk: a backward run is read in chunks
/// of this many frames, each decoded forward from a seek and handed out in
/// reverse (about 30 MB of 640x480 RGB).
const BACKWARD_CHUNK: usize = 32;

/// Decodes the carrier frames `first..=last` and calls `f(index, frame)`
/// for each in order; indices come from each frame's time.
fn decode_range(
    dec: &mut Decoder,
    times_s: &[f64],
    first: usize,
    last: usize,
    f: &mut dyn FnMut(usize, &ImageView) -> Result<()>,
) -> Result<()> {
    // A little before the frame's time, so the seek lands on or before it.
    let dt = if times_s.len() > 1 {
        (times_s[times_s.len() - 1] - times_s[0]) / (times_s.len() - 1) as f64
    } else {
        0.04
    };
    dec.seek_s(times_s[first] - 0.5 * dt)?;
    let mut err = None;
    dec.frames(|t, img| {
        let i = nearest_frame(times_s, t);
        if i < first {
            return Ok(ControlFlow::Continue(()));
        }
        if let Err(e) = f(i, img) {
            err = Some(e);
            return Ok(ControlFlow::Break(()));
        }
        Ok(if i >= last {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        })
    })?;
    match err {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// Calls `f(k, carrier_index, frame)` for every output frame `k` of
/// `plan` (the carrier frame each output frame shows), in output order.
/// Forward runs of the plan are decoded as a stream; backward runs (a
/// ping-pong loop's way back) in chunks decoded forward and handed out in
/// reverse, so memory stays bounded whatever the clip's length.
pub fn for_each_planned(
    video: &Path,
    times_s: &[f64],
    plan: &[usize],
    f: &mut dyn FnMut(usize, usize, &RgbFrame) -> Result<()>,
) -> Result<()> {
    let mut dec = Decoder::open(video)?;
    let mut k = 0;
    while k < plan.len() {
        // The run: as long as the plan keeps one direction.
        let forward = k + 1 >= plan.len() || plan[k + 1] >= plan[k];
        let mut end = k + 1;
        while end < plan.len()
            && (if forward {
                plan[end] >= plan[end - 1]
            } else {
                plan[end] <= plan[end - 1]
            })
        {
            end += 1;
        }
        if forward {
            let mut next = k;
            let mut last: Option<RgbFrame> = None;
            decode_range(&mut dec, times_s, plan[k], plan[end - 1], &mut |i, img| {
                if next < end && plan[next] <= i {
                    let frame = RgbFrame::from_view(img);
                    while next < end && plan[next] <= i {
                        f(next, i, &frame)?;
                        next += 1;
                    }
                    last = Some(frame);
                }
                Ok(())
            })?;
            // A stream that ended early (a damaged tail): the last frame
            // stands in, so the output keeps its length.
            while next < end {
                let frame =
                    last.as_ref()
                        .ok_or_else(|| eyereplay_extract::ExtractError::Decode {
                            path: video.to_path_buf(),
                            message: format!("no frame decoded at carrier frame {}", plan[next]),
                        })?;
                f(next, plan[next], frame)?;
                next += 1;
            }
        } else {
            let mut next = k;
            while next < end {
                let hi = plan[next];
                let lo = hi.saturating_sub(BACKWARD_CHUNK - 1).max(plan[end - 1]);
                let mut chunk: Vec<(usize, RgbFrame)> = Vec::new();
                decode_range(&mut dec, times_s, lo, hi, &mut |i, img| {
                    if i <= hi {
                        chunk.push((i, RgbFrame::from_view(img)));
                    }
                    Ok(())
                })?;
                while next < end && plan[next] >= lo {
                    let want = plan[next];
                    // The decoded frame at or nearest below the wanted one.
                    let (i, frame) = chunk
                        .iter()
                        .rev()
                        .find(|(i, _)| *i <= want)
                        .or(chunk.first())
                        .ok_or_else(|| eyereplay_extract::ExtractError::Decode {
                            path: video.to_path_buf(),
                            message: format!("no frame decoded at carrier frame {want}"),
                        })?;
                    f(next, *i, frame)?;
                    next += 1;
                }
            }
        }
        k = end;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_frame_rounds_to_the_closer_time() {
        let t = [0.0, 0.04, 0.08, 0.12];
        assert_eq!(nearest_frame(&t, -1.0), 0);
        assert_eq!(nearest_frame(&t, 0.019), 0);
        assert_eq!(nearest_frame(&t, 0.021), 1);
        assert_eq!(nearest_frame(&t, 0.08), 2);
        assert_eq!(nearest_frame(&t, 9.0), 3);
    }
}
