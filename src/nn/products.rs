//! The products of a layer's weights with three vectors at once, for the second-order
//! pass of [`Mlp::forward_second_along`](super::Mlp::forward_second_along): the value, the
//! first and the second derivative of the layer's input.
//!
//! Each row of weights is read once for its three products, two rows at a time so that six
//! running sums hide the adder's latency, in AVX2 registers where the processor has them
//! (chosen at run time; a release build targets plain x86-64, two floats a register).
//! Every product is summed in the order of [`dot`]: four running sums over the
//! row in chunks of four, then `(s₀ + s₁) + (s₂ + s₃) + tail`, without fused
//! multiply-adds, so the results are [`dot`]'s to the bit on every processor.

/// `Σ aᵢ bᵢ` in four running sums, which the compiler can keep in one vector register.
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [0.0; 4];
    let (a4, a_rest) = a.split_at(a.len() / 4 * 4);
    let (b4, b_rest) = b.split_at(a4.len());
    for (x, y) in a4.chunks_exact(4).zip(b4.chunks_exact(4)) {
        for k in 0..4 {
            sums[k] += x[k] * y[k];
        }
    }
    finish(sums, a_rest, b_rest)
}

/// The four running sums and the products of the tail, added in [`dot`]'s order.
#[inline(always)]
fn finish(sums: [f64; 4], a_rest: &[f64], b_rest: &[f64]) -> f64 {
    let tail: f64 = a_rest.iter().zip(b_rest).map(|(x, y)| x * y).sum();
    (sums[0] + sums[1]) + (sums[2] + sums[3]) + tail
}

/// One row's three products, each by [`dot`]: the rows the wide code leaves over, and every
/// row where there is no wide unit.
fn row_products(row: &[f64], vectors: [&[f64]; 3]) -> [f64; 3] {
    vectors.map(|vector| dot(row, vector))
}

/// For every row `w` of `weight` (row-major, `vectors[k].len()` columns), the three
/// products `w · vectors[k]`, written to `out[row]`.
pub(super) fn three_products(weight: &[f64], vectors: [&[f64]; 3], out: &mut [[f64; 3]]) {
    let width = vectors[0].len();
    if width == 0 {
        out.fill([0.0; 3]);
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: compiled for AVX2, which the processor was just found to have.
        return unsafe { avx2::three_products(weight, vectors, out) };
    }
    for (row, products) in weight.chunks_exact(width).zip(out) {
        *products = row_products(row, vectors);
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! The products on AVX2: lane `k` of a register holds running sum `k` of
    //! [`dot`](super::dot), added to by separate multiplies and adds, as it does.
    use super::{finish, row_products};
    use std::arch::x86_64::*;

    /// Rows read together: six running registers, and the three vectors' chunks loaded
    /// once for both.
    const ROWS: usize = 2;

    #[target_feature(enable = "avx2")]
    pub(super) fn three_products(weight: &[f64], vectors: [&[f64]; 3], out: &mut [[f64; 3]]) {
        let width = vectors[0].len();
        let whole = width / 4 * 4;
        let weight_groups = weight.chunks_exact(width * ROWS);
        let weight_left = weight_groups.remainder();
        let mut out_groups = out.chunks_exact_mut(ROWS);
        for (group, products) in weight_groups.zip(&mut out_groups) {
            let (first_row, second_row) = group.split_at(width);
            let mut sums = [[_mm256_setzero_pd(); 3]; ROWS];
            for c in (0..whole).step_by(4) {
                let rows = [chunk(first_row, c), chunk(second_row, c)];
                for (v, vector) in vectors.iter().enumerate() {
                    let x = chunk(vector, c);
                    for (row_sums, &row) in sums.iter_mut().zip(&rows) {
                        row_sums[v] = _mm256_add_pd(row_sums[v], _mm256_mul_pd(row, x));
                    }
                }
            }
            for ((row_sums, row), row_products) in
                sums.iter().zip([first_row, second_row]).zip(products)
            {
                for (v, vector) in vectors.iter().enumerate() {
                    let mut lanes = [0.0; 4];
                    // SAFETY: `lanes` holds the four floats an unaligned store writes.
                    unsafe { _mm256_storeu_pd(lanes.as_mut_ptr(), row_sums[v]) };
                    row_products[v] = finish(lanes, &row[whole..], &vector[whole..]);
                }
            }
        }
        for (row, products) in weight_left
            .chunks_exact(width)
            .zip(out_groups.into_remainder())
        {
            *products = row_products(row, vectors);
        }
    }

    /// Floats `c..c + 4` of `values`.
    #[inline(always)]
    fn chunk(values: &[f64], c: usize) -> __m256d {
        let four = &values[c..c + 4];
        // SAFETY: `four` holds the four floats an unaligned load reads.
        unsafe { _mm256_loadu_pd(four.as_ptr()) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows in whole groups and a remainder, widths with and without a tail: every product
    /// is `dot`'s to the bit.
    #[test]
    fn the_products_are_dots_to_the_bit() {
        let mut state = 0x2545_f491_4f6c_dd1d_u64;
        let mut draw = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for (rows, width) in [(128, 128), (7, 13), (5, 2), (3, 4), (9, 1)] {
            let weight: Vec<f64> = (0..rows * width).map(|_| draw()).collect();
            let vectors: [Vec<f64>; 3] =
                std::array::from_fn(|_| (0..width).map(|_| draw() * 1e3).collect());
            let mut out = vec![[f64::NAN; 3]; rows];
            three_products(&weight, [&vectors[0], &vectors[1], &vectors[2]], &mut out);
            for (row, products) in weight.chunks_exact(width).zip(&out) {
                for (v, vector) in vectors.iter().enumerate() {
                    assert_eq!(products[v].to_bits(), dot(row, vector).to_bits());
                }
            }
        }
    }
}
