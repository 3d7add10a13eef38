//! Principal component analysis of stacked training vectors (thesis §3.5: "simple principal
//! component analysis provided the best results"), by the symmetric eigendecomposition of the
//! smaller of the covariance and Gram matrices (derma-core's numerics).

use derma_core::numerics::{dense::symmetric_eigen, Matrix};
use serde::{Deserialize, Serialize};

/// A PCA basis: the mean and orthonormal components, strongest first.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Pca {
    /// The mean of the data (dimension d).
    pub mean: Vec<f64>,
    /// Components (each of dimension d, unit length), by decreasing variance.
    pub components: Vec<Vec<f64>>,
    /// Variance along each component.
    pub variances: Vec<f64>,
    /// Total variance of the data about its mean.
    pub total_variance: f64,
}

impl Pca {
    /// Fits up to `k` components to `rows` (n vectors of dimension d; n ≥ 2).
    pub fn fit(rows: &[Vec<f64>], k: usize) -> crate::Result<Pca> {
        let n = rows.len();
        if n < 2 {
            return Err(derma_core::Invalid::new(
                "frames for principal components",
                "at least 2",
                n,
            )
            .into());
        }
        let d = rows[0].len();
        let mut mean = vec![0.0; d];
        for r in rows {
            for (m, v) in mean.iter_mut().zip(r) {
                *m += v / n as f64;
            }
        }
        let centred: Vec<Vec<f64>> = rows
            .iter()
            .map(|r| r.iter().zip(&mean).map(|(v, m)| v - m).collect())
            .collect();
        let total_variance = centred
            .iter()
            .map(|r| r.iter().map(|v| v * v).sum::<f64>())
            .sum::<f64>()
            / n as f64;
        let k = k.min(d).min(n - 1).max(1);
        // The Gram matrix (n × n) when there are fewer frames than dimensions, else the
        // covariance (d × d); both share the non-zero spectrum.
        let (values, vectors): (Vec<f64>, Vec<Vec<f64>>) = if n < d {
            // Rows of the upper triangle in parallel (each entry one dot product, the same bits
            // at any thread count), mirrored.
            use rayon::prelude::*;
            let upper: Vec<Vec<f64>> = (0..n)
                .into_par_iter()
                .map(|i| {
                    (i..n)
                        .map(|j| dot(&centred[i], &centred[j]) / n as f64)
                        .collect()
                })
                .collect();
            let g = Matrix::from_fn(n, n, |i, j| {
                let (a, b) = if i <= j { (i, j) } else { (j, i) };
                upper[a][b - a]
            });
            let e = symmetric_eigen(&g)?;
            (0..k)
                .map(|c| {
                    let col = n - 1 - c;
                    let lambda = e.values[col].max(0.0);
                    let mut v = vec![0.0; d];
                    for i in 0..n {
                        let w = e.vectors[(i, col)];
                        for (vj, xj) in v.iter_mut().zip(&centred[i]) {
                            *vj += w * xj;
                        }
                    }
                    normalise(&mut v);
                    (lambda, v)
                })
                .unzip()
        } else {
            let mut c = Matrix::zeros(d, d);
            for r in &centred {
                for i in 0..d {
                    for j in 0..=i {
                        c[(i, j)] += r[i] * r[j] / n as f64;
                    }
                }
            }
            let e = symmetric_eigen(&c)?;
            (0..k)
                .map(|c| {
                    let col = d - 1 - c;
                    let v: Vec<f64> = (0..d).map(|i| e.vectors[(i, col)]).collect();
                    (e.values[col].max(0.0), v)
                })
                .unzip()
        };
        // Components without variance (fewer distinct frames than asked for) are dropped; the
        // rest are re-orthogonalised (Gram–Schmidt) against rounding, and given a deterministic
        // sign: the largest-magnitude entry of each component is positive.
        let mut components: Vec<Vec<f64>> = Vec::new();
        let mut variances = Vec::new();
        for (lambda, mut v) in values.into_iter().zip(vectors) {
            if lambda <= 1e-12 * total_variance.max(1e-300) {
                continue;
            }
            for c in &components {
                let d = dot(&v, c);
                v.iter_mut().zip(c).for_each(|(x, y)| *x -= d * y);
            }
            if dot(&v, &v) < 1e-12 {
                continue;
            }
            normalise(&mut v);
            let big = v
                .iter()
                .copied()
                .fold(0.0f64, |a, x| if x.abs() > a.abs() { x } else { a });
            if big < 0.0 {
                v.iter_mut().for_each(|x| *x = -*x);
            }
            components.push(v);
            variances.push(lambda);
        }
        let values = variances;
        Ok(Pca {
            mean,
            components,
            variances: values,
            total_variance,
        })
    }

    /// Coefficients of `x` on the first `k` components.
    pub fn project(&self, x: &[f64], k: usize) -> Vec<f64> {
        self.components[..k.min(self.components.len())]
            .iter()
            .map(|c| {
                c.iter()
                    .zip(x.iter().zip(&self.mean))
                    .map(|(c, (x, m))| c * (x - m))
                    .sum()
            })
            .collect()
    }

    /// The vector with coefficients `e` (x = mean + Σ eᵢ cᵢ).
    pub fn reconstruct(&self, e: &[f64]) -> Vec<f64> {
        let mut x = self.mean.clone();
        for (c, w) in self.components.iter().zip(e) {
            for (xi, ci) in x.iter_mut().zip(c) {
                *xi += w * ci;
            }
        }
        x
    }

    /// Number of components kept.
    pub fn len(&self) -> usize {
        self.components.len()
    }

    /// True when no component is kept.
    pub fn is_empty(&self) -> bool {
        self.components.is_empty()
    }
}

pub(crate) use derma_core::numerics::dense::dot;

fn normalise(v: &mut [f64]) {
    let n = dot(v, v).sqrt();
    if n > 0.0 {
        v.iter_mut().for_each(|x| *x /= n);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(n: usize, d: usize) -> Vec<Vec<f64>> {
        // Two strong directions plus a weak third, deterministic.
        (0..n)
            .map(|i| {
                let a = (i as f64 * 0.37).sin() * 3.0;
                let b = (i as f64 * 1.13).cos() * 1.5;
                let c = (i as f64 * 2.71).sin() * 0.1;
                (0..d)
                    .map(|j| {
                        a * (j as f64 * 0.3).cos()
                            + b * (j as f64 * 0.7).sin()
                            + c * (j % 3) as f64
                            + 2.0
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn components_are_orthonormal_and_explain_the_variance() {
        for (n, d) in [(40, 10), (8, 30)] {
            let x = data(n, d);
            let p = Pca::fit(&x, 3).unwrap();
            for i in 0..3 {
                for j in 0..3 {
                    let want = if i == j { 1.0 } else { 0.0 };
                    assert!((dot(&p.components[i], &p.components[j]) - want).abs() < 1e-9);
                }
            }
            assert!(p.variances.windows(2).all(|w| w[0] >= w[1]));
            // Three components capture every direction of this data.
            let explained: f64 = p.variances.iter().sum();
            assert!((explained - p.total_variance).abs() < 1e-6 * p.total_variance);
            for r in &x {
                let back = p.reconstruct(&p.project(r, 3));
                assert!(back.iter().zip(r).all(|(a, b)| (a - b).abs() < 1e-6));
            }
        }
    }
}
