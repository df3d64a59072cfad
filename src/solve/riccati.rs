//! The Newton step of an optimal-control problem by a Riccati recursion over its stages,
//! with the inertia test that tells whether the step is a descent step.
//!
//! The equality-constrained quadratic problem of `N` stages, each with a state `z_k`
//! (fixed at `z_0 = 0`) and a control `v_k`:
//!
//! ```text
//! minimise  Σ_k ½ [z_k; v_k]ᵀ H_k [z_k; v_k] + q_kᵀ [z_k; v_k]  +  ½ z_Nᵀ H_N z_N + q_Nᵀ z_N
//! subject to  z_{k+1} = A_k z_k + B_k v_k + c_k,   z_0 = 0,
//! ```
//!
//! is solved backwards (`P_N = H_N`; per stage `R̂ = R + BᵀPB`, `Ŝ = S + BᵀPA`,
//! `Q̂ = Q + AᵀPA`, a Cholesky factorisation of `R̂`, the gain `K = −R̂⁻¹Ŝ` and
//! `P = Q̂ + ŜᵀK`), then forwards for the step. Its KKT matrix has the inertia of a
//! minimum — as many positive eigenvalues as variables, as many negative ones as
//! constraints — exactly when every `R̂_k` is positive definite, so the Cholesky
//! factorisations are the inertia test: `H_k` and `H_N` may be indefinite (an indefinite
//! terminal cost is fine) as long as the reduced Hessian is not. A failed factorisation
//! names the stage ([`Riccati::factor`], with a uniform shift `δ` the caller chooses), or
//! the failing stages are corrected one by one on the way ([`Riccati::factor_corrected`]:
//! inertia correction on the controls of the stages that need it, by what they need).
//!
//! [`Riccati::factor`] depends on the matrices only, [`Riccati::solve`] on the vectors
//! `q_k` and `c_k`: a second right-hand side (a second-order correction, a corrector step)
//! reuses the factorisation. Cost `O(N (n_z + n_v)³)` per factorisation; every matrix and
//! vector of both passes lives in the workspace [`Riccati::new`] sizes, so that neither
//! allocates, but for nalgebra's product `P_{k+1} A_k` where both stages have more than
//! five states (and `P_{k+1} B_k` where stage `k` also has more than five controls):
//! matrixmultiply packs its operands in a buffer of its own. A stage-wise correction
//! allocates too (its eigenvalues), and so does the Cholesky storage after a failed
//! factorisation.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

/// One stage `k < N` of the problem (see the [module documentation](self)).
#[derive(Debug, Clone, PartialEq)]
pub struct Stage {
    /// `H_k`, `(n_z + n_v)²`, ordered `[z_k; v_k]`.
    pub h: DMatrix<f64>,
    /// `q_k`, `n_z + n_v`.
    pub q: DVector<f64>,
    /// `A_k`, `n_z(k+1) × n_z(k)`.
    pub a: DMatrix<f64>,
    /// `B_k`, `n_z(k+1) × n_v(k)`.
    pub b: DMatrix<f64>,
    /// `c_k`, `n_z(k+1)`.
    pub c: DVector<f64>,
    /// The diagonal that inertia correction adds `δ` times to `H_k`, `n_z + n_v` (zero
    /// where a component is no variable of its own, such as a copy of an earlier control).
    pub shift: DVector<f64>,
    nz: usize,
}

impl Stage {
    /// A stage of `nz` states, `nv` controls and `nz_next` states at the next stage, all
    /// matrices zero and the shift one.
    pub fn zeros(nz: usize, nv: usize, nz_next: usize) -> Stage {
        Stage {
            h: DMatrix::zeros(nz + nv, nz + nv),
            q: DVector::zeros(nz + nv),
            a: DMatrix::zeros(nz_next, nz),
            b: DMatrix::zeros(nz_next, nv),
            c: DVector::zeros(nz_next),
            shift: DVector::from_element(nz + nv, 1.0),
            nz,
        }
    }

    /// States `n_z` of this stage.
    pub fn nz(&self) -> usize {
        self.nz
    }

    /// Controls `n_v` of this stage.
    pub fn nv(&self) -> usize {
        self.h.nrows() - self.nz
    }
}

