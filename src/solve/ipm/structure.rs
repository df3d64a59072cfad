//! Where each variable, Jacobian entry and Hessian entry of a staged NLP goes in the
//! Riccati recursion's stages, and the assembly of the condensed Newton system there.
//!
//! Stage `k` of the recursion has the state `z_k = [x_k; copies]` and the control
//! `v_k = controls[k]`. The copies are the controls of stage `k − 1` that a row or a
//! Hessian entry of stage `k` also touches (the previous input of a rate limit): a copy
//! follows its original through the identity dynamics `copy_{k+1} = v_k[i]`, which is
//! exact for a Newton step, so stage `k`'s rows and entries stay inside stage `k`.

use super::super::error::SetupError;
use super::super::riccati::{Riccati, Stage, Terminal};
use crate::nlp::{Pattern, Stages};

/// Where one variable lives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Place {
    stage: usize,
    /// Index in `[z; v]` of its stage.
    local: usize,
    /// Index of its copy in `z` of the next stage, if it is carried.
    copy: Option<usize>,
}

/// A Jacobian entry of a dynamics row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum DynamicsEntry {
    /// The `1` on `x_{k+1}`.
    Next,
    /// Column `local` of `[A B]` of stage `stage`, row `row` (in `z_{k+1}`).
    Stage {
        stage: usize,
        row: usize,
        local: usize,
    },
}

/// The map of a staged NLP onto the Riccati stages; see the [module documentation](self).
#[derive(Debug, Clone)]
pub(crate) struct StageMap {
    places: Vec<Place>,
    nz: Vec<usize>,
    nv: Vec<usize>,
    /// Per constraint row: `Some((stage, index in z_{k+1}))` for a dynamics row.
    dynamics_rows: Vec<Option<(usize, usize)>>,
    /// Per Jacobian entry of a dynamics row.
    dynamics_entries: Vec<Option<DynamicsEntry>>,
    /// Per Jacobian entry of another row: `(home stage, local index)`.
    other_entries: Vec<Option<(usize, usize)>>,
    /// Per Hessian entry: `(stage, local row, local column)`.
    hessian_entries: Vec<(usize, usize, usize)>,
    /// Per non-dynamics row, its Jacobian entries `(entry index)` in pattern order.
    row_entries: Vec<Vec<usize>>,
    /// Per stage `k < N`: `(control local index in v_k, copy index in z_{k+1})`.
    carried: Vec<Vec<(usize, usize)>>,
}

/// The stage of every variable and row, as the problem declares them.
struct Owners {
    /// Owner stage of each variable.
    stage_of: Vec<usize>,
    is_control: Vec<bool>,
    /// Per row: `Some((stage, index in z_{k+1}))` for a dynamics row.
    dynamics_rows: Vec<Option<(usize, usize)>>,
}

impl Owners {
    fn of(stages: &Stages, n_vars: usize, n_cons: usize) -> Owners {
        let mut stage_of = vec![0; n_vars];
        let mut is_control = vec![false; n_vars];
        for (k, r) in stages.states.iter().enumerate() {
            for v in r.clone() {
                stage_of[v] = k;
            }
        }
        for (k, r) in stages.controls.iter().enumerate() {
            for v in r.clone() {
                stage_of[v] = k;
                is_control[v] = true;
            }
        }
        let mut dynamics_rows = vec![None; n_cons];
        for (k, rows) in stages.dynamics.iter().enumerate() {
            for (i, r) in rows.clone().enumerate() {
                dynamics_rows[r] = Some((k, i));
            }
        }
        Owners {
            stage_of,
            is_control,
            dynamics_rows,
        }
    }
}

/// How rows and Hessian entries couple the stages.
struct Couplings {
    /// Controls that share a row or a Hessian entry with the next stage.
    carried: Vec<bool>,
    /// Per row, its Jacobian entries (the `1` on `x_{k+1}` of a dynamics row left out).
    row_entries: Vec<Vec<usize>>,
    /// Per row, the stage it lives in.
    homes: Vec<usize>,
}

