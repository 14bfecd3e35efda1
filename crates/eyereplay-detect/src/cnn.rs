//! The paper's suggestion: a 1D convolutional network on the window's
//! trajectory itself (candle), next to the feature model.
//!
//! Input: the prepared window (normalized and oriented, [`crate::window`])
//! as four channels, x, y and their frame-to-frame steps (scaled by
//! [`STEP_GAIN`] so that steps and positions are of one order). Three
//! convolutions (kernel 5, stride 2, 16/32/32 channels, ReLU), the mean
//! over time, one linear unit: the logit of reading. Trained with Adam on a
//! numerically stable binary cross-entropy (`softplus(-y z)`), weights
//! initialized from the seed (He uniform), batches shuffled by the seed, one
//! CPU thread: the same data and seed give the same weights.

use crate::window::Window;
use crate::DetectError;
use candle_core::{DType, Device, Tensor, D};
use candle_nn::{Conv1d, Conv1dConfig, Linear, Module, Optimizer, VarBuilder, VarMap};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Steps are about a tenth of the positions' spread: this brings them level.
pub const STEP_GAIN: f32 = 10.0;
const CHANNELS: [usize; 4] = [4, 16, 32, 32];
const KERNEL: usize = 5;

#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct CnnOptions {
    pub epochs: usize,
    pub batch: usize,
    pub learning_rate: f64,
    pub seed: u64,
}

impl Default for CnnOptions {
    fn default() -> Self {
        CnnOptions {
            epochs: 40,
            batch: 32,
            learning_rate: 2e-3,
            seed: 1,
        }
    }
}

/// Trained weights by parameter name (`c1.weight`, ...), flat, with shapes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CnnWeights {
    pub frames: usize,
    pub tensors: BTreeMap<String, (Vec<usize>, Vec<f32>)>,
}

struct Net {
    convs: Vec<Conv1d>,
    head: Linear,
}

impl Net {
    fn new(vb: &VarBuilder) -> candle_core::Result<Self> {
        let cfg = Conv1dConfig {
            padding: KERNEL / 2,
            stride: 2,
            ..Default::default()
        };
        let mut convs = Vec::new();
        for k in 0..3 {
            convs.push(candle_nn::conv1d(
                CHANNELS[k],
                CHANNELS[k + 1],
                KERNEL,
                cfg,
                vb.pp(format!("c{}", k + 1)),
            )?);
        }
        let head = candle_nn::linear(CHANNELS[3], 1, vb.pp("head"))?;
        Ok(Net { convs, head })
    }

    /// Logits, shape `(batch,)`, of inputs `(batch, 4, frames)`.
    fn forward(&self, x: &Tensor) -> candle_core::Result<Tensor> {
        let mut h = x.clone();
        for c in &self.convs {
            h = c.forward(&h)?.relu()?;
        }
        let pooled = h.mean(D::Minus1)?;
        self.head.forward(&pooled)?.squeeze(1)
    }
}

/// The four input channels of a window, `frames` long.
fn channels(w: &Window) -> Vec<f32> {
    let n = w.x.len();
    let mut out = Vec::with_capacity(4 * n);
    out.extend(w.x.iter().map(|&v| v as f32));
    out.extend(w.y.iter().map(|&v| v as f32));
    for v in [&w.x, &w.y] {
        out.push(0.0);
        out.extend((1..n).map(|i| STEP_GAIN * (v[i] - v[i - 1]) as f32));
    }
    out
}

fn batch_tensor(ws: &[&Window], frames: usize, dev: &Device) -> candle_core::Result<Tensor> {
    let mut data = Vec::with_capacity(ws.len() * 4 * frames);
    for w in ws {
        data.extend(channels(w));
    }
    Tensor::from_vec(data, (ws.len(), 4, frames), dev)
}

fn err(e: candle_core::Error) -> DetectError {
    DetectError::Train(format!("1D-CNN: {e}"))
}

