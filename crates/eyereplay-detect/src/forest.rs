//! Bagged decision trees over the window [`features`](mod@crate::features):
//! each tree (linfa-trees, Gini) fitted on a bootstrap sample of the
//! training windows, a window's score the mean over the trees of the
//! share of reading windows in the leaf it falls in (scikit-learn's
//! `RandomForestClassifier.predict_proba` with every feature at every
//! split). On held-out generated interviews read back from video it
//! separates reading windows from talk better than the logistic
//! regression (docs/DETECTOR.md, "Bagged trees").

use crate::features::FEATURE_COUNT;
use crate::DetectError;
use linfa::prelude::*;
use linfa_trees::{DecisionTree, SplitQuality, TreeNode};
use ndarray::{Array1, Array2};
use rand::Rng;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Trees in a forest (scikit-learn's forest of the same trees separated
/// the interviews' windows as well with 100 as with 300).
pub const TREES: usize = 100;

/// Fewest (bootstrap-weighted) windows in a leaf: an eighth of the
/// default's 160 training windows. Leaves of 3-5 windows separated the
/// generated interviews' windows best but called 8-21 % of other people's
/// real tasks reading in the spliced streams; from 20 to 40 the segments
/// held steady on both (docs/DETECTOR.md, "Bagged trees").
pub const MIN_LEAF_WINDOWS: f32 = 20.0;

/// The weight of a not-reading window against a reading one's 1. linfa
/// names a leaf's class by the larger weight and breaks a tie by the
/// order of a `HashMap`, which differs from one process to the next, and
/// merges sibling leaves of one class after the fit: a tie could then
/// change the tree. A weight a count of windows can never tie with (2^-10
/// over 1, exact in f32) keeps the same data giving the same trees.
const OTHER_WEIGHT: f32 = 1.0 + 1.0 / 1024.0;

/// One tree, its nodes in a list, the root first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tree {
    pub nodes: Vec<Node>,
}

/// A split (a window goes `left` when its feature is below `threshold`,
/// as linfa-trees decides) or a leaf with its share of reading windows.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum Node {
    Split {
        feature: usize,
        threshold: f64,
        left: usize,
        right: usize,
    },
    Leaf {
        reading_share: f64,
    },
}

/// The fitted trees.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Forest {
    pub trees: Vec<Tree>,
}

impl Tree {
    fn leaf_of(&self, f: &[f64; FEATURE_COUNT]) -> usize {
        let mut i = 0;
        loop {
            match self.nodes[i] {
                Node::Split {
                    feature,
                    threshold,
                    left,
                    right,
                } => i = if f[feature] < threshold { left } else { right },
                Node::Leaf { .. } => return i,
            }
        }
    }

    /// The reading share of the leaf `f` falls in.
    fn reading_share(&self, f: &[f64; FEATURE_COUNT]) -> f64 {
        match self.nodes[self.leaf_of(f)] {
            Node::Leaf { reading_share } => reading_share,
            Node::Split { .. } => unreachable!("leaf_of ends on a leaf"),
        }
    }

    /// The list form of a linfa tree, its leaves' shares left at 0.
    fn of(root: &TreeNode<f64, bool>) -> Self {
        fn push(node: &TreeNode<f64, bool>, nodes: &mut Vec<Node>) -> usize {
            let at = nodes.len();
            nodes.push(Node::Leaf { reading_share: 0.0 });
            if !node.is_leaf() {
                let (feature, threshold, _) = node.split();
                let children = node.children();
                let (Some(l), Some(r)) = (children[0], children[1]) else {
                    return at;
                };
                let left = push(l, nodes);
                let right = push(r, nodes);
                nodes[at] = Node::Split {
                    feature,
                    threshold,
                    left,
                    right,
                };
            }
            at
        }
        let mut nodes = Vec::new();
        push(root, &mut nodes);
        Tree { nodes }
    }

