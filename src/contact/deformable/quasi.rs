//! Quasi-static results of the deformable mesh law at a given mesh load:
//! the loaded static transmission error over a mesh cycle, the load sharing
//! of the pairs, the share of the cycle with two pairs loaded, the loaded
//! contact ratio, the separations of the open pairs and the Hertzian band of
//! every loaded pair. The same quantities, found the same way, as the pair
//! model's ([`crate::contact::ltca::MeshModel::approach_for`],
//! [`crate::contact::ltca::MeshModel::loaded_engagement`],
//! [`crate::contact::ltca::mesh_ltca`]).

use crate::contact::deformable::law::{check_finite, DeformableError, DeformableMesh, DeformableState};
use crate::contact::ltca::{loaded_span, try_solve_increasing, Refine};

/// Quasi-static analysis of one mesh over one mesh cycle at a constant load.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DeformableLtca {
    /// Load along the line of action \[N\].
    pub load: f64,
    /// Reference-pair positions over one cycle \[m\].
    pub position: Vec<f64>,
    /// Loaded static transmission error: the approach along the line of action \[m\].
    pub transmission_error: Vec<f64>,
    /// Tangent mesh stiffness ∂F/∂δ [N/m].
    pub mesh_stiffness: Vec<f64>,
    /// Every candidate pair at each position: forces, gaps, separations, Hertz bands.
    pub states: Vec<DeformableState>,
}

impl DeformableLtca {
    /// Loaded pairs at each position.
    pub fn pairs_in_contact(&self) -> Vec<usize> {
        self.states.iter().map(DeformableState::loaded).collect()
    }

    /// Loaded contact ratio sampled over the cycle: the mean number of loaded pairs [-].
    pub fn loaded_contact_ratio(&self) -> f64 {
        let n = self.pairs_in_contact();
        n.iter().sum::<usize>() as f64 / n.len().max(1) as f64
    }

    /// Fraction of the sampled cycle with `n` or more pairs loaded [-].
    pub fn fraction_with_at_least(&self, n: usize) -> f64 {
        let k = self.pairs_in_contact();
        k.iter().filter(|v| **v >= n).count() as f64 / k.len().max(1) as f64
    }

    /// Mean tangent mesh stiffness over the cycle [N/m].
    pub fn mean_stiffness(&self) -> f64 {
        self.mesh_stiffness.iter().sum::<f64>() / self.mesh_stiffness.len().max(1) as f64
    }
}

impl DeformableMesh {
    /// Approach \[m\] at which the mesh carries `load` \[N\] with the reference
    /// pair at `s` \[m\]: safeguarded Newton on the non-decreasing F(δ), to
    /// 1e-13 relative in δ.
    pub fn approach_for(&self, s: f64, load: f64) -> Result<f64, DeformableError> {
        check_finite("load", load)?;
        let f = |d: f64| self.solve(s, d).map(|st| (st.law.force, st.law.approach_stiffness));
        try_solve_increasing(f, load, 0.0, 300).map_err(|(e, x)| match e {
            Some(e) => e,
            None => DeformableError::LoadNotReached { load, approach: x },
        })
    }

    /// The quasi-static analysis at `load` \[N\] over one mesh cycle at
    /// `samples` positions.
    pub fn ltca(&self, load: f64, samples: usize) -> Result<DeformableLtca, DeformableError> {
        let p = self.path().clone();
        let mut out = DeformableLtca { load, ..DeformableLtca::default() };
        for i in 0..samples {
            let s = p.start + p.base_pitch * i as f64 / samples as f64;
            let delta = self.approach_for(s, load)?;
            let state = self.solve(s, delta)?;
            out.position.push(s);
            out.transmission_error.push(delta);
            out.mesh_stiffness.push(state.law.approach_stiffness);
            out.states.push(state);
        }
        Ok(out)
    }

    /// First and last position \[m\] at which one tooth pair carries load
    /// while the mesh transmits `load` \[N\]: the scan and bisection of
    /// [`crate::contact::ltca::MeshModel::loaded_engagement`].
    pub fn loaded_engagement(&self, load: f64) -> Result<(f64, f64), DeformableError> {
        let p = self.path().clone();
        let pb = p.base_pitch;
        let mut error = None;
        let loaded = |s: f64| {
            let r = self.approach_for(s, load).and_then(|d| self.solve(s, d));
            match r {
                Ok(state) => state.pair_force(0) > 0.0,
                Err(e) => {
                    error.get_or_insert(e);
                    false
                }
            }
        };
        let (lo, hi) = (p.start.min(p.start_sharp) - pb, p.end.max(p.end_sharp) + pb);
        let span = loaded_span(lo, hi, 400, loaded, Refine::Width(1e-12 * pb)).unwrap_or((p.start, p.end));
        match error {
            Some(e) => Err(e),
            None => Ok(span),
        }
    }

    /// Loaded contact ratio at `load` \[N\]: the loaded engagement over the base pitch [-].
    pub fn loaded_contact_ratio(&self, load: f64) -> Result<f64, DeformableError> {
        let (a, b) = self.loaded_engagement(load)?;
        Ok((b - a) / self.path().base_pitch)
    }

    /// Share of the mesh cycle with two or more pairs loaded at `load` \[N\] [-].
    pub fn double_contact_share(&self, load: f64) -> Result<f64, DeformableError> {
        Ok((self.loaded_contact_ratio(load)? - 1.0).clamp(0.0, 1.0))
    }
}
