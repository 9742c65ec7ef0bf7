//! The Fourier series of the harmonic balance: rustfft's plans, and the samples of a
//! series of H harmonics and the coefficients of N samples (docs/PERIODIC.md §2).

use std::cell::RefCell;
use std::sync::Arc;

use rustfft::{num_complex::Complex, Fft, FftPlanner};

/// rustfft's forward and inverse plans of one length, with their scratch
/// (`Fft::process` allocates it at every call otherwise).
pub(super) struct Plans {
    forward: Arc<dyn Fft<f64>>,
    inverse: Arc<dyn Fft<f64>>,
    scratch: RefCell<Vec<Complex<f64>>>,
}

impl Plans {
    /// The plans of length `samples`.
    pub(super) fn new(samples: usize) -> Self {
        let mut planner = FftPlanner::new();
        let (forward, inverse) = (planner.plan_fft_forward(samples), planner.plan_fft_inverse(samples));
        let len = forward.get_inplace_scratch_len().max(inverse.get_inplace_scratch_len());
        Self { forward, inverse, scratch: RefCell::new(vec![Complex::new(0.0, 0.0); len]) }
    }

    /// The forward transform of `buffer` in place.
    pub(super) fn forward(&self, buffer: &mut [Complex<f64>]) {
        self.forward.process_with_scratch(buffer, &mut self.scratch.borrow_mut());
    }

    /// The inverse transform of `buffer` in place.
    pub(super) fn inverse(&self, buffer: &mut [Complex<f64>]) {
        self.inverse.process_with_scratch(buffer, &mut self.scratch.borrow_mut());
    }

    /// The same plans with scratch of their own.
    pub(super) fn share(&self) -> Self {
        let scratch = RefCell::new(vec![Complex::new(0.0, 0.0); self.scratch.borrow().len()]);
        Self { forward: Arc::clone(&self.forward), inverse: Arc::clone(&self.inverse), scratch }
    }

    /// The samples' length.
    pub(super) fn len(&self) -> usize {
        self.forward.len()
    }
}

/// N = `plans`' length samples of a series of H = `harmonics` harmonics: `coefficient(c)`
/// gives its entry of coefficient block c, `out` receives the N values y(t_j).
pub(super) fn synthesize_with(
    plans: &Plans,
    harmonics: usize,
    coefficient: impl Fn(usize) -> f64,
    buffer: &mut [Complex<f64>],
    out: &mut [f64],
) {
    let n = plans.len();
    buffer.iter_mut().for_each(|z| *z = Complex::new(0.0, 0.0));
    buffer[0] = Complex::new(coefficient(0), 0.0);
    for k in 1..=harmonics {
        let (a, b) = (coefficient(2 * k - 1), coefficient(2 * k));
        let z = Complex::new(0.5 * a, -0.5 * b);
        buffer[k] += z;
        buffer[n - k] += z.conj();
    }
    plans.inverse(buffer);
    for (o, z) in out.iter_mut().zip(buffer.iter()) {
        *o = z.re;
    }
}

/// Coefficient block `c` of the time derivative of the series whose blocks `coefficient`
/// gives, at ν = `nu` \[rad/s\]: a_k → k ν b_k, b_k → −k ν a_k, the constant 0.
pub(super) fn derivative_coefficient(coefficient: impl Fn(usize) -> f64, c: usize, nu: f64) -> f64 {
    let k = c.div_ceil(2) as f64;
    match c {
        0 => 0.0,
        c if c % 2 == 1 => k * nu * coefficient(c + 1),
        c => -k * nu * coefficient(c - 1),
    }
}

/// The first 2H + 1 Fourier coefficients (a₀, a_k, b_k) of N = `plans`' length samples
/// `values` of one quantity.
pub(super) fn analyse_with(
    plans: &Plans,
    harmonics: usize,
    values: &[f64],
    buffer: &mut [Complex<f64>],
    out: &mut [f64],
) {
    let ns = plans.len();
    for (z, v) in buffer.iter_mut().zip(values) {
        *z = Complex::new(*v, 0.0);
    }
    plans.forward(buffer);
    let scale = 1.0 / ns as f64;
    out[0] = buffer[0].re * scale;
    for k in 1..=harmonics {
        out[2 * k - 1] = 2.0 * buffer[k].re * scale;
        out[2 * k] = -2.0 * buffer[k].im * scale;
    }
}
