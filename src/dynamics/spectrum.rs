//! Order spectra of periodic responses (docs/MODEL.md §3).
//!
//! A signal sampled uniformly over exactly C mesh cycles (N samples, the
//! last sample one step before the window's end) has its i-th mesh harmonic
//! in FFT bin i·C; the single-sided amplitude is F^(i) = 2|X_{iC}|/N, the
//! mean X_0/N. F^(rms) = sqrt(Σ_{i=1..6} F^(i)²).

use rustfft::{num_complex::Complex, FftPlanner};
use serde::{Deserialize, Serialize};

/// Harmonic content of one periodic signal.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Harmonics {
    /// Mean value.
    pub mean: f64,
    /// Amplitudes of mesh harmonics 1..=count.
    pub amplitude: Vec<f64>,
    /// sqrt(Σ amplitude²) over those harmonics.
    pub rms: f64,
}

/// Errors of the spectral analysis.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SpectrumError {
    /// The window does not hold the requested harmonics.
    #[error("{samples} samples over {cycles} mesh cycles cannot resolve harmonic {order}: need more than {needed} samples")]
    TooFewSamples {
        /// Samples.
        samples: usize,
        /// Cycles.
        cycles: usize,
        /// Highest harmonic requested.
        order: usize,
        /// Samples needed.
        needed: usize,
    },
    /// A sample is NaN or infinite.
    #[error("sample {index} is not finite ({value})")]
    NonFinite {
        /// Index of the sample.
        index: usize,
        /// Its value.
        value: f64,
    },
}

fn spectrum(signal: &[f64]) -> Vec<Complex<f64>> {
    thread_local! {
        // The thread's planner keeps the plans it made: planning a length costs more than
        // the transform itself (an FMU takes a window's spectrum at every step).
        static PLANNER: std::cell::RefCell<FftPlanner<f64>> = std::cell::RefCell::new(FftPlanner::new());
    }
    let mut buf: Vec<Complex<f64>> = signal.iter().map(|x| Complex::new(*x, 0.0)).collect();
    let fft = PLANNER.with(|p| p.borrow_mut().plan_fft_forward(buf.len()));
    fft.process(&mut buf);
    buf
}

fn check(signal: &[f64], cycles: usize, order: usize) -> Result<(), SpectrumError> {
    let needed = 2 * order * cycles;
    if cycles == 0 || signal.len() <= needed {
        return Err(SpectrumError::TooFewSamples { samples: signal.len(), cycles, order, needed });
    }
    if let Some((index, value)) = signal.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(SpectrumError::NonFinite { index, value: *value });
    }
    Ok(())
}

/// Mean and amplitudes of mesh harmonics 1..=`count` of a signal spanning
/// exactly `cycles` mesh cycles.
pub fn mesh_harmonics(signal: &[f64], cycles: usize, count: usize) -> Result<Harmonics, SpectrumError> {
    check(signal, cycles, count)?;
    let x = spectrum(signal);
    let n = signal.len() as f64;
    let amplitude: Vec<f64> = (1..=count).map(|i| 2.0 * x[i * cycles].norm() / n).collect();
    let rms = amplitude.iter().map(|a| a * a).sum::<f64>().sqrt();
    Ok(Harmonics { mean: x[0].re / n, amplitude, rms })
}

/// Phases \[rad\] of mesh harmonics 1..=`count` of a signal spanning exactly
/// `cycles` mesh cycles: the harmonic i is F^(i) cos(i·2π t/T_m + φ_i).
pub fn mesh_phases(signal: &[f64], cycles: usize, count: usize) -> Result<Vec<f64>, SpectrumError> {
    check(signal, cycles, count)?;
    let x = spectrum(signal);
    Ok((1..=count).map(|i| x[i * cycles].arg()).collect())
}

/// The order spectrum: (order, amplitude) for every bin up to `max_order`.
pub fn order_spectrum(
    signal: &[f64],
    cycles: usize,
    max_order: f64,
) -> Result<Vec<(f64, f64)>, SpectrumError> {
    check(signal, cycles, max_order.ceil() as usize)?;
    let x = spectrum(signal);
    let n = signal.len() as f64;
    let top = ((max_order * cycles as f64) as usize).min(signal.len() / 2);
    Ok((1..=top).map(|k| (k as f64 / cycles as f64, 2.0 * x[k].norm() / n)).collect())
}

/// Fraction of samples at which a force is zero (the mesh or pair carries nothing); the
/// samples in a slice, a vector or a ring buffer.
pub fn separation_fraction<'a, I>(force: I) -> f64
where
    I: IntoIterator<Item = &'a f64>,
    I::IntoIter: ExactSizeIterator,
{
    let samples = force.into_iter();
    let n = samples.len();
    if n == 0 {
        return 0.0;
    }
    samples.filter(|f| **f == 0.0).count() as f64 / n as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn amplitudes_of_a_synthetic_signal() {
        let cycles = 7;
        let n = 7 * 64;
        let signal: Vec<f64> = (0..n)
            .map(|k| {
                let phase = 2.0 * std::f64::consts::PI * cycles as f64 * k as f64 / n as f64;
                3.0 + 2.0 * phase.cos() + 0.5 * (3.0 * phase + 0.4).sin() + 0.1 * (6.0 * phase).cos()
            })
            .collect();
        let h = mesh_harmonics(&signal, cycles, 6).unwrap();
        assert!((h.mean - 3.0).abs() < 1e-12);
        let expect = [2.0, 0.0, 0.5, 0.0, 0.0, 0.1];
        for (a, e) in h.amplitude.iter().zip(expect) {
            assert!((a - e).abs() < 1e-12, "{a} vs {e}");
        }
        assert!((h.rms - (4.0f64 + 0.25 + 0.01).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn too_few_samples_and_non_finite_are_errors() {
        assert!(matches!(mesh_harmonics(&[0.0; 10], 2, 6), Err(SpectrumError::TooFewSamples { .. })));
        let mut s = vec![0.0; 100];
        s[3] = f64::NAN;
        assert!(matches!(mesh_harmonics(&s, 1, 6), Err(SpectrumError::NonFinite { index: 3, .. })));
    }

    #[test]
    fn separation_fraction_counts_zero_force() {
        assert_eq!(separation_fraction(&[0.0, 1.0, 2.0, 0.0]), 0.5);
    }
}