/// The last stage: a cost on `z_N` only.
#[derive(Debug, Clone, PartialEq)]
pub struct Terminal {
    /// `H_N`, `n_z(N)²`.
    pub h: DMatrix<f64>,
    /// `q_N`.
    pub q: DVector<f64>,
    /// The inertia-correction diagonal of `H_N`.
    pub shift: DVector<f64>,
}

impl Terminal {
    /// A zero terminal cost on `nz` states, with the shift one.
    pub fn zeros(nz: usize) -> Terminal {
        Terminal {
            h: DMatrix::zeros(nz, nz),
            q: DVector::zeros(nz),
            shift: DVector::from_element(nz, 1.0),
        }
    }
}

/// The reduced Hessian of a stage is not positive definite: the KKT matrix has the wrong
/// inertia (with the `δ` it was factorised with).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("the reduced Hessian of stage {stage} is not positive definite")]
pub struct WrongInertia {
    /// The stage whose `R̂_k` failed its Cholesky factorisation.
    pub stage: usize,
}

/// Per-stage factorisation data.
#[derive(Debug, Clone)]
struct Factor {
    /// `R̂_k`'s Cholesky factor (its storage is reused by the next factorisation).
    chol: Option<Cholesky<f64, Dyn>>,
    /// `K_k = −R̂⁻¹Ŝ`.
    gain: DMatrix<f64>,
    /// `P_k`.
    p: DMatrix<f64>,
    // Workspaces of the factorisation.
    pa: DMatrix<f64>,
    pb: DMatrix<f64>,
    /// `R̂_k`, `Ŝ_k`, `Q̂_k`.
    r_hat: DMatrix<f64>,
    s_hat: DMatrix<f64>,
    q_hat: DMatrix<f64>,
    // Workspaces of the solve: `e = P c + p` of the next stage, `r̂` and `q̂`.
    e: DVector<f64>,
    r_vec: DVector<f64>,
    q_vec: DVector<f64>,
}

/// A stage-structured quadratic problem, its factorisation and its solution.
#[derive(Debug, Clone)]
pub struct Riccati {
    /// Stages `0 … N − 1`.
    pub stages: Vec<Stage>,
    /// The terminal stage `N`.
    pub terminal: Terminal,
    factors: Vec<Factor>,
    p_terminal: DMatrix<f64>,
    /// The `δ_k` of the last factorisation.
    deltas: Vec<f64>,
    factored: bool,
    /// The step: `z_k`, `k = 0 … N`.
    pub z: Vec<DVector<f64>>,
    /// The step: `v_k`, `k = 0 … N − 1`.
    pub v: Vec<DVector<f64>>,
    /// The multipliers of the dynamics of stage `k` (the gradient of the cost to go at
    /// `z_{k+1}`), `k = 0 … N − 1`: in the Lagrangian `… + μ_kᵀ (A_k z_k + B_k v_k + c_k
    /// − z_{k+1})`.
    pub mu: Vec<DVector<f64>>,
    /// `p_k`, the cost to go's gradient at `z_k = 0`.
    p_vec: Vec<DVector<f64>>,
    feedforward: Vec<DVector<f64>>,
}

