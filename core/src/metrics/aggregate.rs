//! From frames to the thesis's table E.1: a syllable scores the mean of its frames' summary
//! means (the union of the lip triangles), and an algorithm scores the mean and population
//! variance of its syllables' scores.

use super::lip_roughness::LipRoughnessRow;

/// One syllable's score.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SyllableScore<'a> {
    pub label: &'a str,
    /// Summary rows (frames) that went into it.
    pub frames: u64,
    /// Mean of their means.
    pub mean: f64,
}

/// An algorithm's score over syllables (table E.1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlgorithmScore {
    pub syllables: usize,
    pub mean: f64,
    /// Population variance of the syllable scores.
    pub variance: f64,
}

#[derive(Debug, Clone, PartialEq)]
struct Syllable {
    label: String,
    frames: u64,
    sum: f64,
}

/// Running per-syllable means of the summary rows, in order of each label's first frame.
/// Frames of one label count towards one syllable even when they are not consecutive.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SyllableScores {
    syllables: Vec<Syllable>,
}

impl SyllableScores {
    pub fn new() -> SyllableScores {
        SyllableScores::default()
    }

    /// Adds a frame's rows under its syllable label; only summary rows count. Allocates
    /// only for a label not seen before.
    pub fn add(&mut self, label: &str, rows: &[LipRoughnessRow]) {
        let index = match self.syllables.iter().rposition(|s| s.label == label) {
            Some(index) => index,
            None => {
                self.syllables.push(Syllable {
                    label: label.to_string(),
                    frames: 0,
                    sum: 0.0,
                });
                self.syllables.len() - 1
            }
        };
        let syllable = &mut self.syllables[index];
        for row in rows.iter().filter(|r| r.is_summary()) {
            syllable.frames += 1;
            syllable.sum += row.mean;
        }
    }

    /// Every syllable with at least one summary row.
    pub fn scores(&self) -> impl Iterator<Item = SyllableScore<'_>> {
        self.syllables
            .iter()
            .filter(|s| s.frames > 0)
            .map(|s| SyllableScore {
                label: &s.label,
                frames: s.frames,
                mean: s.sum / s.frames as f64,
            })
    }

    /// Mean and population variance over the syllables; `None` before any summary row.
    pub fn algorithm_score(&self) -> Option<AlgorithmScore> {
        algorithm_score(self.scores().map(|s| s.mean))
    }
}

/// Mean and population variance of syllable scores; `None` for no scores.
pub fn algorithm_score(syllable_means: impl IntoIterator<Item = f64>) -> Option<AlgorithmScore> {
    // Welford: one pass, no cancellation.
    let (mut count, mut mean, mut squares) = (0usize, 0.0f64, 0.0f64);
    for x in syllable_means {
        count += 1;
        let step = x - mean;
        mean += step / count as f64;
        squares += step * (x - mean);
    }
    (count > 0).then(|| AlgorithmScore {
        syllables: count,
        mean,
        variance: squares / count as f64,
    })
}