impl Couplings {
    /// The couplings of the patterns, or why they do not fit the stages: a row or entry
    /// may reach back one stage only, to a control, which is then carried.
    fn of(
        stages: &Stages,
        owners: &Owners,
        jacobian: &Pattern,
        hessian: &Pattern,
    ) -> Result<Couplings, SetupError> {
        let Owners {
            stage_of,
            is_control,
            dynamics_rows,
        } = owners;
        let n_cons = dynamics_rows.len();
        // Carried controls: those that share a row or a Hessian entry with a later stage.
        let mut carried = vec![false; stage_of.len()];
        let mut mark = |vars: &[usize], home: usize| -> Result<(), SetupError> {
            for &v in vars {
                let s = stage_of[v];
                if s + 1 == home && is_control[v] {
                    carried[v] = true;
                } else if s != home {
                    return Err(SetupError::NotStaged(format!(
                        "variable {v} of stage {s} is coupled with stage {home}"
                    )));
                }
            }
            Ok(())
        };
        let mut row_vars: Vec<Vec<usize>> = vec![Vec::new(); n_cons];
        let mut row_entries: Vec<Vec<usize>> = vec![Vec::new(); n_cons];
        for (e, (&r, &c)) in jacobian.rows.iter().zip(&jacobian.cols).enumerate() {
            if let Some((k, i)) = dynamics_rows[r] {
                if c == stages.states[k + 1].start + i {
                    continue;
                }
                if stage_of[c] > k {
                    return Err(SetupError::NotStaged(format!(
                        "dynamics row {r} has an entry on variable {c} of a later stage"
                    )));
                }
            }
            row_vars[r].push(c);
            row_entries[r].push(e);
        }
        let mut homes = vec![0; n_cons];
        for (r, vars) in row_vars.iter().enumerate() {
            let home = match dynamics_rows[r] {
                Some((k, _)) => k,
                None => vars.iter().map(|&v| stage_of[v]).max().unwrap_or(0),
            };
            homes[r] = home;
            mark(vars, home)?;
        }
        for (&r, &c) in hessian.rows.iter().zip(&hessian.cols) {
            let home = stage_of[r].max(stage_of[c]);
            mark(&[r, c], home)?;
        }
        Ok(Couplings {
            carried,
            row_entries,
            homes,
        })
    }
}

/// The local indices of every variable and the stages' sizes.
struct Places {
    places: Vec<Place>,
    nz: Vec<usize>,
    nv: Vec<usize>,
    /// Per stage `k < N`: `(control local index in v_k, copy index in z_{k+1})`.
    carried: Vec<Vec<(usize, usize)>>,
}

impl Places {
    /// Stage `k`'s states, then the copies of stage `k − 1`'s carried controls (`carried`
    /// per variable), then its controls.
    fn of(stages: &Stages, carried_flag: &[bool]) -> Places {
        let n = stages.horizon();
        let mut places = vec![
            Place {
                stage: 0,
                local: 0,
                copy: None
            };
            carried_flag.len()
        ];
        let mut nz = vec![0; n + 1];
        let mut nv = vec![0; n];
        let mut carried = vec![Vec::new(); n];
        for k in 0..=n {
            let states = stages.states[k].clone();
            for (i, v) in states.clone().enumerate() {
                places[v] = Place {
                    stage: k,
                    local: i,
                    copy: None,
                };
            }
            nz[k] = states.len();
            if k > 0 {
                for (i, v) in stages.controls[k - 1].clone().enumerate() {
                    if carried_flag[v] {
                        let copy = nz[k];
                        places[v].copy = Some(copy);
                        carried[k - 1].push((i, copy));
                        nz[k] += 1;
                    }
                }
            }
            if k < n {
                let controls = stages.controls[k].clone();
                for (i, v) in controls.clone().enumerate() {
                    places[v] = Place {
                        stage: k,
                        local: nz[k] + i,
                        copy: None,
                    };
                }
                nv[k] = controls.len();
            }
        }
        Places {
            places,
            nz,
            nv,
            carried,
        }
    }