    /// Each leaf's share of reading among the windows that reach it.
    fn set_leaf_shares(&mut self, x: &[[f64; FEATURE_COUNT]], y: &[bool]) {
        let mut counts = vec![(0usize, 0usize); self.nodes.len()];
        for (f, &reading) in x.iter().zip(y) {
            let c = &mut counts[self.leaf_of(f)];
            c.0 += usize::from(reading);
            c.1 += 1;
        }
        for (node, (r, n)) in self.nodes.iter_mut().zip(counts) {
            if let Node::Leaf { reading_share } = node {
                *reading_share = if n > 0 { r as f64 / n as f64 } else { 0.5 };
            }
        }
    }
}

/// One tree on `(x, y)` (linfa-trees, Gini, at least `min_leaf` windows
/// in a leaf), a not-reading window weighing `other_weight`; its leaves'
/// reading shares counted from `(x, y)`.
pub(crate) fn fit_tree(
    x: &[[f64; FEATURE_COUNT]],
    y: &[bool],
    other_weight: f32,
    min_leaf: f32,
) -> Result<Tree, DetectError> {
    let records = Array2::from_shape_fn((x.len(), FEATURE_COUNT), |(r, k)| x[r][k]);
    let weights: Array1<f32> = y
        .iter()
        .map(|&r| if r { 1.0 } else { other_weight })
        .collect();
    let data = Dataset::new(records, Array1::from(y.to_vec())).with_weights(weights);
    let fitted = DecisionTree::<f64, bool>::params()
        .split_quality(SplitQuality::Gini)
        .min_weight_leaf(min_leaf)
        .fit(&data)
        .map_err(|e| DetectError::Train(format!("decision tree: {e}")))?;
    let mut tree = Tree::of(fitted.root_node());
    tree.set_leaf_shares(x, y);
    Ok(tree)
}

