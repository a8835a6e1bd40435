//! Alias tables: choosing index i with probability w_i / Σw in O(1) (Walker 1977, built with
//! Vose's method, "A linear algorithm for generating random numbers with a given distribution",
//! IEEE TSE 17(9), 1991; pbrt-v4 §A.1 "The Alias Method"). The GPU picks a bucket i = ⌊u N⌋ and
//! keeps it when the fraction u N − i is below `prob[i]`, else takes `alias[i]`
//! (`shaders/lights.wgsl`), where a binary search over a CDF took log₂ N dependent loads.

/// One bucket: keep the bucket's own index with probability `prob`, else take `alias`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AliasBucket {
    pub prob: f32,
    pub alias: u32,
}

/// The alias table of `weights` (negative or non-finite weights count as 0; all zero: uniform).
pub fn alias_table(weights: &[f64]) -> Vec<AliasBucket> {
    let n = weights.len();
    let clean: Vec<f64> = weights.iter().map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 }).collect();
    let total: f64 = clean.iter().sum();
    // Each bucket's share scaled so that the mean is 1.
    let mut scaled: Vec<f64> =
        if total > 0.0 { clean.iter().map(|w| w * n as f64 / total).collect() } else { vec![1.0; n] };
    let mut table: Vec<AliasBucket> = (0..n).map(|i| AliasBucket { prob: 1.0, alias: i as u32 }).collect();
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(s), Some(&l)) = (small.pop(), large.last()) {
        // Bucket s keeps its own share and lends the rest of its room to l.
        table[s] = AliasBucket { prob: scaled[s] as f32, alias: l as u32 };
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left is 1 up to rounding: those buckets keep their index (prob 1).
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The probability the table gives each index, summed over the buckets.
    fn implied(table: &[AliasBucket]) -> Vec<f64> {
        let n = table.len() as f64;
        let mut p = vec![0.0; table.len()];
        for (i, b) in table.iter().enumerate() {
            p[i] += b.prob as f64 / n;
            p[b.alias as usize] += (1.0 - b.prob as f64) / n;
        }
        p
    }

    #[test]
    fn tables_give_each_index_its_weight() {
        let cases: Vec<Vec<f64>> = vec![
            vec![1.0],
            vec![1.0, 1.0, 1.0],
            vec![1.0, 2.0, 3.0, 4.0],
            vec![0.0, 5.0, 0.0, 1e-6],
            vec![1e6, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
            (0..1000).map(|i| ((i * 7919) % 101) as f64 + 0.5).collect(),
        ];
        for w in cases {
            let total: f64 = w.iter().sum();
            let table = alias_table(&w);
            assert_eq!(table.len(), w.len());
            for (i, (p, wi)) in implied(&table).iter().zip(&w).enumerate() {
                // f32 probabilities: each bucket's share is exact to about 6e-8 of 1/N.
                assert!((p - wi / total).abs() < 1e-6, "index {i} of {w:?}: {p} against {}", wi / total);
                assert!(table[i].prob >= 0.0 && table[i].prob <= 1.0 && (table[i].alias as usize) < w.len());
            }
        }
    }

    #[test]
    fn zero_weights_never_chosen_and_all_zero_is_uniform() {
        let table = alias_table(&[0.0, 3.0, f64::NAN, -1.0]);
        let p = implied(&table);
        assert_eq!((p[0], p[2], p[3]), (0.0, 0.0, 0.0));
        assert!((p[1] - 1.0).abs() < 1e-6);
        let p = implied(&alias_table(&[0.0, 0.0]));
        assert_eq!(p, vec![0.5, 0.5]);
    }
}