impl Riccati {
    /// A problem of the given stages and terminal cost; the dimensions must chain
    /// (`A_k` maps `z_k` to `z_{k+1}`), which [`Riccati::is_consistent`] checks.
    pub fn new(stages: Vec<Stage>, terminal: Terminal) -> Riccati {
        let factors = stages
            .iter()
            .map(|s| Factor {
                chol: None,
                gain: DMatrix::zeros(s.nv(), s.nz()),
                p: DMatrix::zeros(s.nz(), s.nz()),
                pa: DMatrix::zeros(s.a.nrows(), s.nz()),
                pb: DMatrix::zeros(s.b.nrows(), s.nv()),
                r_hat: DMatrix::zeros(s.nv(), s.nv()),
                s_hat: DMatrix::zeros(s.nv(), s.nz()),
                q_hat: DMatrix::zeros(s.nz(), s.nz()),
                e: DVector::zeros(s.a.nrows()),
                r_vec: DVector::zeros(s.nv()),
                q_vec: DVector::zeros(s.nz()),
            })
            .collect();
        let nz_n = terminal.h.nrows();
        let n_stages = stages.len();
        let z = stages
            .iter()
            .map(|s| DVector::zeros(s.nz()))
            .chain(std::iter::once(DVector::zeros(nz_n)))
            .collect();
        let v = stages.iter().map(|s| DVector::zeros(s.nv())).collect();
        let mu = stages.iter().map(|s| DVector::zeros(s.a.nrows())).collect();
        let p_vec = stages
            .iter()
            .map(|s| DVector::zeros(s.nz()))
            .chain(std::iter::once(DVector::zeros(nz_n)))
            .collect();
        let feedforward = stages.iter().map(|s| DVector::zeros(s.nv())).collect();
        Riccati {
            stages,
            terminal,
            factors,
            p_terminal: DMatrix::zeros(nz_n, nz_n),
            deltas: vec![0.0; n_stages],
            factored: false,
            z,
            v,
            mu,
            p_vec,
            feedforward,
        }
    }

    /// Steps `N`.
    pub fn horizon(&self) -> usize {
        self.stages.len()
    }

    /// Whether every matrix has the size its neighbours imply.
    pub fn is_consistent(&self) -> bool {
        let n = self.stages.len();
        (0..n).all(|k| {
            let s = &self.stages[k];
            let next = if k + 1 < n {
                self.stages[k + 1].nz()
            } else {
                self.terminal.h.nrows()
            };
            let size = s.nz() + s.nv();
            s.h.ncols() == size
                && s.q.len() == size
                && s.shift.len() == size
                && s.a.shape() == (next, s.nz())
                && s.b.shape() == (next, s.nv())
                && s.c.len() == next
        }) && self.terminal.h.is_square()
            && self.terminal.q.len() == self.terminal.h.nrows()
            && self.terminal.shift.len() == self.terminal.h.nrows()
    }

    /// Factorises with `δ · shift` added to every `H_k` and to `H_N`. Fails at the first
    /// stage (going backwards) whose reduced Hessian `R̂_k` is not positive definite.
    pub fn factor(&mut self, delta: f64) -> Result<(), WrongInertia> {
        self.factor_from(delta, 0)
    }

    /// Like [`Riccati::factor`], with `δ · shift` added only to the stages from `first` on
    /// (and to `H_N`): the stages a failed factorisation named, and those after them.
    pub fn factor_from(&mut self, delta: f64, first: usize) -> Result<(), WrongInertia> {
        self.factor_stages(delta, first, false).map(|_| ())
    }

    /// Factorises with the least correction stage by stage: where a reduced Hessian `R̂_k`
    /// is not positive definite, `δ_k` times the shift of stage `k`'s controls is added to
    /// it, `δ_k` just above the magnitude of `R̂_k`'s most negative eigenvalue in the
    /// shift's metric, and nothing is added to any state or to any other stage. Adding to
    /// `R̂_k` is adding to `H_k`'s control block (`R̂_k` is linear in it), so the step is
    /// the Newton step of a Hessian corrected only where its inertia was wrong, and only
    /// in the stage's own controls: a flat direction elsewhere (a state the terminal cost
    /// barely curves) keeps its exact curvature instead of a shift sized for the worst
    /// stage. Returns how many stages were corrected; [`Riccati::corrections`] has the
    /// `δ_k`. Fails where a control has no shift, where the numbers are not finite, and
    /// where a stage would need more than [`MAX_STAGE_CORRECTION`]: over a long horizon
    /// the negative curvature of uncorrected states can pile up in the cost to go (a
    /// 1920-stage season reached entries of 1e150), and then one shift of the whole
    /// horizon ([`Riccati::factor_from`]) is the better correction.
    pub fn factor_corrected(&mut self) -> Result<usize, WrongInertia> {
        self.factor_stages(0.0, 0, true)
    }

    /// The `δ_k` of the last factorisation, per stage (the uniform `δ` of
    /// [`Riccati::factor_from`] on its stages, zero on the others).
    pub fn corrections(&self) -> &[f64] {
        &self.deltas
    }