    /// The local index of variable `v` in stage `home` (its copy where it is carried
    /// there).
    fn local_in(&self, v: usize, home: usize) -> usize {
        let p = self.places[v];
        if p.stage == home {
            p.local
        } else {
            p.copy.unwrap_or(p.local)
        }
    }
}

impl StageMap {
    /// The map of a problem with `stages`, its Jacobian and Hessian patterns and `n_cons`
    /// constraints.
    pub fn new(
        stages: &Stages,
        n_vars: usize,
        n_cons: usize,
        jacobian: &Pattern,
        hessian: &Pattern,
    ) -> Result<StageMap, SetupError> {
        if !stages.is_consistent(n_vars, n_cons) {
            return Err(SetupError::NotStaged(
                "the stage ranges do not cover the variables".into(),
            ));
        }
        let owners = Owners::of(stages, n_vars, n_cons);
        let couplings = Couplings::of(stages, &owners, jacobian, hessian)?;
        let places = Places::of(stages, &couplings.carried);
        let (dynamics_rows, homes) = (&owners.dynamics_rows, &couplings.homes);
        let mut dynamics_entries = vec![None; jacobian.len()];
        let mut other_entries = vec![None; jacobian.len()];
        for (e, (&r, &c)) in jacobian.rows.iter().zip(&jacobian.cols).enumerate() {
            match dynamics_rows[r] {
                Some((k, i)) if c == stages.states[k + 1].start + i => {
                    dynamics_entries[e] = Some(DynamicsEntry::Next);
                }
                Some((k, i)) => {
                    dynamics_entries[e] = Some(DynamicsEntry::Stage {
                        stage: k,
                        row: i,
                        local: places.local_in(c, k),
                    });
                }
                None => other_entries[e] = Some((homes[r], places.local_in(c, homes[r]))),
            }
        }
        let stage_of = &owners.stage_of;
        let hessian_entries = hessian
            .rows
            .iter()
            .zip(&hessian.cols)
            .map(|(&r, &c)| {
                let home = stage_of[r].max(stage_of[c]);
                (home, places.local_in(r, home), places.local_in(c, home))
            })
            .collect();
        let row_entries = couplings
            .row_entries
            .into_iter()
            .enumerate()
            .map(|(r, list)| {
                if dynamics_rows[r].is_some() {
                    Vec::new()
                } else {
                    list
                }
            })
            .collect();
        Ok(StageMap {
            places: places.places,
            nz: places.nz,
            nv: places.nv,
            dynamics_rows: owners.dynamics_rows,
            dynamics_entries,
            other_entries,
            hessian_entries,
            row_entries,
            carried: places.carried,
        })
    }

    /// Whether row `r` is a dynamics row.
    pub fn is_dynamics(&self, r: usize) -> bool {
        self.dynamics_rows[r].is_some()
    }

    /// A Riccati problem of the right sizes, the copies' dynamics set.
    pub fn riccati(&self) -> Riccati {
        let n = self.nv.len();
        let stages = (0..n)
            .map(|k| {
                let mut s = Stage::zeros(self.nz[k], self.nv[k], self.nz[k + 1]);
                s.shift.fill(0.0);
                for &(i, copy) in &self.carried[k] {
                    s.b[(copy, i)] = 1.0;
                }
                s
            })
            .collect();
        let mut terminal = Terminal::zeros(self.nz[n]);
        terminal.shift.fill(0.0);
        Riccati::new(stages, terminal)
    }

