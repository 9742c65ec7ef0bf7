//! Time integrators for second-order systems (interface; the integrators
//! land in this module).

/// A second-order system M q'' = f(t, q, q') with a constant diagonal mass matrix.
pub trait SecondOrderSystem {
    /// Number of degrees of freedom.
    fn dim(&self) -> usize;
    /// Diagonal of the mass matrix (positive) [kg or kg·m², per coordinate].
    fn mass(&self) -> &[f64];
    /// Total generalised force f(t, q, v) (external minus internal minus damping) into `f`.
    fn force(&mut self, t: f64, q: &[f64], v: &[f64], f: &mut [f64]);
    /// Tangent stiffness K = −∂f/∂q and damping C = −∂f/∂v at (t, q, v), with the
    /// piecewise (contact) status taken at (t, q, v) and frozen (exact piecewise Jacobian).
    fn jacobian(
        &mut self,
        t: f64,
        q: &[f64],
        v: &[f64],
        k: &mut nalgebra::DMatrix<f64>,
        c: &mut nalgebra::DMatrix<f64>,
    );
    /// Event functions: their zero crossings mark switches of the piecewise force
    /// (a tooth pair starting or ending contact). Default: none.
    fn events(&mut self, _t: f64, _q: &[f64], _v: &[f64], _out: &mut Vec<f64>) {}
}