    fn factor_stages(
        &mut self,
        delta: f64,
        first: usize,
        correct: bool,
    ) -> Result<usize, WrongInertia> {
        self.factored = false;
        let t = &self.terminal;
        self.p_terminal.copy_from(&t.h);
        for i in 0..t.shift.len() {
            self.p_terminal[(i, i)] += delta * t.shift[i];
        }
        let mut corrected = 0;
        for k in (0..self.stages.len()).rev() {
            let (done, rest) = self.factors.split_at_mut(k + 1);
            let next_p = rest.first().map_or(&self.p_terminal, |f| &f.p);
            let f = &mut done[k];
            let s = &self.stages[k];
            let (nz, nv) = (s.nz(), s.nv());
            let delta = if k >= first { delta } else { 0.0 };
            // PA, PB with the next stage's P.
            next_p.mul_to(&s.a, &mut f.pa);
            next_p.mul_to(&s.b, &mut f.pb);
            f.r_hat.copy_from(&s.h.view((nz, nz), (nv, nv)));
            f.r_hat.gemm_tr(1.0, &s.b, &f.pb, 1.0);
            f.s_hat.copy_from(&s.h.view((nz, 0), (nv, nz)));
            f.s_hat.gemm_tr(1.0, &s.b, &f.pa, 1.0);
            f.q_hat.copy_from(&s.h.view((0, 0), (nz, nz)));
            f.q_hat.gemm_tr(1.0, &s.a, &f.pa, 1.0);
            for i in 0..nz {
                f.q_hat[(i, i)] += delta * s.shift[i];
            }
            for i in 0..nv {
                f.r_hat[(i, i)] += delta * s.shift[nz + i];
            }
            self.deltas[k] = delta;
            // The last factor's storage, else a new one (the first time, or after a
            // factorisation that failed and took its storage with it).
            let storage = f
                .chol
                .take()
                .map_or_else(|| DMatrix::zeros(nv, nv), Cholesky::unpack_dirty);
            let chol = match positive_definite(&f.r_hat, storage) {
                Some(chol) => chol,
                None if correct => {
                    let r_hat = &f.r_hat;
                    let shift = s.shift.rows(nz, nv);
                    let least = least_correction(r_hat, shift.as_slice())
                        .ok_or(WrongInertia { stage: k })?;
                    // Rounding may leave the first try short: quadrupled until it holds
                    // (twenty times at most).
                    let held = (0..20).map(|i| least * 4f64.powi(i)).find_map(|delta_k| {
                        let mut shifted = r_hat.clone();
                        for i in 0..nv {
                            shifted[(i, i)] += delta_k * shift[i];
                        }
                        positive_definite(&shifted, shifted.clone()).map(|chol| (delta_k, chol))
                    });
                    let (delta_k, chol) = held
                        .filter(|(d, _)| *d <= MAX_STAGE_CORRECTION)
                        .ok_or(WrongInertia { stage: k })?;
                    self.deltas[k] = delta_k;
                    corrected += 1;
                    chol
                }
                None => return Err(WrongInertia { stage: k }),
            };
            f.gain.copy_from(&f.s_hat);
            chol.solve_mut(&mut f.gain);
            f.gain.neg_mut();
            // P = Q̂ + Ŝᵀ K, symmetrised.
            f.p.copy_from(&f.q_hat);
            f.p.gemm_tr(1.0, &f.s_hat, &f.gain, 1.0);
            for i in 0..nz {
                for j in 0..i {
                    let m = 0.5 * (f.p[(i, j)] + f.p[(j, i)]);
                    f.p[(i, j)] = m;
                    f.p[(j, i)] = m;
                }
            }
            f.chol = Some(chol);
        }
        self.factored = true;
        Ok(corrected)
    }

