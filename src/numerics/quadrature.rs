//! Gauss quadrature rules from the Golub–Welsch eigenvalue method (nodes are the eigenvalues of
//! the symmetric Jacobi matrix of the orthogonal polynomials; weights from the first components
//! of the eigenvectors).

use nalgebra::DMatrix;

/// Nodes and weights of an n-point rule, nodes ascending.
#[derive(Debug, Clone)]
pub struct Rule {
    /// Abscissae.
    pub nodes: Vec<f64>,
    /// Weights (sum to the integral of the weight function).
    pub weights: Vec<f64>,
}

fn golub_welsch(off_diagonal: impl Fn(usize) -> f64, n: usize, total_weight: f64) -> Rule {
    let mut jacobi = DMatrix::<f64>::zeros(n, n);
    for k in 1..n {
        let b = off_diagonal(k);
        jacobi[(k, k - 1)] = b;
        jacobi[(k - 1, k)] = b;
    }
    let eig = jacobi.symmetric_eigen();
    let mut pairs: Vec<(f64, f64)> = (0..n)
        .map(|k| {
            let v0 = eig.eigenvectors[(0, k)];
            (eig.eigenvalues[k], total_weight * v0 * v0)
        })
        .collect();
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0));
    Rule {
        nodes: pairs.iter().map(|p| p.0).collect(),
        weights: pairs.iter().map(|p| p.1).collect(),
    }
}

/// Gauss–Legendre rule on [a, b] (weight 1).
pub fn gauss_legendre(n: usize, a: f64, b: f64) -> Rule {
    let reference = golub_welsch(
        |k| {
            let k = k as f64;
            k / (4.0 * k * k - 1.0).sqrt()
        },
        n,
        2.0,
    );
    let (half, mid) = (0.5 * (b - a), 0.5 * (a + b));
    Rule {
        nodes: reference.nodes.iter().map(|x| mid + half * x).collect(),
        weights: reference.weights.iter().map(|w| half * w).collect(),
    }
}

/// Rule for the expectation over a standard normal variable: ∫ f(z) φ(z) dz ≈ Σ w f(z)
/// (probabilists' Gauss–Hermite; weights sum to 1).
pub fn gauss_hermite_normal(n: usize) -> Rule {
    golub_welsch(|k| (k as f64).sqrt(), n, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legendre_integrates_polynomials_exactly() {
        let rule = gauss_legendre(8, 0.0, 2.0);
        for p in 0..16 {
            let quad: f64 = rule
                .nodes
                .iter()
                .zip(&rule.weights)
                .map(|(x, w)| w * x.powi(p))
                .sum();
            let exact = 2f64.powi(p + 1) / (p + 1) as f64;
            assert!((quad / exact - 1.0).abs() < 1e-13, "p={p}");
        }
    }

    #[test]
    fn hermite_reproduces_normal_moments() {
        let rule = gauss_hermite_normal(12);
        let moment = |p: i32| -> f64 {
            rule.nodes
                .iter()
                .zip(&rule.weights)
                .map(|(x, w)| w * x.powi(p))
                .sum()
        };
        assert!((moment(0) - 1.0).abs() < 1e-14);
        assert!(moment(1).abs() < 1e-14);
        assert!((moment(2) - 1.0).abs() < 1e-13);
        assert!((moment(4) - 3.0).abs() < 1e-12);
        assert!((moment(6) - 15.0).abs() < 1e-11);
        // E[e^{σZ}] = e^{σ²/2}: the log-normal mean
        let sigma = 0.3;
        let m: f64 = rule
            .nodes
            .iter()
            .zip(&rule.weights)
            .map(|(z, w)| w * (sigma * z).exp())
            .sum();
        assert!((m - (0.5 * sigma * sigma).exp()).abs() < 1e-14);
    }
}
