//! Rows built from other rows (the lip smoothing's means, a needle's blend of its edge):
//! terms of one control merged, then cut back to the `k` largest as the biharmonic field's
//! own rows are, so that deforming costs what it did.

use super::binding::LinearTerm;

/// One term per control, its weights summed (terms that sum to 0 dropped), the `k`
/// largest kept ([`keep_largest`]), in control order.
pub fn merge_by_control(terms: &mut [LinearTerm], k: usize) -> Vec<LinearTerm> {
    terms.sort_unstable_by_key(|t| t.control);
    let mut merged: Vec<(u16, f64)> = Vec::new();
    for term in terms.iter() {
        match merged.last_mut() {
            Some(last) if last.0 == term.control => last.1 += f64::from(term.weight),
            _ => merged.push((term.control, f64::from(term.weight))),
        }
    }
    merged.retain(|&(_, w)| w != 0.0);
    keep_largest(&mut merged, k);
    merged.sort_unstable_by_key(|&(control, _)| control);
    merged
        .into_iter()
        .map(|(control, weight)| LinearTerm {
            control,
            weight: weight as f32,
        })
        .collect()
}

/// Keeps the `k` weights of largest magnitude, corrected so that they keep the sum of
/// all: the dropped weights' sum goes to the kept ones in proportion to their magnitude.
/// For weights of one sign that is a rescale to the full sum; for the signed weights of an
/// extrapolating vertex it never divides by a sum that nearly cancels.
pub fn keep_largest<T>(weights: &mut Vec<(T, f64)>, k: usize) {
    if weights.len() <= k {
        return;
    }
    if k == 0 {
        weights.clear();
        return;
    }
    let total: f64 = weights.iter().map(|&(_, w)| w).sum();
    weights.select_nth_unstable_by(k - 1, |a, b| b.1.abs().total_cmp(&a.1.abs()));
    weights.truncate(k);
    let kept: f64 = weights.iter().map(|&(_, w)| w).sum();
    let magnitude: f64 = weights.iter().map(|&(_, w)| w.abs()).sum();
    if magnitude > 0.0 {
        let dropped_per_magnitude = (total - kept) / magnitude;
        for (_, w) in weights.iter_mut() {
            *w += dropped_per_magnitude * w.abs();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn terms_of_one_control_are_summed_and_cancelled_ones_dropped() {
        let term = |control, weight| LinearTerm { control, weight };
        let mut terms = vec![
            term(7, 0.25),
            term(2, 0.5),
            term(7, 0.5),
            term(3, 0.25),
            term(3, -0.25),
        ];
        assert_eq!(merge_by_control(&mut terms, 4), vec![term(2, 0.5), term(7, 0.75)]);
    }

    #[test]
    fn only_the_largest_terms_are_kept_and_they_keep_the_sum() {
        // 0.5, 0.25, 0.125 and 0.125 over four controls, two kept: the dropped 0.25 goes
        // to the kept in proportion (0.5 + 0.5 * 1/3, 0.25 + 0.25 * 1/3), summing to 1.
        let term = |control, weight| LinearTerm { control, weight };
        let mut terms = vec![term(4, 0.125), term(1, 0.25), term(9, 0.5), term(2, 0.125)];
        let kept = merge_by_control(&mut terms, 2);
        assert_eq!(kept.iter().map(|t| t.control).collect::<Vec<_>>(), [1, 9]);
        assert!((kept[0].weight - 1.0 / 3.0).abs() < 1e-6, "{kept:?}");
        assert!((kept[1].weight - 2.0 / 3.0).abs() < 1e-6, "{kept:?}");
    }
}