    /// Fills the matrices of `riccati`: the Hessian `hessian` (pattern values), the
    /// diagonal `diagonal` (per variable), `Σ_r J_rᵀ σ_r J_r` over the non-dynamics rows
    /// (`row_weight[r] = σ_r`), the dynamics' `A`, `B` from `jacobian`, and the
    /// inertia-correction diagonal `shift` (per variable).
    pub fn fill_matrices(
        &self,
        riccati: &mut Riccati,
        hessian: &[f64],
        diagonal: &[f64],
        jacobian: &[f64],
        row_weight: &[f64],
        shift: &[f64],
    ) {
        for (k, s) in riccati.stages.iter_mut().enumerate() {
            s.h.fill(0.0);
            s.a.fill(0.0);
            // The copies' identity rows of B stay; the state rows are filled below.
            let state_rows = self.nz[k + 1] - self.carried[k].len();
            s.b.rows_mut(0, state_rows).fill(0.0);
        }
        riccati.terminal.h.fill(0.0);
        let n = riccati.stages.len();
        for (&(k, a, b), &v) in self.hessian_entries.iter().zip(hessian) {
            let h = if k < n {
                &mut riccati.stages[k].h
            } else {
                &mut riccati.terminal.h
            };
            h[(a, b)] += v;
            if a != b {
                h[(b, a)] += v;
            }
        }
        for (v, p) in self.places.iter().enumerate() {
            let (h, sh) = if p.stage < n {
                let s = &mut riccati.stages[p.stage];
                (&mut s.h, &mut s.shift)
            } else {
                (&mut riccati.terminal.h, &mut riccati.terminal.shift)
            };
            h[(p.local, p.local)] += diagonal[v];
            sh[p.local] = shift[v];
        }
        for (r, entries) in self.row_entries.iter().enumerate() {
            let sigma = row_weight[r];
            if sigma == 0.0 || entries.is_empty() {
                continue;
            }
            for &e1 in entries {
                let Some((k, a)) = self.other_entries[e1] else {
                    continue;
                };
                let h = if k < n {
                    &mut riccati.stages[k].h
                } else {
                    &mut riccati.terminal.h
                };
                let ja = jacobian[e1] * sigma;
                for &e2 in entries {
                    if let Some((_, b)) = self.other_entries[e2] {
                        h[(a, b)] += ja * jacobian[e2];
                    }
                }
            }
        }
        for (e, entry) in self.dynamics_entries.iter().enumerate() {
            if let Some(DynamicsEntry::Stage { stage, row, local }) = *entry {
                let s = &mut riccati.stages[stage];
                let nz = s.nz();
                if local < nz {
                    s.a[(row, local)] -= jacobian[e];
                } else {
                    s.b[(row, local - nz)] -= jacobian[e];
                }
            }
        }
    }

    /// Fills the vectors of `riccati`: `q` from the condensed gradient (per variable) and
    /// `c = −residual` of every dynamics row.
    pub fn fill_vectors(&self, riccati: &mut Riccati, gradient: &[f64], residual: &[f64]) {
        let n = riccati.stages.len();
        for s in &mut riccati.stages {
            s.q.fill(0.0);
            s.c.fill(0.0);
        }
        riccati.terminal.q.fill(0.0);
        for (v, p) in self.places.iter().enumerate() {
            if p.stage < n {
                riccati.stages[p.stage].q[p.local] = gradient[v];
            } else {
                riccati.terminal.q[p.local] = gradient[v];
            }
        }
        for (r, place) in self.dynamics_rows.iter().enumerate() {
            if let Some((k, i)) = *place {
                riccati.stages[k].c[i] = -residual[r];
            }
        }
    }

    /// Reads the step (per variable) and the new multipliers of the dynamics rows (the
    /// other rows' entries of `multipliers` are left alone) from a solved `riccati`.
    pub fn read_solution(&self, riccati: &Riccati, step: &mut [f64], multipliers: &mut [f64]) {
        for (v, p) in self.places.iter().enumerate() {
            let nz = self.nz[p.stage];
            step[v] = if p.local < nz {
                riccati.z[p.stage][p.local]
            } else {
                riccati.v[p.stage][p.local - nz]
            };
        }
        for (r, place) in self.dynamics_rows.iter().enumerate() {
            if let Some((k, i)) = *place {
                multipliers[r] = -riccati.mu[k][i];
            }
        }
    }
}