    /// Solves for the current `q_k`, `c_k` with the last factorisation: fills `z`, `v`
    /// and `mu`. Returns `false` when there is no valid factorisation.
    pub fn solve(&mut self) -> bool {
        if !self.factored {
            return false;
        }
        let n = self.stages.len();
        self.p_vec[n].copy_from(&self.terminal.q);
        for k in (0..n).rev() {
            let s = &self.stages[k];
            let (done, rest) = self.factors.split_at_mut(k + 1);
            let next_p = rest.first().map_or(&self.p_terminal, |f| &f.p);
            let f = &mut done[k];
            let (nz, nv) = (s.nz(), s.nv());
            // e = P c + p (next stage).
            next_p.mul_to(&s.c, &mut f.e);
            f.e += &self.p_vec[k + 1];
            // r̂ = q_v + Bᵀ e, q̂ = q_z + Aᵀ e.
            f.r_vec.copy_from(&s.q.rows(nz, nv));
            f.r_vec.gemv_tr(1.0, &s.b, &f.e, 1.0);
            f.q_vec.copy_from(&s.q.rows(0, nz));
            f.q_vec.gemv_tr(1.0, &s.a, &f.e, 1.0);
            let Some(chol) = f.chol.as_ref() else {
                return false;
            };
            let ff = &mut self.feedforward[k];
            ff.copy_from(&f.r_vec);
            chol.solve_mut(ff);
            ff.neg_mut();
            // p = q̂ + Kᵀ r̂.
            f.q_vec.gemv_tr(1.0, &f.gain, &f.r_vec, 1.0);
            self.p_vec[k].copy_from(&f.q_vec);
        }
        self.z[0].fill(0.0);
        for k in 0..n {
            let s = &self.stages[k];
            let f = &self.factors[k];
            let (done, rest) = self.z.split_at_mut(k + 1);
            let (z, z_next) = (&done[k], &mut rest[0]);
            // v = K z + feedforward.
            f.gain.mul_to(z, &mut self.v[k]);
            self.v[k] += &self.feedforward[k];
            // z⁺ = c + A z + B v.
            s.a.mul_to(z, z_next);
            *z_next += &s.c;
            z_next.gemv(1.0, &s.b, &self.v[k], 1.0);
            let next_p = if k + 1 < n {
                &self.factors[k + 1].p
            } else {
                &self.p_terminal
            };
            // μ = P z⁺ + p (next stage).
            next_p.mul_to(z_next, &mut self.mu[k]);
            self.mu[k] += &self.p_vec[k + 1];
        }
        true
    }
}

/// The Cholesky factor of `m`, computed in `storage` (a matrix of `m`'s size, which the
/// factor keeps), if `m` is positive definite; `None` for any other. A pivot far below its
/// own row's diagonal is a direction lost in rounding (the row nearly a combination of the
/// ones before it): treated as not positive definite, like fatrop's pivot test, but
/// relative to each row, so that the test does not depend on the units of the variables (a
/// diagonal scaling of the matrix scales each pivot and its diagonal alike).
fn positive_definite(m: &DMatrix<f64>, mut storage: DMatrix<f64>) -> Option<Cholesky<f64, Dyn>> {
    let n = m.nrows();
    storage.copy_from(m);
    let chol = Cholesky::new(storage)?;
    let l = chol.l_dirty();
    if (0..n).any(|i| l[(i, i)] * l[(i, i)] <= 1e-14 * m[(i, i)]) {
        return None;
    }
    Some(chol)
}

/// The largest stage correction [`Riccati::factor_corrected`] makes (in the shift's
/// metric, where a control's range is one).
pub const MAX_STAGE_CORRECTION: f64 = 1e8;

