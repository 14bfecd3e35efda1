use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// The behaviour a session shows; the dataset's label.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GazeClass {
    Reading,
    Conversation,
}

impl GazeClass {
    pub const ALL: [GazeClass; 2] = [GazeClass::Reading, GazeClass::Conversation];

    /// Binary label as in the paper's `labels.csv`: 1 = reading, 0 = conversation.
    pub fn label(self) -> u8 {
        match self {
            GazeClass::Reading => 1,
            GazeClass::Conversation => 0,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            GazeClass::Reading => "reading",
            GazeClass::Conversation => "conversation",
        }
    }

    /// The paper's per-class speed scale (appendix, circular slicing).
    pub fn default_speed_scale(self) -> f64 {
        match self {
            GazeClass::Reading => 1.05,
            GazeClass::Conversation => 1.0,
        }
    }
}

impl fmt::Display for GazeClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for GazeClass {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "reading" => Ok(GazeClass::Reading),
            "conversation" => Ok(GazeClass::Conversation),
            other => Err(format!(
                "unknown class '{other}' (expected 'reading' or 'conversation')"
            )),
        }
    }
}
