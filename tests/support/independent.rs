//! The independent integrator that confirms the work-precision reference:
//! DOP853 (Dormand & Prince's explicit Runge–Kutta 8(5,3) with its
//! seventh-order dense output, Hairer, Nørsett & Wanner, *Solving ODEs I*,
//! §II.10) from the `differential-equations` crate, a code of its own: its
//! own step control and interpolant, no contact-event location (it meets the
//! contact switches by step rejection alone). Shared by tests/accuracy.rs and
//! benches/work_precision.rs.

use std::cell::RefCell;

use differential_equations::prelude::{ExplicitRungeKutta, IVP, ODE};
use planetwear::analysis::accuracy::{IndependentIntegrator, IndependentSolution};
use planetwear::dynamics::solver::SecondOrderSystem;

/// DOP853 at a relative tolerance; absolute tolerances scaled as the
/// reference's (1e-6 m and 1e-3 m/s per unit of relative tolerance).
pub struct Dop853 {
    /// Relative tolerance [1].
    pub rtol: f64,
}

/// y = [q, v], y' = [v, M⁻¹ f(t, q, v)].
struct FirstOrder<'a> {
    sys: RefCell<&'a mut dyn SecondOrderSystem>,
    mass: Vec<f64>,
    force: RefCell<Vec<f64>>,
}

impl ODE<f64, Vec<f64>> for FirstOrder<'_> {
    fn diff(&self, t: f64, y: &Vec<f64>, dydt: &mut Vec<f64>) {
        let n = self.mass.len();
        let (q, v) = y.split_at(n);
        let mut f = self.force.borrow_mut();
        self.sys.borrow_mut().force(t, q, v, &mut f);
        dydt[..n].copy_from_slice(v);
        for i in 0..n {
            dydt[n + i] = f[i] / self.mass[i];
        }
    }
}

impl IndependentIntegrator for Dop853 {
    fn name(&self) -> String {
        format!("DOP853 (differential-equations 0.7) rtol {:e}", self.rtol)
    }

    fn solve(
        &self,
        sys: &mut dyn SecondOrderSystem,
        q0: &[f64],
        v0: &[f64],
        times: &[f64],
    ) -> Result<IndependentSolution, String> {
        let n = q0.len();
        let mass = sys.mass().to_vec();
        let t_end = *times.last().ok_or("no output times")?;
        let mut y0 = q0.to_vec();
        y0.extend_from_slice(v0);
        let mut atol = vec![self.rtol * 1e-6; n];
        atol.extend(vec![self.rtol * 1e-3; n]);
        let ode = FirstOrder { sys: RefCell::new(sys), mass, force: RefCell::new(vec![0.0; n]) };
        let method = ExplicitRungeKutta::dop853().rtol(self.rtol).atol(atol).max_steps(usize::MAX);
        let solution = IVP::ode(&ode, 0.0, t_end, y0)
            .t_eval(times)
            .method(method)
            .solve()
            .map_err(|e| format!("{e:?}"))?;
        if solution.t.len() != times.len() {
            return Err(format!("{} outputs for {} times", solution.t.len(), times.len()));
        }
        let q = solution.y.iter().map(|y| y[..n].to_vec()).collect();
        let v = solution.y.iter().map(|y| y[n..].to_vec()).collect();
        Ok(IndependentSolution {
            q,
            v,
            steps: solution.steps.accepted as u64,
            rhs_evaluations: solution.evals.function as u64,
        })
    }
}
