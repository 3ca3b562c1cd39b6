//! Weights that sum to one: every blending algorithm scales its terms' weights so, and the
//! scaling lives here once.

/// A term with a blending weight.
pub trait Weighted {
    fn weight_mut(&mut self) -> &mut f32;
}

impl Weighted for (u16, f32) {
    fn weight_mut(&mut self) -> &mut f32 {
        &mut self.1
    }
}

/// Scales the weights of `terms` so that they sum to 1. Weights that sum to zero or less
/// (or to no finite number) are left as they are: there is nothing to scale.
pub fn normalize<T: Weighted>(terms: &mut [T]) {
    let total: f32 = terms.iter_mut().map(|t| *t.weight_mut()).sum();
    if total > 0.0 && total.is_finite() {
        for term in terms {
            *term.weight_mut() /= total;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_keep_their_ratios() {
        let mut terms = [(0u16, 1.0f32), (1, 3.0)];
        normalize(&mut terms);
        assert_eq!(terms, [(0, 0.25), (1, 0.75)]);
    }

    #[test]
    fn weights_summing_to_zero_are_left_alone() {
        let mut terms = [(0u16, 0.0f32), (1, 0.0)];
        normalize(&mut terms);
        assert_eq!(terms, [(0, 0.0), (1, 0.0)]);
        let mut none: [(u16, f32); 0] = [];
        normalize(&mut none);
    }
}