/// The `δ` that lifts `R̂ + δ · diag(shift)` just above positive definiteness: the most
/// negative eigenvalue `λ` of `D^{-1/2} R̂ D^{-1/2}` (`D = diag(shift)`) becomes
/// `MARGIN · |λ|` (or a small fraction of the largest eigenvalue where `λ` is near zero).
/// `None` where a shift is not positive or an entry is not finite.
fn least_correction(r_hat: &DMatrix<f64>, shift: &[f64]) -> Option<f64> {
    const MARGIN: f64 = 0.2;
    if shift.iter().any(|&d| !(d > 0.0 && d.is_finite())) || !r_hat.iter().all(|v| v.is_finite()) {
        return None;
    }
    let n = r_hat.nrows();
    let scaled = DMatrix::from_fn(n, n, |i, j| r_hat[(i, j)] / (shift[i] * shift[j]).sqrt());
    let eigenvalues = scaled.symmetric_eigenvalues();
    if !eigenvalues.iter().all(|l| l.is_finite()) {
        return None;
    }
    let lowest = eigenvalues.min();
    let margin = (MARGIN * lowest.abs())
        .max(1e-12 * eigenvalues.amax())
        .max(f64::MIN_POSITIVE);
    Some((margin - lowest).max(margin))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One stage with a scalar state and control: by hand.
    #[test]
    fn one_stage_by_hand() {
        // min ½ v² + ½ z₁² + q v  s.t. z₁ = 2 v + 1  →  v + 2 (2v + 1) + q = 0.
        let mut stage = Stage::zeros(0, 1, 1);
        stage.h[(0, 0)] = 1.0;
        stage.q[0] = 3.0;
        stage.b[(0, 0)] = 2.0;
        stage.c[0] = 1.0;
        let mut terminal = Terminal::zeros(1);
        terminal.h[(0, 0)] = 1.0;
        let mut r = Riccati::new(vec![stage], terminal);
        assert!(r.is_consistent());
        r.factor(0.0).unwrap();
        assert!(r.solve());
        let v = -(3.0 + 2.0) / 5.0;
        assert!((r.v[0][0] - v).abs() < 1e-15);
        assert!((r.z[1][0] - (2.0 * v + 1.0)).abs() < 1e-15);
        // μ = ∂(½ z²)/∂z at z₁.
        assert!((r.mu[0][0] - r.z[1][0]).abs() < 1e-15);
    }

    /// A negative control curvature not cured by the dynamics is the wrong inertia; the
    /// shift cures it.
    #[test]
    fn negative_reduced_curvature_is_reported() {
        let mut stage = Stage::zeros(0, 1, 1);
        stage.h[(0, 0)] = -3.0;
        stage.b[(0, 0)] = 1.0;
        let mut terminal = Terminal::zeros(1);
        terminal.h[(0, 0)] = 1.0;
        let mut r = Riccati::new(vec![stage], terminal);
        assert_eq!(r.factor(0.0), Err(WrongInertia { stage: 0 }));
        assert!(!r.solve());
        // With P = 1 + δ and R = −3 + δ: R̂ = −2 + 2δ > 0 from δ > 1.
        assert!(r.factor(0.9).is_err());
        assert!(r.factor(1.1).is_ok());
    }

    /// The pivot test does not depend on units: a well-conditioned positive definite
    /// matrix in badly mixed units (a diagonal scaling of 1e-6 … 1e6) is positive definite,
    /// a singular one in good units is not.
    #[test]
    fn the_pivot_test_is_independent_of_units() {
        let m = DMatrix::from_row_slice(3, 3, &[2.0, 1.0, 0.0, 1.0, 2.0, 1.0, 0.0, 1.0, 2.0]);
        let d = DMatrix::from_diagonal(&DVector::from_vec(vec![1e-6, 1.0, 1e6]));
        let scaled = &d * &m * &d;
        assert!(positive_definite(&scaled, scaled.clone()).is_some());
        let singular = DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0 + 1e-17]);
        assert!(positive_definite(&singular, singular.clone()).is_none());
    }

    /// Negative state curvature under unstable dynamics piles up in the cost to go (×4
    /// per stage here): over a long horizon the stage-wise correction would need more
    /// than its cap and says so, and one shift of the whole horizon still cures it.
    #[test]
    fn curvature_piled_up_over_a_long_horizon_is_left_to_the_whole_horizon_shift() {
        let stages: Vec<Stage> = (0..40)
            .map(|_| {
                let mut s = Stage::zeros(1, 1, 1);
                s.h[(0, 0)] = -1.0;
                s.h[(1, 1)] = 1.0;
                s.a[(0, 0)] = 2.0;
                s.b[(0, 0)] = 1e-3;
                s
            })
            .collect();
        let mut terminal = Terminal::zeros(1);
        terminal.h[(0, 0)] = -1.0;
        let mut r = Riccati::new(stages, terminal);
        let failure = r
            .factor_corrected()
            .expect_err("the cost to go reaches 4^40");
        assert!(failure.stage < 39, "{failure:?}");
        assert!(r.factor(2.0).is_ok());
        assert!(r.solve());
    }
}