/// Trains the network on prepared windows (all of one length).
pub fn train_cnn(
    windows: &[Window],
    labels: &[bool],
    opts: CnnOptions,
) -> Result<CnnWeights, DetectError> {
    let frames = windows.first().map_or(0, |w| w.x.len());
    if windows.is_empty() || windows.iter().any(|w| w.x.len() != frames) {
        return Err(DetectError::Train(
            "1D-CNN: windows must be non-empty and of one length".into(),
        ));
    }
    let dev = Device::Cpu;
    let varmap = VarMap::new();
    let vb = VarBuilder::from_varmap(&varmap, DType::F32, &dev);
    let net = Net::new(&vb).map_err(err)?;
    seed_weights(&varmap, opts.seed).map_err(err)?;
    let mut opt = candle_nn::AdamW::new(
        varmap.all_vars(),
        candle_nn::ParamsAdamW {
            lr: opts.learning_rate,
            weight_decay: 0.0,
            ..Default::default()
        },
    )
    .map_err(err)?;
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed ^ 0x5eed);
    let mut order: Vec<usize> = (0..windows.len()).collect();
    for _ in 0..opts.epochs {
        order.shuffle(&mut rng);
        for chunk in order.chunks(opts.batch.max(1)) {
            let ws: Vec<&Window> = chunk.iter().map(|&i| &windows[i]).collect();
            let x = batch_tensor(&ws, frames, &dev).map_err(err)?;
            let sign: Vec<f32> = chunk
                .iter()
                .map(|&i| if labels[i] { 1.0 } else { -1.0 })
                .collect();
            let y = Tensor::from_vec(sign, chunk.len(), &dev).map_err(err)?;
            let z = net.forward(&x).map_err(err)?;
            // softplus(-y z) = relu(t) + log(1 + exp(-|t|)), t = -y z.
            let t = (z * y).map_err(err)?.neg().map_err(err)?;
            let loss = (t.relu().map_err(err)?
                + ((t
                    .abs()
                    .map_err(err)?
                    .neg()
                    .map_err(err)?
                    .exp()
                    .map_err(err)?
                    + 1.0)
                    .map_err(err)?
                    .log())
                .map_err(err)?)
            .map_err(err)?
            .mean_all()
            .map_err(err)?;
            opt.backward_step(&loss).map_err(err)?;
        }
    }
    let mut tensors = BTreeMap::new();
    let data = varmap.data().lock().expect("varmap lock");
    for (name, var) in data.iter() {
        let t = var.as_tensor();
        let values: Vec<f32> = t.flatten_all().map_err(err)?.to_vec1().map_err(err)?;
        tensors.insert(name.clone(), (t.dims().to_vec(), values));
    }
    Ok(CnnWeights { frames, tensors })
}

/// He-uniform weights and zero biases from the seed, in name order (the
/// library's own initialization draws from an unseeded generator).
fn seed_weights(varmap: &VarMap, seed: u64) -> candle_core::Result<()> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let data = varmap.data().lock().expect("varmap lock");
    let mut names: Vec<&String> = data.keys().collect();
    names.sort();
    for name in names {
        let var = &data[name];
        let dims = var.as_tensor().dims().to_vec();
        let n: usize = dims.iter().product();
        let values: Vec<f32> = if name.ends_with("bias") {
            vec![0.0; n]
        } else {
            let fan_in: usize = dims[1..].iter().product::<usize>().max(1);
            let bound = (6.0 / fan_in as f64).sqrt() as f32;
            (0..n).map(|_| rng.gen_range(-bound..bound)).collect()
        };
        var.set(&Tensor::from_vec(values, dims, var.device())?)?;
    }
    Ok(())
}

impl CnnWeights {
    fn net(&self) -> candle_core::Result<Net> {
        let dev = Device::Cpu;
        let mut map = std::collections::HashMap::new();
        for (name, (shape, values)) in &self.tensors {
            map.insert(
                name.clone(),
                Tensor::from_vec(values.clone(), shape.clone(), &dev)?,
            );
        }
        let vb = VarBuilder::from_tensors(map, DType::F32, &dev);
        Net::new(&vb)
    }

    /// Reading probabilities of windows of this network's length.
    pub fn probabilities(&self, windows: &[&Window]) -> Result<Vec<f64>, DetectError> {
        if windows.is_empty() {
            return Ok(Vec::new());
        }
        let net = self.net().map_err(err)?;
        let x = batch_tensor(windows, self.frames, &Device::Cpu).map_err(err)?;
        let z: Vec<f32> = net.forward(&x).map_err(err)?.to_vec1().map_err(err)?;
        Ok(z.iter()
            .map(|&z| 1.0 / (1.0 + (-f64::from(z)).exp()))
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::window::prepare_window;

    /// Sawtooth (reading-like) against random jumps, with noise.
    fn data(n: usize, seed: u64) -> (Vec<Window>, Vec<bool>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let (mut ws, mut ls) = (Vec::new(), Vec::new());
        for k in 0..n {
            let reading = k % 2 == 0;
            let mut xy = Vec::new();
            let (mut x, mut y) = (0.0f64, 0.0f64);
            for i in 0..250 {
                if reading {
                    if i % 8 == 0 {
                        x += 0.1;
                    }
                    if x > 0.8 {
                        x = 0.0;
                        y += 0.05;
                    }
                } else if i % 9 == 0 {
                    x = rng.gen_range(0.0..1.0);
                    y = rng.gen_range(0.0..1.0);
                }
                xy.push([
                    x + rng.gen_range(-0.01..0.01),
                    y + rng.gen_range(-0.01..0.01),
                ]);
            }
            ws.push(prepare_window(&xy, 0).unwrap());
            ls.push(reading);
        }
        (ws, ls)
    }

    #[test]
    fn the_network_learns_a_separable_task_and_training_is_deterministic() {
        let (ws, ls) = data(48, 1);
        let opts = CnnOptions {
            epochs: 15,
            ..CnnOptions::default()
        };
        let a = train_cnn(&ws, &ls, opts).unwrap();
        let b = train_cnn(&ws, &ls, opts).unwrap();
        assert_eq!(a, b);
        let (tw, tl) = data(20, 2);
        let refs: Vec<&Window> = tw.iter().collect();
        let p = a.probabilities(&refs).unwrap();
        let auc = crate::metrics::auroc(&p, &tl).unwrap();
        assert!(auc >= 0.95, "AUROC {auc} on new windows: {p:?}");
    }
}
