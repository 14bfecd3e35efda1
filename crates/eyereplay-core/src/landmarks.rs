//! Which landmark networks read a face: named here, below the extractor,
//! so that a config's `video` source, `eyereplay extract --landmarks` and
//! the Python package spell and parse one type.

use serde::{Deserialize, Serialize};

/// Which landmark networks read the face and eyes.
///
/// The cascade is the default of the library: reading rendered video back
/// (the probes, the read-back match, the report), `generate`'s `video`
/// sources and the detector were all measured with it. `eyereplay extract`
/// reads real video with the attention mesh unless told otherwise
/// (`eyereplay_extract::landmarks_for_real_video`).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum LandmarkModel {
    /// The face mesh (`face_landmark`), then the iris model on each eye's
    /// own 64-px crop: MediaPipe's iris pipeline.
    #[default]
    Cascade,
    /// The attention face mesh (`face_landmark_with_attention`), which
    /// MediaPipe's Python face mesh runs with `refine_landmarks=True`: the
    /// mesh, both eye contours and both irises from one 192-px face crop,
    /// about a third of the cascade's arithmetic.
    Attention,
}

impl LandmarkModel {
    /// Every model, in the order their names are listed.
    pub const ALL: [LandmarkModel; 2] = [LandmarkModel::Cascade, LandmarkModel::Attention];

    /// The name `--landmarks`, a `video` source's `landmarks` and the
    /// Python package spell.
    pub fn name(self) -> &'static str {
        match self {
            LandmarkModel::Cascade => "cascade",
            LandmarkModel::Attention => "attention",
        }
    }
}

impl std::str::FromStr for LandmarkModel {
    type Err = String;

    /// A model by its [`LandmarkModel::name`]; the error names the value
    /// and the names there are.
    fn from_str(s: &str) -> Result<LandmarkModel, String> {
        LandmarkModel::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| {
                let names: Vec<String> = LandmarkModel::ALL
                    .iter()
                    .map(|m| format!("{:?}", m.name()))
                    .collect();
                format!("landmarks {s:?}: expected {}", names.join(" or "))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::LandmarkModel;

    #[test]
    fn names_parse_back_and_serialize_as_spelled() {
        for m in LandmarkModel::ALL {
            assert_eq!(m.name().parse::<LandmarkModel>(), Ok(m));
            assert_eq!(
                serde_json::to_string(&m).unwrap(),
                format!("\"{}\"", m.name())
            );
        }
        assert_eq!(
            "mesh".parse::<LandmarkModel>(),
            Err("landmarks \"mesh\": expected \"cascade\" or \"attention\"".to_string())
        );
        assert_eq!(LandmarkModel::default(), LandmarkModel::Cascade);
    }
}