impl Forest {
    /// Fits [`TREES`] trees, each on a bootstrap sample of `(x, y)` drawn
    /// from `seed`.
    pub fn fit(x: &[[f64; FEATURE_COUNT]], y: &[bool], seed: u64) -> Result<Self, DetectError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut trees = Vec::with_capacity(TREES);
        for _ in 0..TREES {
            let pick: Vec<usize> = (0..x.len()).map(|_| rng.gen_range(0..x.len())).collect();
            let bx: Vec<[f64; FEATURE_COUNT]> = pick.iter().map(|&i| x[i]).collect();
            let by: Vec<bool> = pick.iter().map(|&i| y[i]).collect();
            trees.push(fit_tree(&bx, &by, OTHER_WEIGHT, MIN_LEAF_WINDOWS)?);
        }
        Ok(Forest { trees })
    }

    /// The mean over the trees of the reading share of the leaf `f` falls in.
    pub fn probability(&self, f: &[f64; FEATURE_COUNT]) -> f64 {
        let sum: f64 = self.trees.iter().map(|t| t.reading_share(f)).sum();
        sum / self.trees.len().max(1) as f64
    }

    /// The logit of [`Forest::probability`], held half a tree's vote
    /// inside 0 and 1 so that it stays finite: what Platt scaling
    /// calibrates.
    pub fn log_odds(&self, f: &[f64; FEATURE_COUNT]) -> f64 {
        let margin = 0.5 / self.trees.len().max(1) as f64;
        let p = self.probability(f).clamp(margin, 1.0 - margin);
        (p / (1.0 - p)).ln()
    }

    /// Whether every split names a feature and a node of its own tree (a
    /// model file edited by hand could name others).
    pub fn is_well_formed(&self) -> bool {
        self.malformed().is_none()
    }

    /// What is wrong with a forest read from a file, if anything.
    pub fn malformed(&self) -> Option<&'static str> {
        if self.trees.is_empty() || self.trees.iter().any(|t| t.nodes.is_empty()) {
            return Some("its forest has no trees, or a tree without nodes");
        }
        for t in &self.trees {
            for (i, n) in t.nodes.iter().enumerate() {
                match *n {
                    Node::Split {
                        feature,
                        left,
                        right,
                        threshold,
                    } => {
                        if !(feature < FEATURE_COUNT
                            && left > i
                            && right > i
                            && left < t.nodes.len()
                            && right < t.nodes.len())
                        {
                            return Some("its trees name a feature or a node that is not there");
                        }
                        if !threshold.is_finite() {
                            return Some("a split of its trees has no finite threshold");
                        }
                    }
                    Node::Leaf { reading_share } => {
                        if !(0.0..=1.0).contains(&reading_share) {
                            return Some("a leaf of its trees has a reading share outside 0 to 1");
                        }
                    }
                }
            }
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(a: f64, b: f64) -> [f64; FEATURE_COUNT] {
        let mut f = [0.0; FEATURE_COUNT];
        f[0] = a;
        f[1] = b;
        f
    }

    /// Worked by hand: x = 1..8 on feature 0, reading at 4, 5, 7, 8. With
    /// three or more windows a side the splits are 3|4 (left 3 F: Gini 0;
    /// right T T F T T: 1 - 0.8^2 - 0.2^2 = 0.32; weighted 5/8 * 0.32 =
    /// 0.2), 4|5 (0.375 both sides: 0.375) and 5|6 (F F F T T: 0.48,
    /// F T T: 0.444; 0.3 + 0.167 = 0.467). So the split is at the midpoint
    /// 3.5; the right side's 5 cannot split again into two leaves of 3,
    /// and its leaf holds 4 of 5 reading.
    #[test]
    fn a_tree_splits_where_gini_says_with_its_leaves_reading_shares() {
        let x: Vec<_> = (1..=8).map(|v| point(v as f64, 0.0)).collect();
        let y = [false, false, false, true, true, false, true, true];
        let tree = fit_tree(&x, &y, 1.0, 3.0).unwrap();
        assert_eq!(
            tree.nodes,
            [
                Node::Split {
                    feature: 0,
                    threshold: 3.5,
                    left: 1,
                    right: 2
                },
                Node::Leaf { reading_share: 0.0 },
                Node::Leaf { reading_share: 0.8 },
            ]
        );
    }

    /// Reading where exactly one of two features is positive: no line
    /// separates it (a logistic regression scores it at chance), the
    /// trees do; and the same data and seed give the same forest.
    #[test]
    fn the_forest_learns_an_interaction_and_is_deterministic() {
        let mut x = Vec::new();
        let mut y = Vec::new();
        for i in 0..20 {
            for j in 0..20 {
                let (a, b) = (i as f64 - 9.5, j as f64 - 9.5);
                x.push(point(a, b));
                y.push((a > 0.0) != (b > 0.0));
            }
        }
        let forest = Forest::fit(&x, &y, 7).unwrap();
        assert!(forest.is_well_formed());
        for (a, b, reading) in [
            (5.0, -5.0, true),
            (-5.0, 5.0, true),
            (5.0, 5.0, false),
            (-5.0, -5.0, false),
        ] {
            let p = forest.probability(&point(a, b));
            assert_eq!(p > 0.9, reading, "({a}, {b}): {p}");
            assert_eq!(p < 0.1, !reading, "({a}, {b}): {p}");
        }
        let again = Forest::fit(&x, &y, 7).unwrap();
        assert_eq!(
            serde_json::to_string(&forest).unwrap(),
            serde_json::to_string(&again).unwrap()
        );
        // The log-odds stay finite where every tree agrees.
        assert!(forest.log_odds(&point(5.0, -5.0)).is_finite());
    }

    #[test]
    fn a_tree_naming_a_node_out_of_reach_is_not_well_formed() {
        let tree = |left| Tree {
            nodes: vec![
                Node::Split {
                    feature: 0,
                    threshold: 0.0,
                    left,
                    right: 2,
                },
                Node::Leaf { reading_share: 0.0 },
                Node::Leaf { reading_share: 1.0 },
            ],
        };
        assert!(Forest {
            trees: vec![tree(1)]
        }
        .is_well_formed());
        // A loop back to the root, and a node that is not there.
        assert!(!Forest {
            trees: vec![tree(0)]
        }
        .is_well_formed());
        assert!(!Forest {
            trees: vec![tree(5)]
        }
        .is_well_formed());
    }
}
