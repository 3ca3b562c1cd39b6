//! Which algorithms a comparison runs: the `--algos` list, each entry with the short label
//! that tables and charts use (the preset letter of a preset, `X1`, `X2`, ... otherwise).

use crate::deform::AlgoSpec;

use super::CompareError;

/// One algorithm to compare.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The letter (`A`-`U`) of a preset, else `X1`, `X2`, ... in list order.
    pub label: String,
    pub spec: AlgoSpec,
}

/// Every preset, A-R from the thesis plus S (`kshirsagar`), T (`rbf`), U (interpolating
/// `point_distance`) and V (`biharmonic`).
pub fn every_preset() -> Vec<Candidate> {
    AlgoSpec::presets()
        .into_iter()
        .map(|(letter, spec, _)| Candidate {
            label: letter.to_string(),
            spec,
        })
        .collect()
}

/// Parses a comma-separated list of specs or letters: `A,C,rbf:r_mm=30`. Specs have commas
/// of their own (`bary2:weights=distance,r_mm=10`), so an item that is `key=value` with no
/// `name:` part continues the spec before it. The same algorithm twice is an error.
pub fn parse_algorithms(text: &str) -> Result<Vec<Candidate>, CompareError> {
    let mut items: Vec<String> = Vec::new();
    for item in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let continues = item.contains('=') && !item.contains(':');
        match items.last_mut() {
            Some(previous) if continues && previous.contains(':') => {
                previous.push(',');
                previous.push_str(item);
            }
            Some(previous) if continues => {
                return Err(CompareError::DanglingParameter {
                    item: item.to_string(),
                    previous: previous.clone(),
                })
            }
            _ => items.push(item.to_string()),
        }
    }
    if items.is_empty() {
        return Err(CompareError::NoAlgorithms);
    }
    let mut candidates: Vec<(Candidate, String)> = Vec::with_capacity(items.len());
    let mut unnamed = 0;
    for item in items {
        let spec: AlgoSpec = item.parse().map_err(|source| CompareError::Algorithm {
            item: item.clone(),
            source,
        })?;
        if let Some((_, first)) = candidates.iter().find(|(c, _)| c.spec == spec) {
            return Err(CompareError::Repeated {
                spec: spec.to_string(),
                first: first.clone(),
                second: item,
            });
        }
        let label = match spec.letter() {
            Some(letter) => letter.to_string(),
            None => {
                unnamed += 1;
                format!("X{unnamed}")
            }
        };
        candidates.push((Candidate { label, spec }, item));
    }
    Ok(candidates.into_iter().map(|(c, _)| c).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn labels(text: &str) -> Vec<String> {
        parse_algorithms(text)
            .unwrap()
            .into_iter()
            .map(|c| c.label)
            .collect()
    }

    #[test]
    fn letters_specs_and_their_commas() {
        assert_eq!(labels("A, t"), ["A", "T"]);
        assert_eq!(labels("bary2:weights=distance,r_mm=10,rbf"), ["C", "T"]);
        assert_eq!(labels("rbf:r_mm=30,kernel=gaussian ,G"), ["X1", "G"]);
        assert_eq!(
            labels("rbf:kernel=gaussian,r_mm=30,bary1:alpha=0.5"),
            ["X1", "X2"]
        );
        assert_eq!(every_preset().len(), 22);
    }

    #[test]
    fn bad_lists_say_what_is_wrong() {
        let text = |list: &str| parse_algorithms(list).unwrap_err().to_string();
        assert!(
            text("A,warp").contains("valid: bary1, bary2"),
            "{}",
            text("A,warp")
        );
        assert!(text("A,warp").starts_with("--algos item \"warp\""));
        assert!(text("rbf,r_mm=30").contains("write rbf:r_mm=30"));
        assert!(
            text("T,rbf").contains("listed twice (T and rbf)"),
            "{}",
            text("T,rbf")
        );
        assert!(text(" , ").contains("empty"));
    }
}
